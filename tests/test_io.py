"""Reading, validating and atomically writing point clouds (pcgeom.io).

The checks on arrays themselves (validate_points, validate_faces, deduplicate, normalize) are
in test_cloud.py; the results file (ParamResult) in test_results.py.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest

from pcgeom.cloud import deduplicate
from pcgeom.io import (
    SUPPORTED_EXTENSIONS,
    InputError,
    PointCloud,
    check_writable,
    read_points,
    save_npz_atomic,
    write_ply_atomic,
)

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def _cloud() -> tuple[np.ndarray, np.ndarray]:
    """A saddle patch z = x^2 - y^2 on a 6 x 5 grid, with non-round coordinates, and its faces.

    Rows are shuffled so that any reordering by a reader shows up.
    """
    x, y = np.meshgrid(np.linspace(-0.7, 0.9, 6), np.linspace(-0.3, 1.1, 5), indexing="xy")
    V = np.column_stack([x.ravel(), y.ravel(), (x**2 - y**2).ravel()]) * np.pi  # (30, 3)
    idx = np.arange(30).reshape(5, 6)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    F = np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])  # (40, 3)
    perm = np.random.default_rng(7).permutation(30)
    new_index = np.empty(30, dtype=np.int64)
    new_index[perm] = np.arange(30)
    return V[perm], new_index[F]


def _fmt(row) -> str:
    return " ".join(f"{float(v):.17g}" for v in row)  # 17 digits: exact float64 round trip


def _ls(folder: Path) -> list[str]:
    return sorted(os.listdir(folder))


# --------------------------------------------------------------------------- package surface


def test_io_exports():
    import pcgeom.io as pio

    assert set(pio.__all__) == {"InputError", "PointCloud", "SUPPORTED_EXTENSIONS", "read_points",
                                "write_ply_atomic", "check_writable", "write_atomic",
                                "write_files_atomic", "save_npz_atomic", "ParamResult",
                                "LandmarkPair", "read_landmarks"}
    assert all(hasattr(pio, name) for name in pio.__all__)
    # Array preparation lives in pcgeom.cloud, not here.
    for name in ("validate_points", "deduplicate", "normalize"):
        assert not hasattr(pio, name)


# --------------------------------------------------------------------------- round trips


def test_ply_with_faces_round_trip(tmp_path):
    V, F = _cloud()
    write_ply_atomic(tmp_path / "m.ply", V, F)
    pc = read_points(tmp_path / "m.ply")
    assert isinstance(pc, PointCloud)
    assert pc.points.dtype == np.float64 and pc.faces.dtype == np.int64
    np.testing.assert_array_equal(pc.points, V)  # exact: float64 on disk, order kept
    np.testing.assert_array_equal(pc.faces, F)
    assert pc.source == str(tmp_path / "m.ply")


def test_ply_without_faces_round_trip(tmp_path):
    V, _ = _cloud()
    write_ply_atomic(tmp_path / "p.ply", V)
    pc = read_points(tmp_path / "p.ply")
    np.testing.assert_array_equal(pc.points, V)
    assert pc.faces is None


def test_ply_written_by_trimesh_is_read(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    V, F = _cloud()
    (tmp_path / "t.ply").write_bytes(trimesh.Trimesh(V, F, process=False).export(file_type="ply"))
    (tmp_path / "c.ply").write_bytes(trimesh.PointCloud(V).export(file_type="ply"))
    pc, bare = read_points(tmp_path / "t.ply"), read_points(tmp_path / "c.ply")
    np.testing.assert_allclose(pc.points, V, atol=1e-6)  # trimesh writes float32
    np.testing.assert_array_equal(pc.faces, F)
    np.testing.assert_allclose(bare.points, V, atol=1e-6)
    assert bare.faces is None


def test_ascii_ply_keeps_duplicates_and_unreferenced_vertices(tmp_path):
    V, F = _cloud()
    V = np.vstack([V, V[:3]])  # duplicates at the end, never referenced by a face
    header = (
        "ply\nformat ascii 1.0\n"
        f"element vertex {len(V)}\nproperty double x\nproperty double y\nproperty double z\n"
        f"element face {len(F)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    body = "".join(_fmt(v) + "\n" for v in V) + "".join("3 %d %d %d\n" % tuple(f) for f in F)
    (tmp_path / "a.ply").write_text(header + body)
    pc = read_points(tmp_path / "a.ply")
    np.testing.assert_array_equal(pc.points, V)
    np.testing.assert_array_equal(pc.faces, F)


def test_obj_round_trip_keeps_order_duplicates_and_unreferenced(tmp_path):
    V, F = _cloud()
    V = np.vstack([V, V[:2]])
    text = "# saddle\no patch\n" + "".join(f"v {_fmt(v)}\n" for v in V)
    text += "vt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\n"
    text += "".join("f %d/1/1 %d/2/1 %d/3/1\n" % tuple(f + 1) for f in F)
    (tmp_path / "m.obj").write_text(text)
    pc = read_points(tmp_path / "m.obj")
    np.testing.assert_array_equal(pc.points, V)
    np.testing.assert_array_equal(pc.faces, F)


def test_obj_polygons_negative_indices_and_bare_points(tmp_path):
    V, _ = _cloud()
    text = "".join(f"v {_fmt(v)}\n" for v in V) + "f 1 2 3 4\nf -3 -2 -1\n"
    (tmp_path / "q.obj").write_text(text)
    pc = read_points(tmp_path / "q.obj")
    np.testing.assert_array_equal(pc.faces, [[0, 1, 2], [0, 2, 3], [27, 28, 29]])
    (tmp_path / "p.obj").write_text("".join(f"v {_fmt(v)}\n" for v in V))
    assert read_points(tmp_path / "p.obj").faces is None


def test_off_round_trip(tmp_path):
    V, F = _cloud()
    V = np.vstack([V, V[:2]])
    text = f"OFF\n{len(V)} {len(F)} 0\n" + "".join(_fmt(v) + "\n" for v in V)
    text += "".join("3 %d %d %d\n" % tuple(f) for f in F)
    (tmp_path / "m.off").write_text(text)
    pc = read_points(tmp_path / "m.off")
    np.testing.assert_array_equal(pc.points, V)
    np.testing.assert_array_equal(pc.faces, F)


@pytest.mark.parametrize(
    "name, sep, header, extra",
    [
        ("c.xyz", " ", "", False),
        ("c.txt", "\t", "# scanner export\n# x y z r g b\n", True),
        ("c.csv", ",", "x,y,z,intensity\n", True),
        ("d.csv", ", ", "", False),
    ],
)
def test_tables_round_trip(tmp_path, name, sep, header, extra):
    V, _ = _cloud()
    lines = []
    for i, v in enumerate(V):
        cols = [f"{float(c):.17g}" for c in v] + ([str(i), "0.5"] if extra else [])
        lines.append(sep.join(cols) + ("  # inline comment" if i == 3 else ""))
    (tmp_path / name).write_text(header + "\n".join(lines) + "\n\n")
    pc = read_points(tmp_path / name)
    np.testing.assert_array_equal(pc.points, V)
    assert pc.faces is None


@pytest.mark.parametrize("key", ["points", "V", "vertices", "anything"])
def test_npz_round_trip(tmp_path, key):
    V, F = _cloud()
    np.savez(tmp_path / "c.npz", **{key: V})
    pc = read_points(tmp_path / "c.npz")
    np.testing.assert_array_equal(pc.points, V)
    assert pc.faces is None


@pytest.mark.parametrize("face_key", ["faces", "F"])
def test_npz_with_faces_and_saved_atomically(tmp_path, face_key):
    V, F = _cloud()
    save_npz_atomic(tmp_path / "m.npz", V=V, **{face_key: F}, extra=np.arange(4))
    pc = read_points(tmp_path / "m.npz")
    np.testing.assert_array_equal(pc.points, V)
    np.testing.assert_array_equal(pc.faces, F)
    assert _ls(tmp_path) == ["m.npz"]


def test_extension_is_case_insensitive(tmp_path):
    V, _ = _cloud()
    write_ply_atomic(tmp_path / "m.ply", V)
    os.replace(tmp_path / "m.ply", tmp_path / "M.PLY")
    np.testing.assert_array_equal(read_points(tmp_path / "M.PLY").points, V)


# --------------------------------------------------------------------------- read errors


@pytest.mark.parametrize("ext", SUPPORTED_EXTENSIONS)
def test_empty_file(tmp_path, ext):
    path = tmp_path / f"e{ext}"
    path.write_bytes(b"")
    with pytest.raises(InputError, match=re.escape(f"{path}: file is empty (0 bytes)")):
        read_points(path)


@pytest.mark.parametrize("name, text", [("c.xyz", "# only a comment\n\n"), ("c.obj", "o empty\n")])
def test_file_without_points(tmp_path, name, text):
    (tmp_path / name).write_text(text)
    with pytest.raises(InputError, match="file holds no points"):
        read_points(tmp_path / name)


def test_ply_with_zero_vertices(tmp_path):
    header = "ply\nformat ascii 1.0\nelement vertex 0\nproperty double x\nproperty double y\n"
    (tmp_path / "z.ply").write_text(header + "property double z\nend_header\n")
    with pytest.raises(InputError, match="z.ply: file holds no points"):
        read_points(tmp_path / "z.ply")


@pytest.mark.parametrize(
    "name, content, match",
    [
        ("g.ply", b"hello garbage\x00\xff\n1 2\n", r"g\.ply: cannot parse: not a PLY file \(it does not "
                                                r"start with 'ply'\)"),
        ("g.off", b"hello world\nfoo\n", r"g\.off: cannot parse: "),
        ("g.npz", b"PK not really a zip", r"g\.npz: cannot parse: "),
        ("g.txt", b"1 2 3\n4 five 6\n", r"g\.txt: cannot parse: .*five"),
        ("g.xyz", b"\xff\xfe\x00\x01binary", r"g\.xyz: cannot parse: not a text file"),
        ("g.obj", b"v 1 2 three\n", r"g\.obj: cannot parse line 1: "),
    ],
)
def test_garbage_content(tmp_path, name, content, match):
    (tmp_path / name).write_bytes(content)
    with pytest.raises(InputError, match=match) as info:
        read_points(tmp_path / name)
    assert "\n" not in str(info.value)


_PLY_HEAD = "ply\nformat ascii 1.0\nelement vertex 12\nproperty float x\nproperty float y\n"
_PLY_XYZ = _PLY_HEAD + "property float z\n"
_PLY_ROWS = "".join(f"{k} {k % 3} {k % 5}\n" for k in range(12))
_PLY_FACES = "element face 2\nproperty list uchar int vertex_indices\n"


@pytest.mark.parametrize(
    "content, match",
    [  # issue 39: "list index out of range", or read without a word
        ("ply\nformat ascii 1.0\nelement vertex\nproperty float x\nend_header\n1\n",
         r"m\.ply: malformed PLY header, line 3: 'element vertex' \(expected 'element NAME "
         r"COUNT'\)"),
        ("ply\nformat ascii 1.0\nelement vertex 12\nproperty\nend_header\n" + _PLY_ROWS,
         r"m\.ply: malformed PLY header, line 4: 'property' \(expected 'property TYPE NAME' or "
         r"'property list TYPE TYPE NAME' after an element\)"),
        (_PLY_HEAD + "property float z w\nend_header\n" + _PLY_ROWS,
         r"m\.ply: malformed PLY header, line 6: 'property float z w'"),
        ("ply\nformat ascii\nelement vertex 12\nend_header\n" + _PLY_ROWS,
         r"m\.ply: malformed PLY header, line 2: 'format ascii' \(expected 'format ascii 1\.0' "
         r"or a binary format\)"),
        (_PLY_XYZ + "vertex_count 3\nend_header\n" + _PLY_ROWS,
         r"m\.ply: malformed PLY header, line 7: 'vertex_count 3' \(not a PLY header keyword\)"),
        (_PLY_XYZ + _PLY_ROWS, r"m\.ply: malformed PLY header: no 'end_header' line"),
        ("ply\nelement vertex 12\nproperty float x\nend_header\n" + _PLY_ROWS,
         r"m\.ply: malformed PLY header: no 'format' line"),
        (_PLY_XYZ + "end_header\n" + _PLY_ROWS[:-6],
         r"m\.ply: malformed PLY data, line 19: 1 value\(s\) do not match the vertex's "
         r"properties \(x y z\)"),
        (_PLY_XYZ + "end_header\n" + _PLY_ROWS.replace("11 2 1\n", ""),
         r"m\.ply: truncated PLY: its header declares 12 vertex but the data ends at line 18"),
        (_PLY_XYZ + _PLY_FACES + "end_header\n" + _PLY_ROWS + "3 0 1 2\n3 1 2\n",
         r"m\.ply: malformed PLY data, line 23: 3 value\(s\) do not match the face's "
         r"properties \(vertex_indices\)"),
        (_PLY_XYZ + _PLY_FACES + "end_header\n" + _PLY_ROWS + "3 0 1 2\n",
         r"m\.ply: truncated PLY: its header declares 12 vertex, 2 face but the data ends at "
         r"line 22"),
    ],
)
def test_malformed_ply_is_one_line_naming_the_file_and_the_fault(tmp_path, content, match):
    (tmp_path / "m.ply").write_text(content)
    with pytest.raises(InputError, match=match) as info:
        read_points(tmp_path / "m.ply")
    assert "\n" not in str(info.value) and str(info.value).startswith(str(tmp_path / "m.ply"))
    (tmp_path / "m.ply").write_text(_PLY_XYZ + _PLY_FACES + "end_header\n" + _PLY_ROWS
                                    + "3 0 1 2\n4 1 2 3 4\n\n")  # a quad, a trailing blank line
    assert len(read_points(tmp_path / "m.ply").points) == 12


def test_unknown_extension_lists_supported(tmp_path):
    (tmp_path / "scan.e57").write_bytes(b"ASTM-E57")
    match = (r"scan\.e57: unknown extension '\.e57'; "
             r"supported: \.csv, \.las, \.laz, \.npz, \.obj, \.off, \.ply")
    with pytest.raises(InputError, match=match):
        read_points(tmp_path / "scan.e57")
    with pytest.raises(InputError, match=r"unknown extension \(none\)"):
        read_points(tmp_path / "noext")


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match=r"nothere\.ply: no such file"):
        read_points(tmp_path / "nothere.ply")


def test_directory_is_not_a_file(tmp_path):
    (tmp_path / "d.ply").mkdir()
    with pytest.raises(InputError, match=r"d\.ply: not a regular file"):
        read_points(tmp_path / "d.ply")


def test_wrong_shape_npz(tmp_path):
    np.savez(tmp_path / "w.npz", points=np.zeros((20, 2)))
    with pytest.raises(InputError, match=r"w\.npz: expected shape \(N, 3\), got \(20, 2\)"):
        read_points(tmp_path / "w.npz")


def test_npz_without_point_key_lists_keys(tmp_path):
    np.savez(tmp_path / "k.npz", a=np.zeros((20, 3)), b=np.zeros((20, 3)))
    with pytest.raises(InputError, match=r"k\.npz: no point array; .*found: a, b"):
        read_points(tmp_path / "k.npz")


def test_npz_faces_out_of_range(tmp_path):
    V, F = _cloud()
    np.savez(tmp_path / "f.npz", V=V, F=F + 1)
    match = r"f\.npz: faces reference vertex indices 1\.\.30 but there are 30 points"
    with pytest.raises(InputError, match=match):
        read_points(tmp_path / "f.npz")


def test_wrong_shape_txt_two_columns(tmp_path):
    (tmp_path / "w.txt").write_text("".join(f"{i} {i * i}\n" for i in range(20)))
    match = r"w\.txt: expected shape \(N, 3\) \(x y z columns\), got \(20, 2\)"
    with pytest.raises(InputError, match=match):
        read_points(tmp_path / "w.txt")


def test_ragged_table(tmp_path):
    (tmp_path / "r.csv").write_text("1,2,3\n4,5,6,7\n")
    match = r"r\.csv: rows have different numbers of columns \(3 in row 1, 4 in row 2\)"
    with pytest.raises(InputError, match=match):
        read_points(tmp_path / "r.csv")


@pytest.mark.parametrize("bad, word", [(np.nan, "nan"), (np.inf, "inf"), (-np.inf, "-inf")])
def test_non_finite_in_file(tmp_path, bad, word):
    V, _ = _cloud()
    V[[2, 5], 1] = bad
    (tmp_path / "n.xyz").write_text("".join(_fmt(v) + "\n" for v in V))
    assert word in (tmp_path / "n.xyz").read_text()
    with pytest.raises(InputError, match=r"n\.xyz: 2 of 30 rows contain NaN or inf"):
        read_points(tmp_path / "n.xyz")


def test_too_few_points(tmp_path):
    V, _ = _cloud()
    np.savez(tmp_path / "input.npz", points=V[:3])
    with pytest.raises(InputError, match=r"input\.npz: 3 points, need at least 10$"):
        read_points(tmp_path / "input.npz")
    assert read_points(tmp_path / "input.npz", min_points=3).points.shape == (3, 3)


def test_all_coincident(tmp_path):
    np.savez(tmp_path / "c.npz", points=np.tile([[1.5, -2.0, 3.25]], (12, 1)))
    with pytest.raises(InputError, match=r"c\.npz: all 12 points coincide"):
        read_points(tmp_path / "c.npz")


def test_collinear(tmp_path):
    t = np.linspace(0.0, 1.0, 15)[:, None]
    P = np.array([0.1, 0.2, 0.3]) + t * np.array([1.0, -2.0, 0.5])
    np.savez(tmp_path / "l.npz", points=P)
    with pytest.raises(InputError, match=r"l\.npz: all 15 points lie on one line"):
        read_points(tmp_path / "l.npz")


# --------------------------------------------------------------------------- duplicates


def test_duplicates_allowed_and_deduplicate_round_trips(tmp_path):
    V, _ = _cloud()
    P = np.vstack([V, V[[4, 0, 4]], V[:1]])  # (34, 3)
    write_ply_atomic(tmp_path / "d.ply", P)
    loaded = read_points(tmp_path / "d.ply").points
    np.testing.assert_array_equal(loaded, P)
    unique, inverse = deduplicate(loaded)
    assert unique.shape == (30, 3) and inverse.shape == (34,) and inverse.dtype == np.int64
    np.testing.assert_array_equal(unique[inverse], P)
    np.testing.assert_array_equal(unique, V)  # first-occurrence order
    np.testing.assert_array_equal(inverse[30:], [4, 0, 4, 0])


# --------------------------------------------------------------------------- writing


class _Exploding:
    """Array-like whose conversion fails, so np.savez fails after writing earlier arrays."""

    def __array__(self, dtype=None, copy=None):
        raise RuntimeError("disk full")


def test_npz_writer_leaves_nothing_on_failure(tmp_path):
    V, _ = _cloud()
    with pytest.raises(RuntimeError, match="disk full"):
        save_npz_atomic(tmp_path / "out.npz", a=V, b=_Exploding())
    assert _ls(tmp_path) == []


def test_ply_writer_leaves_nothing_on_failure_mid_write(tmp_path, monkeypatch):
    import pcgeom.io.points as points_module

    def half_write(f, V, F, N, UV=None):
        f.write(b"ply\nformat binary_little_endian 1.0\n")
        raise OSError("disk full")

    monkeypatch.setattr(points_module, "_write_ply", half_write)
    V, F = _cloud()
    with pytest.raises(OSError, match="disk full"):
        write_ply_atomic(tmp_path / "out.ply", V, F)
    assert _ls(tmp_path) == []


def test_files_written_together_leave_none_on_failure(tmp_path):
    """write_files_atomic: all files appear or none; earlier versions stay until all succeed."""
    from pcgeom.io import write_files_atomic

    paths = [tmp_path / name for name in ("a.obj", "a.mtl", "a.png")]
    write_files_atomic({p: (lambda f, p=p: f.write(p.name.encode())) for p in paths})
    assert [p.read_bytes() for p in paths] == [b"a.obj", b"a.mtl", b"a.png"]

    def fails(f):
        f.write(b"half")
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        write_files_atomic({paths[0]: lambda f: f.write(b"new"),
                            paths[1]: lambda f: f.write(b"new"), paths[2]: fails})
    assert [p.read_bytes() for p in paths] == [b"a.obj", b"a.mtl", b"a.png"]
    assert _ls(tmp_path) == ["a.mtl", "a.obj", "a.png"]  # no temporary left


def test_failed_write_keeps_previous_output(tmp_path, monkeypatch):
    V, F = _cloud()
    write_ply_atomic(tmp_path / "out.ply", V, F)
    before = (tmp_path / "out.ply").read_bytes()

    def failing_replace(src, dst):
        raise OSError("rename failed")

    monkeypatch.setattr(os, "replace", failing_replace)
    with pytest.raises(OSError, match="rename failed"):
        write_ply_atomic(tmp_path / "out.ply", V[::-1], F)
    with pytest.raises(OSError, match="rename failed"):
        save_npz_atomic(tmp_path / "out.npz", V=V)
    monkeypatch.undo()
    assert _ls(tmp_path) == ["out.ply"]
    assert (tmp_path / "out.ply").read_bytes() == before


def test_written_file_gets_umask_permissions(tmp_path):
    umask = os.umask(0o022)
    try:
        save_npz_atomic(tmp_path / "o.npz", V=np.zeros(3))
    finally:
        os.umask(umask)
    assert (tmp_path / "o.npz").stat().st_mode & 0o777 == 0o644


def test_ply_writer_rejects_bad_arrays(tmp_path):
    V, F = _cloud()
    with pytest.raises(ValueError, match=r"vertices: expected shape \(N, 3\), got \(30, 2\)"):
        write_ply_atomic(tmp_path / "o.ply", V[:, :2])
    with pytest.raises(InputError,
                       match=r"faces: faces reference vertex indices 0\.\.30 but there are 30 points"):
        write_ply_atomic(tmp_path / "o.ply", V, np.vstack([F, [[0, 1, 30]]]))
    with pytest.raises(ValueError, match="vertices: contain NaN or inf"):
        write_ply_atomic(tmp_path / "o.ply", np.full((3, 3), np.nan))
    assert _ls(tmp_path) == []


def test_check_writable(tmp_path):
    assert check_writable(tmp_path / "out.npz", "npz") == tmp_path / "out.npz"
    assert check_writable(str(tmp_path / "out.PLY"), "ply") == tmp_path / "out.PLY"
    match = r"out\.ply: output must have extension '\.npz', got '\.ply'"
    with pytest.raises(InputError, match=match):
        check_writable(tmp_path / "out.ply", "npz")
    with pytest.raises(InputError, match=r"output must have extension '\.ply', got none"):
        check_writable(tmp_path / "out", "ply")
    with pytest.raises(InputError, match=r"out\.npz: output directory '.*missing' does not exist"):
        check_writable(tmp_path / "missing" / "out.npz", "npz")
    (tmp_path / "dir.npz").mkdir()
    with pytest.raises(InputError, match=r"dir\.npz: is a directory, expected a file"):
        check_writable(tmp_path / "dir.npz", "npz")
    # The writers check before writing anything.
    with pytest.raises(InputError, match="does not exist"):
        save_npz_atomic(tmp_path / "missing" / "out.npz", V=np.zeros(3))
    with pytest.raises(InputError, match="must have extension '.ply'"):
        write_ply_atomic(tmp_path / "out.obj", np.zeros((3, 3)))


# --------------------------------------------------------------------------- real data


@pytest.mark.skipif(not DATA.is_dir(), reason=f"test surfaces not found at {DATA}")
def test_real_face_mesh():
    pc = read_points(DATA / "face_human_choi.ply")
    assert pc.points.shape == (17157, 3) and pc.points.dtype == np.float64
    assert pc.faces.shape == (34144, 3) and pc.faces.dtype == np.int64
    assert pc.faces.max() == 17156
