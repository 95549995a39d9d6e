"""Every example command line in ``pcgeom --help`` and ``pcgeom COMMAND --help`` runs.

The examples are read from the help texts themselves (``cli.build_parser().epilog`` and each
module's ``EPILOG`` in ``cli.COMMANDS``), so a new command or a new example is covered without
touching this file. Each example runs in-process (``cli.main``) in its own empty directory,
where the input files it names are created first from a small three-peaks patch:

- a cloud (``scan.ply``, ``mesh.obj``, ``scan.xyz``, ``scan.las``, ...) in the format its
  extension names, with the reference triangles when the format holds faces; a name starting
  with ``statue`` is a closed surface (an analytic ellipsoid, for ``--domain sphere``);
- ``NAME_uv.npz`` read as a map (``--map`` or a positional): a free-boundary map of ``NAME``
  (a sphere map of a closed ``NAME``);
- ``--landmarks FILE.json``: landmark pairs on that cloud; any other ``.json``: a polygon domain;
- a glob (``scans/*.ply``): three small clouds matching it.

Training is shrunk to a second: every command module's ``get_preset`` is patched with
``tests.helpers.tiny_preset`` (what ``tests/test_cli.py`` does; the CLI has no size option of
its own), so ``--preset fast`` and ``--preset paper`` keep their names and their checks.
An example naming ``--device cuda`` would run on the CPU when CUDA is not available (none
does today: they say ``--device auto``). An example passes when it exits
with status 0 and writes every output it names (``--out``, ``--out-ply``, ``--out-mesh``,
``--plot``, ``-o``).
"""

from __future__ import annotations

import dataclasses
import json
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from pcgeom import cli, parametrize
from pcgeom.examples import peaks_surface
from pcgeom.io import read_points
from pcgeom.io.points import SUPPORTED_EXTENSIONS, write_ply_atomic

from .helpers import tiny_preset

OUTPUT_OPTIONS = ("--out", "--out-ply", "--out-mesh", "--plot", "-o")
"""Options whose value is a file the example writes (checked to exist afterwards)."""
MAP_OPTIONS = ("--map",)
LANDMARK_OPTIONS = ("--landmarks",)
N_SIDE = 24
"""The example cloud: a 24 x 24 grid of the three-peaks surface (576 points)."""


def example_lines(epilog: str | None) -> list[str]:
    """The command lines of a help epilog: its lines that start with ``pcgeom ``."""
    return [line.strip() for line in (epilog or "").splitlines()
            if line.strip().startswith("pcgeom ")]


def _all_examples() -> list[tuple[str, str]]:
    """(help it comes from, line) for every distinct example line, commands first."""
    found: dict[str, str] = {}
    for command in cli.COMMANDS:
        for line in example_lines(command.EPILOG):
            found.setdefault(line, command.NAME)
    for line in example_lines(cli.build_parser().epilog):
        found.setdefault(line, "pcgeom")
    return [(owner, line) for line, owner in found.items()]


EXAMPLES = _all_examples()


# --------------------------------------------------------------------------- input files


CLOSED_STEMS = ("statue",)
"""Cloud names (their start) written as a closed surface."""


def _cloud(closed: bool = False) -> tuple[np.ndarray, np.ndarray]:
    if closed:
        from pcgeom.synthetic_closed import closed_surface

        s = closed_surface("ellipsoid", 800, sampling="grid")
        return s.points, s.faces
    return peaks_surface("peaks3", n_side=N_SIDE)


def _write_cloud(path: Path) -> None:
    """The example cloud in the format of ``path``'s extension (faces where it holds them)."""
    import trimesh

    V, F = _cloud(path.stem.startswith(CLOSED_STEMS))
    path.parent.mkdir(parents=True, exist_ok=True)
    ext = path.suffix.lower()
    if ext == ".ply":
        write_ply_atomic(path, V, F)
    elif ext in (".obj", ".off"):
        trimesh.Trimesh(V, F, process=False).export(path)
    elif ext == ".npz":
        np.savez(path, points=V, faces=F)
    elif ext in (".las", ".laz"):
        import laspy

        header = laspy.LasHeader(point_format=3, version="1.2")
        header.offsets = V.min(axis=0)
        header.scales = np.full(3, 1e-6)
        las = laspy.LasData(header)
        las.x, las.y, las.z = V[:, 0], V[:, 1], V[:, 2]
        las.write(path)
    elif ext == ".csv":
        np.savetxt(path, V, delimiter=",", header="x,y,z", comments="", fmt="%.17g")
    else:  # .xyz .txt
        np.savetxt(path, V, fmt="%.17g")


_MAPS: dict[bytes, object] = {}


def _write_map(path: Path, cloud_path: Path) -> None:
    """A free-boundary map of the cloud in ``cloud_path``, as ``pcgeom param`` writes it."""
    points = read_points(cloud_path).points
    key = points.tobytes()
    if key not in _MAPS:  # one training per distinct cloud, shared by the examples
        domain = "sphere" if cloud_path.stem.startswith(CLOSED_STEMS) else "free"
        _MAPS[key] = parametrize(points, domain, config=small_preset("fast"), seed=0,
                                 progress=False)
    _MAPS[key].save(path)


def _write_landmarks(path: Path) -> None:
    V, _ = _cloud()
    left, right = np.argmin(V[:, 0]), np.argmax(V[:, 0])
    pairs = [{"indices": [int(left)], "targets": [[-0.8, 0.0]]},
             {"indices": [int(right)], "targets": [[0.8, 0.0]]}]
    path.write_text(json.dumps(pairs))


def _write_polygon(path: Path) -> None:
    path.write_text(json.dumps({"type": "Polygon", "coordinates": [
        [[0, 0], [2, 0], [2, 1], [0, 1]], [[0.5, 0.25], [1, 0.25], [1, 0.75]]]}))


def _write_mask(path: Path) -> None:
    """A white disk with a black hole, 64 x 64."""
    from PIL import Image

    y, x = np.mgrid[:64, :64] - 31.5
    r = np.hypot(x, y)
    Image.fromarray(((r < 30) & (r > 10)).astype(np.uint8) * 255).save(path)


def _is_cloud_name(token: str) -> bool:
    return Path(token).suffix.lower() in SUPPORTED_EXTENSIONS


def prepare_inputs(argv: list[str], where: Path) -> list[Path]:
    """Create in ``where`` every input file ``argv`` names; returns the outputs it names."""
    outputs, maps = [], []
    clouds: dict[str, Path] = {}
    for prev, token in zip([""] + argv, argv):
        path = where / token
        if prev in OUTPUT_OPTIONS:
            outputs.append(path)  # a file, or a folder (``--out maps``)
        elif token.startswith("-") or ("." not in path.name and "*" not in token):
            continue  # an option, or a value such as a domain spec or a number
        elif prev in LANDMARK_OPTIONS:
            _write_landmarks(path)
        elif path.suffix.lower() == ".json":
            _write_polygon(path)
        elif path.suffix.lower() == ".png":  # an input image: a domain's mask
            _write_mask(path)
        elif "*" in token:
            for k in range(3):
                _write_cloud(where / token.replace("*", f"cloud{k}", 1))
        elif path.suffix.lower() == ".npz" and (prev in MAP_OPTIONS or path.stem.endswith("_uv")):
            maps.append(path)
        elif _is_cloud_name(token) and not path.exists():
            _write_cloud(path)
            clouds[path.stem] = path
    for path in maps:
        # NAME_uv.npz maps the cloud NAME.* of the same example (any cloud if none matches).
        cloud = clouds.get(path.stem.removesuffix("_uv")) or next(iter(clouds.values()), None)
        if cloud is None:
            cloud = where / "cloud_for_map.ply"
            _write_cloud(cloud)
        _write_map(path, cloud)
    return outputs


# --------------------------------------------------------------------------- tests


def test_every_command_shows_an_example():
    for command in cli.COMMANDS:
        lines = example_lines(command.EPILOG)
        assert lines, f"pcgeom {command.NAME} --help shows no example"
        for line in lines:
            assert shlex.split(line)[1] == command.NAME, f"{command.NAME}: {line!r}"
    assert example_lines(cli.build_parser().epilog)


def small_preset(name: str, **overrides):
    """``name`` shrunk to about a second: one short stage, a few refinement steps."""
    config = tiny_preset(name, refine_steps=3)
    return dataclasses.replace(config, refine=dataclasses.replace(config.refine,
                                                                  batch_domain=128))


@pytest.fixture
def tiny(monkeypatch):
    """Every command module's preset lookup returns :func:`small_preset`; one torch thread
    (the examples are tiny, and CI's two cores are shared)."""
    for command in cli.COMMANDS:
        if hasattr(command, "get_preset"):
            monkeypatch.setattr(command, "get_preset", small_preset)
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


@pytest.mark.parametrize("owner, line", EXAMPLES,
                         ids=[f"{owner}:{k}" for k, (owner, _) in enumerate(EXAMPLES)])
def test_help_example_runs(owner, line, tmp_path, monkeypatch, tiny, capsys):
    argv = shlex.split(line)[1:]
    if not torch.cuda.is_available():
        argv = ["cpu" if prev == "--device" and tok == "cuda" else tok
                for prev, tok in zip([""] + argv, argv)]
    monkeypatch.chdir(tmp_path)
    outputs = prepare_inputs(argv, tmp_path)
    code = cli.main(argv)
    out, err = capsys.readouterr()
    assert code == 0, f"{line!r} exited with {code}:\n{err}"
    for path in outputs:
        assert path.exists(), f"{line!r} did not write {path.name}"
    if "--json" in argv:
        json.loads(out)


def test_python_m_pcgeom_shows_the_same_help():
    """``python -m pcgeom`` is ``pcgeom``: the same help, examples included."""
    done = subprocess.run([sys.executable, "-m", "pcgeom", "param", "--help"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    for line in example_lines(cli.COMMANDS[0].EPILOG):
        assert line in done.stdout
