"""Figures (pcgeom.apps.plot): valid PNGs, written atomically, bad input rejected."""

from __future__ import annotations

import numpy as np
import pytest

from pcgeom.apps.plot import plot_angle_histogram, plot_domain, plot_history, plot_map
from pcgeom.domains import Disk, FreeBoundary, Smile

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _assert_png(path) -> None:
    """``path`` is a decodable PNG of non-trivial size, and nothing else is in its directory."""
    import matplotlib.image

    assert path.read_bytes()[:8] == PNG_SIGNATURE
    img = matplotlib.image.imread(path)
    assert img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100
    assert sorted(p.name for p in path.parent.iterdir()) == [path.name]  # no temp file left


def _history() -> list[dict]:
    return [
        {"stage": 1, "kind": "leg", "leg": 0.3, "hand": 0.0, "landmarks": 0.0, "total": 0.3},
        {"stage": 2, "kind": "leg", "leg": 0.1, "hand": 0.0, "landmarks": 0.0, "total": 0.1},
        {"stage": 3, "kind": "leg", "leg": 0.05, "hand": 0.0, "landmarks": 0.0, "total": 0.05},
    ]


def test_plot_map_with_values_and_domain(tmp_path):
    rng = np.random.default_rng(0)
    uv = Disk().sample(500)
    path = plot_map(uv, tmp_path / "map.png", values=rng.uniform(0.5, 2.0, 500),
                    domain=Disk(), title="disk")
    assert path == tmp_path / "map.png"
    _assert_png(path)


def test_plot_map_plain(tmp_path):
    uv = np.random.default_rng(1).normal(size=(50, 2))
    _assert_png(plot_map(uv, tmp_path / "plain.png"))


def test_plot_map_draws_red_domain_boundary(tmp_path):
    """The domain boundary is drawn in red: the picture has red pixels only when it is given."""
    import matplotlib.image

    uv = Disk().sample(200) * 0.5

    def red_pixels(path):
        img = matplotlib.image.imread(path)[..., :3]
        return int(((img[..., 0] > 0.9) & (img[..., 1] < 0.2) & (img[..., 2] < 0.2)).sum())

    plot_map(uv, tmp_path / "with.png", domain=Disk())
    plot_map(uv, tmp_path / "without.png")
    assert red_pixels(tmp_path / "with.png") > 100
    assert red_pixels(tmp_path / "without.png") == 0


def _red_pixels(path) -> int:
    import matplotlib.image

    img = matplotlib.image.imread(path)[..., :3]
    return int(((img[..., 0] > 0.9) & (img[..., 1] < 0.2) & (img[..., 2] < 0.2)).sum())


def test_plot_map_draws_every_boundary_loop(tmp_path):
    """The smiling face's eyes and mouth are drawn too: its loops are 1.7x the circle's length."""
    uv = Disk().sample(200) * 0.5
    plot_map(uv, tmp_path / "disk.png", domain=Disk())
    plot_map(uv, tmp_path / "smile.png", domain=Smile())
    assert _red_pixels(tmp_path / "smile.png") > 1.3 * _red_pixels(tmp_path / "disk.png")


def test_plot_domain(tmp_path):
    path = plot_domain(Smile(), tmp_path / "smile.png", n=500)
    assert path == tmp_path / "smile.png"
    _assert_png(path)
    assert _red_pixels(path) > 100


def test_plot_domain_rejects_bad_input(tmp_path):
    with pytest.raises(ValueError, match="domain 'free' has no region to draw"):
        plot_domain(FreeBoundary(), tmp_path / "free.png")
    with pytest.raises(ValueError, match="n: expected a positive count, got 0"):
        plot_domain(Disk(), tmp_path / "disk.png", n=0)
    with pytest.raises(ValueError, match="expected extension '.png', got '.jpg'"):
        plot_domain(Disk(), tmp_path / "disk.jpg")
    assert list(tmp_path.iterdir()) == []


def test_plot_map_overwrites_existing_file(tmp_path):
    path = tmp_path / "map.png"
    path.write_bytes(b"old")
    plot_map(np.eye(2), path)
    _assert_png(path)


@pytest.mark.parametrize(
    "uv, values, match",
    [
        (np.zeros((5, 3)), None, r"U: expected shape \(N, 2\) with N >= 1, got \(5, 3\)"),
        (np.zeros((0, 2)), None, r"U: expected shape \(N, 2\) with N >= 1, got \(0, 2\)"),
        (np.array([[0.0, np.nan], [1.0, 1.0]]), None, "U: contains NaN or inf"),
        (np.zeros((5, 2)), np.zeros(4), r"values: expected shape \(5,\), got \(4,\)"),
    ],
)
def test_plot_map_rejects_bad_input(tmp_path, uv, values, match):
    with pytest.raises(ValueError, match=match):
        plot_map(uv, tmp_path / "map.png", values=values)
    assert list(tmp_path.iterdir()) == []


def test_plot_rejects_wrong_extension(tmp_path):
    with pytest.raises(ValueError, match=r"expected extension '\.png', got '\.jpg'"):
        plot_map(np.eye(2), tmp_path / "map.jpg")
    assert list(tmp_path.iterdir()) == []


def test_plot_history(tmp_path):
    _assert_png(plot_history(_history(), tmp_path / "history.png"))


def test_plot_history_all_zero_terms(tmp_path):
    """Zero losses cannot go on a log axis; the figure is still written."""
    rows = [{"stage": 1, "leg": 0.0, "hand": 0.0, "landmarks": 0.0, "total": 0.0}]
    _assert_png(plot_history(rows, tmp_path / "history.png"))


def test_plot_history_rejects_empty(tmp_path):
    with pytest.raises(ValueError, match="history: expected at least one stage, got none"):
        plot_history([], tmp_path / "history.png")
    with pytest.raises(ValueError, match="history: stage 0 is a list, expected a dict"):
        plot_history([[1.0]], tmp_path / "history.png")
    assert list(tmp_path.iterdir()) == []


def test_plot_angle_histogram(tmp_path):
    per_corner = np.abs(np.random.default_rng(2).normal(0.0, 0.05, size=(300, 3)))
    _assert_png(plot_angle_histogram(per_corner, tmp_path / "angles.png"))


def test_plot_angle_histogram_rejects_bad_input(tmp_path):
    with pytest.raises(ValueError, match="per_corner: expected at least one value, got none"):
        plot_angle_histogram(np.zeros((0, 3)), tmp_path / "angles.png")
    with pytest.raises(ValueError, match="per_corner: contains NaN or inf"):
        plot_angle_histogram(np.array([0.1, np.inf]), tmp_path / "angles.png")
    with pytest.raises(ValueError, match="bins: expected a positive int, got 0"):
        plot_angle_histogram(np.array([0.1, 0.2]), tmp_path / "angles.png", bins=0)
    assert list(tmp_path.iterdir()) == []


def test_failed_render_leaves_no_temp_file(tmp_path, monkeypatch):
    """An exception while saving removes the temporary file and keeps the old output."""
    from matplotlib.figure import Figure

    path = tmp_path / "map.png"
    path.write_bytes(b"old")

    def broken_savefig(self, fname, **kwargs):
        fname.write(b"partial")  # a file object: the temporary file beside path
        raise RuntimeError("disk full")

    monkeypatch.setattr(Figure, "savefig", broken_savefig)
    with pytest.raises(RuntimeError, match="disk full"):
        plot_map(np.eye(2), path)
    assert path.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["map.png"]
