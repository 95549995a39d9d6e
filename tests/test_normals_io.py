"""Per-point normals in and out of files (pcgeom.io.read_points, write_ply_atomic).

Every format that can carry normals is read with and without them; every bad-normals message
reaches the user through ``read_points``. The array checks themselves
(``pcgeom.cloud.validate_normals``) are tested in test_cloud.py.
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

import pcgeom.maps.run as run_module
from pcgeom import parametrize
from pcgeom.examples import peaks_surface
from pcgeom.io import InputError, PointCloud, read_points, save_npz_atomic, write_ply_atomic

from tests.helpers import tiny_preset


def _cloud() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A saddle patch on a 6 x 5 grid, its faces, and one normal per row of any length.

    The normals are random, not the saddle's, so that a reader that computes its own normals
    (trimesh does, from faces) or reorders rows shows up.
    """
    x, y = np.meshgrid(np.linspace(-0.7, 0.9, 6), np.linspace(-0.3, 1.1, 5), indexing="xy")
    V = np.column_stack([x.ravel(), y.ravel(), (x**2 - y**2).ravel()]) * np.pi  # (30, 3)
    idx = np.arange(30).reshape(5, 6)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    F = np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])  # (40, 3)
    rng = np.random.default_rng(11)
    N = rng.normal(size=(30, 3)) * rng.uniform(0.5, 3.0, size=(30, 1))  # (30, 3), not unit
    return V, F, N


def _unit(N: np.ndarray) -> np.ndarray:
    return N / np.linalg.norm(N, axis=1, keepdims=True)


def _fmt(row) -> str:
    return " ".join(f"{float(v):.17g}" for v in row)  # 17 digits: exact float64 round trip


def _ascii_ply(path, V, N=None, names=("nx", "ny", "nz"), dtype="double", F=None) -> None:
    props = ["x", "y", "z"] + (list(names) if N is not None else [])
    header = ["ply", "format ascii 1.0", f"element vertex {len(V)}"]
    header += [f"property {dtype} {p}" for p in props]
    if F is not None:
        header += [f"element face {len(F)}", "property list uchar int vertex_indices"]
    rows = V if N is None else np.hstack([V, N])
    body = "".join(_fmt(r) + "\n" for r in rows)
    if F is not None:
        body += "".join("3 %d %d %d\n" % tuple(f) for f in F)
    path.write_text("\n".join(header) + "\nend_header\n" + body)


# --------------------------------------------------------------------------- PointCloud


def test_point_cloud_normals_is_the_last_field_and_defaults_to_none():
    V, _, N = _cloud()
    assert [f.name for f in dataclasses.fields(PointCloud)] == [
        "points", "faces", "source", "normals"]
    assert PointCloud(V, None, "a.ply").normals is None  # positional constructors still work
    np.testing.assert_allclose(PointCloud(V, None, "a.ply", normals=N).normals,
                               N / np.linalg.norm(N, axis=1, keepdims=True), rtol=0, atol=1e-15)


def test_point_cloud_is_checked_when_built_and_parametrize_takes_it_as_it_is(monkeypatch):
    """A PointCloud is checked once, when built (messages name its source); parametrize takes
    one without checking it again and gives the map of its points and normals."""
    V, _, N = _cloud()
    with pytest.raises(InputError, match=r"^a\.ply: 3 points, need at least 10$"):
        PointCloud(V[:3], None, "a.ply")
    with pytest.raises(InputError, match=r"^a\.ply: faces reference vertex indices 0\.\.30 "
                                         r"but there are 30 points$"):
        PointCloud(V, np.array([[0, 1, 30]]), "a.ply")
    with pytest.raises(InputError, match=r"^a\.ply: 29 normals for 30 points$"):
        PointCloud(V, None, "a.ply", N[:-1])
    with pytest.raises(InputError, match=r"^a\.ply: 9 points, need at least 10$"):
        PointCloud(V[:9], None, "a.ply", min_points=10)
    assert len(PointCloud(V[:9], None, "a.ply", min_points=4).points) == 9
    peaks, _ = peaks_surface("peaks3", n_side=16)
    normals = np.tile([0.0, 0.0, 2.0], (len(peaks), 1))
    cloud = PointCloud(peaks, None, "peaks", normals)
    config = tiny_preset("fast")
    from_arrays = parametrize(peaks, config=config, normals=normals, progress=False)
    monkeypatch.setattr(run_module, "validate_points", lambda *a, **k: pytest.fail("checked"))
    from_cloud = parametrize(cloud, config=config, progress=False)
    np.testing.assert_array_equal(from_cloud.uv, from_arrays.uv)
    assert from_cloud.history[0]["normals"] == "input"


# --------------------------------------------------------------------------- PLY


@pytest.mark.parametrize("with_faces", [True, False])
def test_ply_writer_round_trips_normals(tmp_path, with_faces):
    V, F, N = _cloud()
    F = F if with_faces else None
    write_ply_atomic(tmp_path / "n.ply", V, F, normals=N)
    pc = read_points(tmp_path / "n.ply")
    np.testing.assert_array_equal(pc.points, V)
    assert pc.normals.dtype == np.float64 and pc.normals.shape == (30, 3)
    np.testing.assert_allclose(pc.normals, _unit(N), rtol=0, atol=1e-12)
    if with_faces:
        np.testing.assert_array_equal(pc.faces, F)
    else:
        assert pc.faces is None


def test_ply_writer_header_names_double_normals(tmp_path):
    V, _, N = _cloud()
    write_ply_atomic(tmp_path / "n.ply", V, normals=N)
    header = (tmp_path / "n.ply").read_bytes().split(b"end_header\n", 1)[0].decode()
    assert "property double nx\nproperty double ny\nproperty double nz" in header
    write_ply_atomic(tmp_path / "p.ply", V)
    assert b"nx" not in (tmp_path / "p.ply").read_bytes().split(b"end_header\n", 1)[0]


def test_ply_mesh_without_normals_gets_none_not_computed_ones(tmp_path):
    # trimesh computes vertex normals from faces on demand; those are not the file's.
    V, F, _ = _cloud()
    write_ply_atomic(tmp_path / "m.ply", V, F)
    _ascii_ply(tmp_path / "a.ply", V, F=F)
    assert read_points(tmp_path / "m.ply").normals is None
    assert read_points(tmp_path / "a.ply").normals is None


@pytest.mark.parametrize("dtype, atol", [("double", 1e-15), ("float", 1e-6)])
def test_ascii_ply_point_cloud_normals(tmp_path, dtype, atol):
    V, _, N = _cloud()
    _ascii_ply(tmp_path / "a.ply", V, N, dtype=dtype)
    pc = read_points(tmp_path / "a.ply")
    assert pc.faces is None
    np.testing.assert_allclose(pc.normals, _unit(N), rtol=0, atol=atol)


def test_binary_ply_mesh_with_pcl_names_and_extra_properties(tmp_path):
    V, F, N = _cloud()
    fields = ["x", "y", "z", "red", "normal_x", "normal_y", "normal_z", "curvature"]
    types = ["<f8", "<f8", "<f8", "u1", "<f4", "<f4", "<f4", "<f4"]
    rows = np.zeros(len(V), dtype=list(zip(fields, types)))
    rows["x"], rows["y"], rows["z"] = V.T
    rows["normal_x"], rows["normal_y"], rows["normal_z"] = N.T
    rows["red"], rows["curvature"] = 200, 0.25
    ply_types = {"<f8": "double", "<f4": "float", "u1": "uchar"}
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(V)}"]
    header += [f"property {ply_types[t]} {n}" for n, t in zip(fields, types)]
    header += [f"element face {len(F)}", "property list uchar int vertex_indices", "end_header\n"]
    faces = np.empty(len(F), dtype=[("n", "u1"), ("v", "<i4", (3,))])
    faces["n"], faces["v"] = 3, F
    (tmp_path / "b.ply").write_bytes("\n".join(header).encode() + rows.tobytes()
                                      + faces.tobytes())
    pc = read_points(tmp_path / "b.ply")
    np.testing.assert_array_equal(pc.points, V)
    np.testing.assert_array_equal(pc.faces, F)
    np.testing.assert_allclose(pc.normals, _unit(N.astype(np.float32).astype(np.float64)),
                               rtol=0, atol=1e-15)


def test_ply_zero_length_normal(tmp_path):
    V, _, N = _cloud()
    N[2] = 0.0
    N[7] = 0.0
    _ascii_ply(tmp_path / "z.ply", V, N)
    match = re.escape(f"{tmp_path / 'z.ply'}: normal of row 2 has zero length (2 such rows)")
    with pytest.raises(InputError, match=match):
        read_points(tmp_path / "z.ply")


def test_ply_incomplete_normals(tmp_path):
    V, _, N = _cloud()
    _ascii_ply(tmp_path / "i.ply", V, N[:, :2], names=("nx", "ny"))
    with pytest.raises(InputError, match=r"i\.ply: incomplete normals: has nx, ny but no nz"):
        read_points(tmp_path / "i.ply")


def test_ply_two_sets_of_normals(tmp_path):
    V, _, N = _cloud()
    _ascii_ply(tmp_path / "t.ply", V, np.hstack([N, N]),
               names=("nx", "ny", "nz", "normal_x", "normal_y", "normal_z"))
    with pytest.raises(InputError,
                       match=r"t\.ply: two sets of normals \(nx/ny/nz and normal_x/normal_y/"
                             r"normal_z\); keep one"):
        read_points(tmp_path / "t.ply")


def test_off_and_obj_normals_are_not_read(tmp_path):
    V, F, _ = _cloud()
    text = f"OFF\n{len(V)} {len(F)} 0\n" + "".join(_fmt(v) + "\n" for v in V)
    (tmp_path / "m.off").write_text(text + "".join("3 %d %d %d\n" % tuple(f) for f in F))
    (tmp_path / "m.obj").write_text("".join(f"v {_fmt(v)}\n" for v in V) + "vn 0 0 1\n")
    assert read_points(tmp_path / "m.off").normals is None
    assert read_points(tmp_path / "m.obj").normals is None


# --------------------------------------------------------------------------- NPZ


@pytest.mark.parametrize("point_key", ["points", "V", "anything"])
def test_npz_normals(tmp_path, point_key):
    V, F, N = _cloud()
    # "anything": the single-array fallback must not take the normals for the points.
    save_npz_atomic(tmp_path / "n.npz", **{point_key: V}, faces=F, normals=N)
    pc = read_points(tmp_path / "n.npz")
    np.testing.assert_array_equal(pc.points, V)
    np.testing.assert_array_equal(pc.faces, F)
    np.testing.assert_allclose(pc.normals, _unit(N), rtol=0, atol=1e-15)
    save_npz_atomic(tmp_path / "p.npz", V=V, N=N)  # only "normals" names normals
    assert read_points(tmp_path / "p.npz").normals is None


def test_npz_with_only_normals_has_no_point_array(tmp_path):
    _, _, N = _cloud()
    np.savez(tmp_path / "n.npz", normals=N)
    with pytest.raises(InputError, match=r"n\.npz: no point array; .* found: normals"):
        read_points(tmp_path / "n.npz")


@pytest.mark.parametrize(
    "bad, match",
    [
        (lambda N: N[:-1], "29 normals for 30 points"),
        (lambda N: N[:, :2], re.escape("expected normals of shape (N, 3), got (30, 2)")),
        (lambda N: N.astype(str), "normals must be numbers, got dtype <U"),
    ],
)
def test_npz_bad_normals(tmp_path, bad, match):
    V, _, N = _cloud()
    np.savez(tmp_path / "b.npz", points=V, normals=bad(N))
    with pytest.raises(InputError, match=re.escape(f"{tmp_path / 'b.npz'}: ") + match):
        read_points(tmp_path / "b.npz")


# --------------------------------------------------------------------------- tables


@pytest.mark.parametrize(
    "name, sep, header",
    [
        ("n.xyz", " ", ""),
        ("n.txt", "\t", "# x y z nx ny nz, no header row: a comment\n"),
        ("n.csv", ",", "x,y,z,nx,ny,nz\n"),
        ("m.csv", ", ", "X, Y, Z, Normal_X, Normal_Y, Normal_Z\n"),
    ],
)
def test_table_with_six_columns_has_normals(tmp_path, name, sep, header):
    V, _, N = _cloud()
    if not header.startswith("x") and not header.startswith("X"):
        N = _unit(N)  # a headerless table's columns 4-6 are normals only when unit vectors
    lines = [sep.join(f"{float(c):.17g}" for c in row) for row in np.hstack([V, N])]
    (tmp_path / name).write_text(header + "\n".join(lines) + "\n")
    pc = read_points(tmp_path / name)
    np.testing.assert_array_equal(pc.points, V)
    np.testing.assert_allclose(pc.normals, _unit(N), rtol=0, atol=1e-15)


def test_table_header_locates_normal_columns(tmp_path):
    V, _, N = _cloud()
    table = np.column_stack([V, np.arange(30), N[:, 2], N[:, 1], N[:, 0]])  # (30, 7)
    text = "x y z intensity nz ny nx\n" + "".join(_fmt(r) + "\n" for r in table)
    (tmp_path / "h.txt").write_text(text)
    pc = read_points(tmp_path / "h.txt")
    np.testing.assert_array_equal(pc.points, V)
    np.testing.assert_allclose(pc.normals, _unit(N), rtol=0, atol=1e-15)


@pytest.mark.parametrize(
    "header, width",
    [
        ("", 4),  # x y z + one extra column
        ("", 7),  # widths other than 6 keep extra columns ignored
        ("x y z r g b\n", 6),  # a header that names no normals: columns 4-6 are not normals
    ],
)
def test_table_without_normals(tmp_path, header, width):
    V, _, _ = _cloud()
    extra = np.tile([0.0, 255.0, 7.0, 1.0], (30, 1))[:, : width - 3]  # zero rows: not normals
    text = header + "".join(_fmt(r) + "\n" for r in np.hstack([V, extra]))
    (tmp_path / "c.txt").write_text(text)
    pc = read_points(tmp_path / "c.txt")
    np.testing.assert_array_equal(pc.points, V)
    assert pc.normals is None


def test_table_nan_normal(tmp_path):
    V, _, N = _cloud()
    lines = [_fmt(r) for r in np.hstack([V, N])]
    lines[4] = _fmt(V[4]) + " 0 nan 1"
    (tmp_path / "n.xyz").write_text("\n".join(lines) + "\n")
    match = re.escape(f"{tmp_path / 'n.xyz'}: normal of row 4 contains NaN or inf")
    with pytest.raises(InputError, match=match):
        read_points(tmp_path / "n.xyz")


def test_table_header_width_must_match_rows_when_it_names_normals(tmp_path):
    V, _, N = _cloud()
    text = "x y z nx ny nz\n" + "".join(_fmt(r) + " 1\n" for r in np.hstack([V, N]))
    (tmp_path / "w.csv").write_text(text)
    with pytest.raises(InputError, match=r"w\.csv: header names 6 columns but rows have 7"):
        read_points(tmp_path / "w.csv")


def test_table_incomplete_normals_in_header(tmp_path):
    V, _, N = _cloud()
    text = "x,y,z,nx,nz\n" + "".join(_fmt(r).replace(" ", ",") + "\n"
                                     for r in np.hstack([V, N[:, :2]]))
    (tmp_path / "i.csv").write_text(text)
    with pytest.raises(InputError, match=r"i\.csv: incomplete normals: has nx, nz but no ny"):
        read_points(tmp_path / "i.csv")


def test_normals_false_reads_a_colour_table(tmp_path):
    # x y z r g b without a header: the colours are not unit vectors, so not normals (issue
    # 39: they were read as normals and the map turned over 1.92% of its mesh); one warning.
    V, _, _ = _cloud()
    rgb = np.tile([200.0, 10.0, 0.0], (30, 1))
    rgb[5] = 0.0  # a black point: a zero-length "normal" before
    (tmp_path / "rgb.xyz").write_text("".join(_fmt(r) + "\n" for r in np.hstack([V, rgb])))
    with pytest.warns(UserWarning, match=r"rgb\.xyz: columns 4-6 are not unit vectors "
                                         r"\(lengths 0 to 200\), so not read as normals; name "
                                         r"them in a header row \(x y z nx ny nz\) to use them"
                      ) as caught:
        pc = read_points(tmp_path / "rgb.xyz")
    assert len(caught) == 1 and pc.normals is None
    np.testing.assert_array_equal(pc.points, V)
    pc = read_points(tmp_path / "rgb.xyz", normals=False)
    np.testing.assert_array_equal(pc.points, V)
    assert pc.normals is None


def test_headerless_normals_within_the_tolerance_are_read_and_past_it_ignored(tmp_path):
    """Three-decimal unit normals are normals; one row 3% long makes the columns not normals."""
    V, _, N = _cloud()
    N = np.round(_unit(N), 3)
    (tmp_path / "u.xyz").write_text("".join(_fmt(r) + "\n" for r in np.hstack([V, N])))
    np.testing.assert_allclose(read_points(tmp_path / "u.xyz").normals, _unit(N), atol=1e-15)
    N[7] *= 1.03
    (tmp_path / "u.xyz").write_text("".join(_fmt(r) + "\n" for r in np.hstack([V, N])))
    with pytest.warns(UserWarning, match=r"u\.xyz: columns 4-6 are not unit vectors"):
        assert read_points(tmp_path / "u.xyz").normals is None


def test_cli_says_a_colour_table_has_no_normals_in_one_line(tmp_path, capsys):
    from pcgeom import cli

    V, _ = peaks_surface("peaks3", n_side=10)
    rgb = np.tile([120.0, 30.0, 250.0], (len(V), 1))
    (tmp_path / "rgb.xyz").write_text("".join(_fmt(r) + "\n" for r in np.hstack([V, rgb])))
    assert cli.main(["param", str(tmp_path / "rgb.xyz"), "--quiet", "--json"]) == 0
    captured = capsys.readouterr()
    lines = [ln for ln in captured.err.splitlines() if "columns 4-6" in ln]
    assert lines == [f"pcgeom: warning: {tmp_path / 'rgb.xyz'}: columns 4-6 are not unit vectors "
                     "(lengths 279 to 279), so not read as normals; name them in a header row "
                     "(x y z nx ny nz) to use them"]
    assert '"normals": "estimated"' in captured.out


@pytest.mark.parametrize("ext", [".ply", ".npz", ".csv", ".las"])
def test_normals_false_skips_every_check_on_normals(tmp_path, ext):
    V, _, N = _cloud()
    N[0] = 0.0  # zero length
    path = tmp_path / f"z{ext}"
    if ext == ".ply":
        _ascii_ply(path, V, N[:, :2], names=("nx", "ny"))  # incomplete
    elif ext == ".npz":
        np.savez(path, points=V, normals=N[:-1])  # wrong count
    elif ext == ".csv":
        path.write_text("x,y,z,nx,ny,nz\n" + "".join(_fmt(r).replace(" ", ",") + ",1\n"
                                                    for r in np.hstack([V, N])))  # width
    else:
        _write_las(path, V, N, kind="nx")
    with pytest.raises(InputError, match=re.escape(f"{path}: ")):
        read_points(path)
    pc = read_points(path, normals=False)
    np.testing.assert_allclose(pc.points, V + ([100.0, -20.0, 3.0] if ext == ".las" else 0),
                               rtol=0, atol=5.1e-7)
    assert pc.normals is None


# --------------------------------------------------------------------------- LAS / LAZ


def _write_las(path, V, normals=None, kind="float", point_format=3, version="1.2"):
    """A LAS or LAZ file (by extension) with 1e-6 scales and non-zero offsets.

    ``kind``: ``"float"`` NormalX/NormalY/NormalZ float32 extra dimensions; ``"scaled"``
    int16 normal_x/... with scales 1e-4, 2e-4, 5e-5; ``"nx"`` float64 nx/ny/nz; ``"vector"``
    one "3f8" dimension named "normals".
    """
    laspy = pytest.importorskip("laspy")
    header = laspy.LasHeader(point_format=point_format, version=version)
    header.scales = np.array([1e-6, 1e-6, 1e-6])
    header.offsets = np.array([100.0, -20.0, 3.0])
    if normals is not None:
        if kind == "float":
            names = ["NormalX", "NormalY", "NormalZ"]
            header.add_extra_dims([laspy.ExtraBytesParams(name=n, type=np.float32)
                                   for n in names])
        elif kind == "scaled":
            # Different scales per component: reading the raw integers would turn the normals.
            names = ["normal_x", "normal_y", "normal_z"]
            header.add_extra_dims([
                laspy.ExtraBytesParams(name=n, type=np.int16, scales=np.array([scale]),
                                       offsets=np.array([0.0]))
                for n, scale in zip(names, [1e-4, 2e-4, 5e-5])])
        elif kind == "nx":
            names = ["nx", "ny", "nz"]
            header.add_extra_dims([laspy.ExtraBytesParams(name=n, type=np.float64)
                                   for n in names])
        else:
            names = None
            header.add_extra_dims([laspy.ExtraBytesParams(name="normals", type="3f8")])
    las = laspy.LasData(header)
    las.x, las.y, las.z = (V + header.offsets).T
    if normals is not None:
        if names is None:
            las.normals = normals
        else:
            for n, col in zip(names, normals.T):
                las[n] = col
    las.write(str(path))


@pytest.mark.parametrize("ext", [".las", ".laz"])
def test_las_without_normals(tmp_path, ext):
    V, _, _ = _cloud()
    _write_las(tmp_path / f"p{ext}", V)
    pc = read_points(tmp_path / f"p{ext}")
    assert pc.points.dtype == np.float64 and pc.faces is None and pc.normals is None
    # Scaled coordinates: the stored integers times 1e-6 plus the offset.
    np.testing.assert_allclose(pc.points, V + [100.0, -20.0, 3.0], rtol=0, atol=5.1e-7)


@pytest.mark.parametrize("ext", [".las", ".laz"])
@pytest.mark.parametrize("kind, atol", [("float", 1e-6), ("nx", 1e-15), ("vector", 1e-15)])
def test_las_normals_from_extra_dimensions(tmp_path, ext, kind, atol):
    V, _, N = _cloud()
    _write_las(tmp_path / f"n{ext}", V, N, kind=kind)
    pc = read_points(tmp_path / f"n{ext}")
    np.testing.assert_allclose(pc.points, V + [100.0, -20.0, 3.0], rtol=0, atol=5.1e-7)
    np.testing.assert_allclose(pc.normals, _unit(N), rtol=0, atol=atol)


def test_las_scaled_integer_normals(tmp_path):
    V, _, N = _cloud()
    U = _unit(N)
    _write_las(tmp_path / "s.las", V, U, kind="scaled")
    pc = read_points(tmp_path / "s.las")
    np.testing.assert_allclose(pc.normals, U, rtol=0, atol=2e-4)  # <= 2e-4 steps, renormalized


def test_las_format_6_with_normals(tmp_path):
    V, _, N = _cloud()
    _write_las(tmp_path / "f6.laz", V, N, kind="nx", point_format=6, version="1.4")
    np.testing.assert_allclose(read_points(tmp_path / "f6.laz").normals, _unit(N), atol=1e-15)


@pytest.mark.parametrize("ext", [".las", ".laz"])
def test_las_without_points(tmp_path, ext):
    _write_las(tmp_path / f"e{ext}", np.zeros((0, 3)))
    with pytest.raises(InputError, match=re.escape(f"{tmp_path / ('e' + ext)}: file holds no "
                                                   "points")):
        read_points(tmp_path / f"e{ext}")


def test_las_garbage(tmp_path):
    (tmp_path / "g.las").write_bytes(b"LASF but nothing else")
    with pytest.raises(InputError, match=r"g\.las: cannot parse: ") as info:
        read_points(tmp_path / "g.las")
    assert "\n" not in str(info.value)


def test_las_bad_normals(tmp_path):
    V, _, N = _cloud()
    N[3] = [np.inf, 0.0, 1.0]
    _write_las(tmp_path / "b.las", V, N, kind="nx")
    with pytest.raises(InputError, match=r"b\.las: normal of row 3 contains NaN or inf"):
        read_points(tmp_path / "b.las")


def test_las_too_few_points(tmp_path):
    V, _, _ = _cloud()
    _write_las(tmp_path / "f.las", V[:4])
    with pytest.raises(InputError, match=r"f\.las: 4 points, need at least 10"):
        read_points(tmp_path / "f.las")


# --------------------------------------------------------------------------- writer errors


@pytest.mark.parametrize(
    "bad, match",
    [
        (lambda N: N[:-1], "normals: 29 normals for 30 points"),
        (lambda N: np.where(np.arange(30)[:, None] == 3, np.nan, N),
         "normals: normal of row 3 contains NaN or inf"),
        (lambda N: np.where(np.arange(30)[:, None] == 0, 0.0, N),
         re.escape("normals: normal of row 0 has zero length (1 such rows)")),
    ],
)
def test_ply_writer_rejects_bad_normals(tmp_path, bad, match):
    V, F, N = _cloud()
    with pytest.raises(InputError, match=match):
        write_ply_atomic(tmp_path / "o.ply", V, F, normals=bad(N))
    assert list(tmp_path.iterdir()) == []
