"""Surface reconstruction from a map (the paper's section 8, remeshing): a free-boundary
map, meshed inside its detected loops (below), or a map onto a bounded domain, meshed on the
domain itself (:func:`reconstruct_on_domain`).

1. Mesh the region of the map inside the detected loops (the outer loop minus the holes)
   with gmsh, every loop point a mesh vertex, so the mesh's boundary is the detected one.
2. Size: uniform, the element size ``s = sqrt(2 A / (sqrt(3) n))`` of ``n`` equilateral
   triangles covering the area ``A``, then corrected from the vertex counts of up to two
   trial meshes (the loop points, all kept, add vertices the formula does not see).
   Adaptive: ``s * r(x)`` with ``r = lambda_inv ** -0.5`` (the issue's lambda-adaptive rule)
   given to gmsh as a size callback, ``s`` from the same formula with the area weighted by
   ``mean(r ** -2)`` and the same correction. Under LEG's model (``|f(x) - f(y)|`` about
   ``|x - y| / (2 lambda_inv)``) a map size ``s`` is a surface size ``2 s lambda_inv``, so
   this rule refines where the map compresses the surface, by the square root of the
   compression.
3. Lift each new 2D vertex to 3D by barycentric interpolation over the triangles that
   boundary detection kept (the Delaunay triangulation of f(X) without the triangles that
   span gaps).

Vertices outside every kept triangle
------------------------------------
The meshed region is the polygon of the kept loops; the kept triangles cover it except in the
gaps whose loops were dropped as too small (``BoundaryLoops.dropped``) and, up to rounding,
on the boundary edges themselves. A vertex found in no kept triangle takes the point of the
kept triangles' boundary edges nearest to it in the map and is lifted linearly along that
edge (barycentric interpolation on its triangle, with the opposite vertex's weight 0). It is
a projection onto the nearest covered point, so a gap is bridged by the surface around it,
never extrapolated.

Measured on face_3holes_small_choi (5053 points), its ``fast`` map, 5000 target vertices:
5060 vertices (uniform; 5128 adaptive), 4 boundary loops, edge-manifold, oriented; distance
of the vertices to the true mesh at most 0.46% of the bounding-box diagonal; minimum angle
22 degrees (24 adaptive); about a second.

Where loops touch
-----------------
Boundary detection can return loops that pass through one point twice (a hole touching the
rim or another hole at one point, or a rim pinched at one point; :mod:`pcgeom.apps.boundary`).
gmsh cannot mesh a polygon through a point twice, so each visit of such a point becomes its
own mesh vertex, moved a tenth of its shorter loop edge (:data:`TOUCH_STEP`) into its own
corner of the region (along the corner's bisector; the corner runs counter-clockwise from the
visit's outgoing edge to the next loop edge at the point). The copies are lifted like any vertex, so
the mesh's loops touch in 3D only up to that step: it stays edge-manifold, with one boundary
loop per detected loop. Loops that share an edge are refused (detection never makes them).

Where the map folds (a bare cloud whose sheets touch), the kept triangles overlap in the map
and the detected loops can cross themselves and each other, which gmsh cannot mesh (it does
not fail: it runs on). Such loops are repaired first: the region is the outer polygon minus
the union of the holes, each made valid by shapely (``make_valid``), shrunk by a thousandth
of the median loop edge (:data:`REPAIR_SHRINK`) so that no two rings share a point (a hole
that touched the rim then opens into it), and meshed part by part, largest first, without
the slivers under a hundredth of the largest part (:data:`REPAIR_MIN_PART`), and with the
ring points closer than a fifth of the median loop edge to their predecessor merged away
where the region stays valid (:data:`REPAIR_MIN_EDGE`: crossings leave such short edges, and
gmsh slivers at them); the mesh's loops are then those of the repaired region, which the
report counts. On face_human_choi as a bare cloud (its ``fast`` map folds 3.45% of the triangles),
11 pairs of its 19 detected holes overlap and 4 cross themselves.

Orientation: every triangle is counter-clockwise in the map, so the 3D mesh is consistently
oriented wherever the map is one-to-one (its normal is the one the map's orientation gives).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..cloud import _one_line, validate_faces, validate_points
from ..errors import InputError
from ..io import check_writable, write_atomic, write_ply_atomic
from .boundary import BoundaryLoops, _validate_map

__all__ = ["reconstruct_surface", "reconstruct_on_domain", "lift", "mesh_region",
           "mesh_domain", "map_delaunay", "mesh_report", "SIZES",
           "require_gmsh", "MESH_FORMATS", "check_mesh_path", "write_mesh"]

SIZES = ("uniform", "adaptive")
"""Mesh size rules that :func:`reconstruct_surface` implements."""


GMSH_INSTALL = "pip install 'gmsh>=4.11'"
GMSH_SYSTEM_LIBS = "libgl1 libglu1-mesa libxcursor1 libxft2 libxinerama1"


def require_gmsh():
    """The ``gmsh`` module, or an ImportError that says how to get it.

    Call it before any long work (the CLI does, before training) so a missing gmsh fails
    first.

    Raises
    ------
    ImportError
        gmsh is not installed (the message names ``pip install 'gmsh>=4.11'``), or its shared
        library cannot load (the message names the system libraries it needs on Debian or
        Ubuntu).
    """
    try:
        import gmsh
    except ImportError as exc:
        raise ImportError(f"surface reconstruction needs gmsh: {GMSH_INSTALL}") from exc
    except OSError as exc:  # the wheel is there but libgmsh cannot load its X/GL libraries
        raise ImportError(f"gmsh is installed but cannot load ({' '.join(str(exc).split())}); "
                          f"on Debian or Ubuntu: apt-get install {GMSH_SYSTEM_LIBS}") from exc
    return gmsh


_gmsh = require_gmsh  # the former private name, still imported by other modules

MESH_FORMATS = ("ply", "obj")
"""File formats :func:`write_mesh` writes, by extension."""


def check_mesh_path(path) -> Path:
    """``path`` as a Path, checked (before any work) to be a writable ``.ply`` or ``.obj``.

    Raises
    ------
    InputError
        Another extension (the message lists :data:`MESH_FORMATS`), or anything
        :func:`pcgeom.io.check_writable` refuses.
    """
    ext = Path(path).suffix.lower().lstrip(".")
    if ext not in MESH_FORMATS:
        got = repr(Path(path).suffix) if ext else "none"
        raise InputError(f"{os.fspath(path)}: mesh output must have extension "
                         f"{' or '.join('.' + f for f in MESH_FORMATS)}, got {got}")
    return check_writable(path, ext)


def write_mesh(path, V, F) -> Path:
    """Write the triangle mesh ``(V, F)`` atomically, in the format of ``path``'s extension.

    ``.ply``: binary PLY (:func:`pcgeom.io.write_ply_atomic`, float64 coordinates, exact).
    ``.obj``: Wavefront OBJ from trimesh's exporter, vertices and faces only, coordinates
    with 17 decimal places: rounded by at most 5e-18, so exact in float64 for magnitudes of
    0.1 or more.

    Parameters
    ----------
    path : str or os.PathLike
    V : (K, 3) array_like
    F : (M, 3) array_like of int

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    InputError
        A bad path (:func:`check_mesh_path`), no faces, or bad faces
        (:func:`pcgeom.cloud.validate_faces`).
    ValueError
        Vertices of the wrong shape or not finite.
    """
    path = check_mesh_path(path)
    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 3:
        raise ValueError(f"V: expected shape (K, 3), got {V.shape}")
    if not np.isfinite(V).all():
        raise ValueError("V: contains NaN or inf")
    F = validate_faces(F, len(V), name="F", allow_empty=False)
    if path.suffix.lower() == ".ply":
        write_ply_atomic(path, V, F)
        return path
    import trimesh
    from trimesh.exchange.obj import export_obj

    from .._version import __version__

    mesh = trimesh.Trimesh(vertices=V, faces=F, process=False)  # process=False: keep rows
    text = export_obj(mesh, include_normals=False, include_color=False, include_texture=False,
                      digits=17, header=f"pcgeom {__version__}")
    write_atomic(path, lambda f: f.write(text.encode("utf-8")))
    return path


TOUCH_STEP = 0.1
"""Where loops touch, each visit of the shared point moves this fraction of its shorter loop
edge into its own corner of the region (module docstring)."""

REPAIR_SHRINK = 1e-3
"""Loops that cross (a folded map) are repaired into a region shrunk by this fraction of the
median loop edge, so that its rings share no point."""

REPAIR_MIN_EDGE = 0.2
"""In a repaired region, ring points closer than this fraction of the median loop edge to
the previous point are merged away (the crossings leave such edges; gmsh slivers at them)."""

REPAIR_MIN_PART = 0.01
"""Parts of a repaired region smaller than this fraction of the largest are left out (the
slivers between crossing loops)."""


def _polygons(U: np.ndarray, loops: BoundaryLoops) -> list[list[np.ndarray]]:
    """The region inside ``loops`` (one outer loop minus its holes) as simple map polygons:
    a list of parts, each its outer ring (counter-clockwise) and its holes (clockwise), with
    every point that rings share split into one copy per visit (module docstring)."""
    if not loops.loops:
        raise InputError("loops: no boundary loop; the reconstruction would be empty")
    rows = np.concatenate(loops.loops)
    if rows.min() < 0 or rows.max() >= len(U):
        raise InputError(f"loops: rows out of range for a map of {len(U)} points")
    edges = np.sort(np.concatenate([np.column_stack([loop, np.roll(loop, -1)])
                                    for loop in loops.loops]), axis=1)
    pairs, counts = np.unique(edges, axis=0, return_counts=True)
    if (counts > 1).any():
        a, b = pairs[counts > 1][0]
        raise InputError(f"loops: the edge of rows {int(a)} and {int(b)} is on loops twice; "
                         "loops may touch at points but not share edges")
    if loops.areas[0] <= 0:
        raise InputError("loops: the first loop must be the outer loop (counter-clockwise)")
    islands = [i for i, a in enumerate(loops.areas[1:], 1) if a > 0]
    if islands:
        raise InputError(f"loops: {len(islands)} more counter-clockwise loop(s) (separate "
                         "patches of the map); only one outer loop and its holes are supported")
    rings = [U[loop] for loop in loops.loops]
    if _simple_region(rings):
        parts = _split_shared([rings])
        if _valid(parts):
            return parts
    edge = float(np.median(np.concatenate([np.linalg.norm(np.roll(r, -1, axis=0) - r, axis=1)
                                           for r in rings])))
    parts = _repaired(rings, REPAIR_SHRINK * edge)
    # Crossing points make edges far shorter than the spacing, and gmsh slivers at them:
    # merge them away where the region stays valid.
    for i, part in enumerate(parts):
        for j in range(len(part)):  # ring by ring, each merge kept if its part stays valid
            trial = part[:j] + [_merge_short(part[j], REPAIR_MIN_EDGE * edge)] + part[j + 1:]
            if _valid([trial]):
                part = trial
        parts[i] = part
    if not _valid(parts):
        raise InputError("loops: the region inside the loops could not be made into simple "
                         "polygons for gmsh (the map folds there)")
    return parts


def _merge_short(ring: np.ndarray, min_edge: float) -> np.ndarray:
    """``ring`` without the points closer than ``min_edge`` to the previous kept point (at
    least 3 points stay)."""
    keep = [0]
    for k in range(1, len(ring)):
        if np.linalg.norm(ring[k] - ring[keep[-1]]) >= min_edge:
            keep.append(k)
    if len(keep) > 1 and np.linalg.norm(ring[keep[-1]] - ring[0]) < min_edge:
        keep.pop()
    return ring[keep] if len(keep) >= 3 else ring


def _valid(parts: list[list[np.ndarray]]) -> bool:
    """Every part a valid polygon (shapely), and no ring point used twice."""
    from shapely.geometry import Polygon

    allpts = np.concatenate([r for rings in parts for r in rings])
    if len(np.unique(allpts, axis=0)) < len(allpts):
        return False
    return all(Polygon(rings[0], rings[1:]).is_valid for rings in parts)


def _simple_region(rings: list[np.ndarray]) -> bool:
    """Whether the outer ring and the holes are simple, the holes inside the outer ring and
    apart from each other (touching at points allowed): what gmsh can mesh once the shared
    points are split."""
    from shapely import STRtree
    from shapely.geometry import LinearRing, Polygon

    if not all(LinearRing(r).is_simple for r in rings):
        return False
    outer = Polygon(rings[0])
    holes = [Polygon(r) for r in rings[1:]]
    if not all(outer.covers(h) for h in holes):
        return False
    tree = STRtree(holes)
    for i, h in enumerate(holes):
        for j in tree.query(h):
            if j > i and h.intersection(holes[j]).area > 0:
                return False
    return True


def _repaired(rings: list[np.ndarray], shrink: float) -> list[list[np.ndarray]]:
    """Where the map folds, detected loops can cross themselves and each other: the region is
    then the outer polygon minus the union of the holes, each made valid by shapely
    (``make_valid``: a self-crossing ring becomes the polygons it bounds), shrunk by
    ``shrink`` (map units) so that no two rings share a point; its parts of at least
    :data:`REPAIR_MIN_PART` of the largest one's area, largest first."""
    from shapely import make_valid, unary_union
    from shapely.geometry import Polygon
    from shapely.geometry.polygon import orient

    def valid(ring):
        return make_valid(Polygon(ring))

    region = valid(rings[0]).difference(unary_union([valid(r) for r in rings[1:]]))
    region = region.buffer(-shrink, join_style="mitre")
    parts = sorted((g for g in getattr(region, "geoms", [region])
                    if g.geom_type == "Polygon" and g.area > 0), key=lambda g: -g.area)
    if not parts:
        raise InputError("loops: the holes cover the outer loop; the reconstruction would be "
                         "empty")
    out = []
    for part in parts:
        if part.area < REPAIR_MIN_PART * parts[0].area:
            break
        part = orient(part, 1.0)  # exterior counter-clockwise, holes clockwise
        out.append([np.asarray(part.exterior.coords)[:-1]]
                   + [np.asarray(h.coords)[:-1] for h in part.interiors])
    return out


def _split_shared(parts: list[list[np.ndarray]]) -> list[list[np.ndarray]]:
    """Each ring point that appears more than once (in one ring or several) moved into its
    own corner of the region at each visit.

    The region is on the left of every ring edge, so at a visit of point ``v`` (on to ``q``)
    it fills the corner counter-clockwise from ``v -> q`` to the next ring edge at ``v``, of
    any visit (as boundary detection walks). The copy goes along that corner's bisector,
    :data:`TOUCH_STEP` times the shorter of the visit's two edges: the corners of the visits
    do not overlap, so the copies are distinct and the rings simple.
    """
    visits: dict[tuple, list] = {}  # point -> [(part, ring, k, angle out, angle back)]
    for i, rings in enumerate(parts):
        for j, ring in enumerate(rings):
            nxt, prv = np.roll(ring, -1, axis=0) - ring, np.roll(ring, 1, axis=0) - ring
            a_out = np.arctan2(nxt[:, 1], nxt[:, 0])
            a_back = np.arctan2(prv[:, 1], prv[:, 0])
            step = TOUCH_STEP * np.minimum(np.linalg.norm(nxt, axis=1),
                                           np.linalg.norm(prv, axis=1))
            for k, key in enumerate(map(tuple, ring.tolist())):
                visits.setdefault(key, []).append((i, j, k, a_out[k], a_back[k], step[k]))
    out = [[ring.copy() for ring in rings] for rings in parts]
    for key, here in visits.items():
        if len(here) < 2:
            continue
        angles = np.array([a for v in here for a in (v[3], v[4])])  # every edge at the point
        for i, j, k, a_out, _, step in here:
            turn = (angles - a_out) % (2 * np.pi)
            turn[turn < 1e-12] = 2 * np.pi  # its own outgoing edge bounds the corner last
            angle = a_out + 0.5 * turn.min()
            out[i][j][k] = np.asarray(key) + step * np.array([np.cos(angle), np.sin(angle)])
    return out


def _gmsh_mesh(parts: list[list[np.ndarray]], size: float,
               relative=None) -> tuple[np.ndarray, np.ndarray]:
    """One gmsh session: the plane regions ``parts`` (each an outer ring and its holes)
    meshed with element size ``size``, times ``relative(x, y)`` where that callable is
    given.

    Returns the 2D vertices (K, 2) and the triangles (M, 3) int64, counter-clockwise.
    """
    gmsh = require_gmsh()
    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("pcgeom_region")
        geo = gmsh.model.geo
        for polygons in parts:
            curve_loops = []
            for poly in polygons:
                points = [geo.addPoint(float(x), float(y), 0.0, size) for x, y in poly]
                lines = [geo.addLine(points[k], points[(k + 1) % len(points)])
                         for k in range(len(points))]
                curve_loops.append(geo.addCurveLoop(lines))
            geo.addPlaneSurface(curve_loops)  # the first loop bounds it, the others are holes
        geo.synchronize()
        if relative is None:
            gmsh.option.setNumber("Mesh.MeshSizeMin", size)
            gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        else:
            gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
            gmsh.model.mesh.setSizeCallback(
                lambda dim, tag, x, y, z, lc: size * float(relative(x, y)))
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        # The size inside must not be interpolated from the loop segments' lengths (that
        # would tie the vertex count to how many times each segment is split).
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.model.mesh.generate(2)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        types, _, node_tags = gmsh.model.mesh.getElements(2)
    finally:
        gmsh.finalize()
    if 2 not in list(types):
        raise InputError("gmsh made no triangles; the reconstruction would be empty")
    index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    index[tags.astype(np.int64)] = np.arange(len(tags))
    T = index[np.asarray(node_tags[list(types).index(2)], dtype=np.int64).reshape(-1, 3)]
    Q = np.asarray(coords, dtype=np.float64).reshape(-1, 3)[:, :2]
    used = np.unique(T)  # gmsh keeps geometry-only nodes; drop any that no triangle uses
    remap = np.full(len(Q), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    Q, T = Q[used], remap[T]
    flip = _signed_area2(Q, T) < 0
    T[flip] = T[flip][:, [0, 2, 1]]
    return Q, T


def _signed_area2(U: np.ndarray, T: np.ndarray) -> np.ndarray:
    a, b, c = U[T[:, 0]], U[T[:, 1]], U[T[:, 2]]
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


def _polygon_area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def mesh_region(U, loops: BoundaryLoops, target_vertices: int,
                relative_size=None) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate the region of the map inside ``loops`` with about ``target_vertices``
    vertices (module docstring).

    Parameters
    ----------
    U : (N, 2) array_like
        The map.
    loops : BoundaryLoops
        From :func:`pcgeom.apps.boundary.detect_boundary`: one outer loop and its holes.
    target_vertices : int
        Wanted vertex count (>= 3); loop points are all kept, so a mesh has at least as
        many vertices as the loops have points.
    relative_size : (N,) array_like, optional
        Relative element size at each map point (positive); between the points, the mean of
        the 8 nearest points' values. Default: uniform.

    Returns
    -------
    Q : (K, 2) float64
        Vertices in the map; the loops' points are among them (moved a little where loops
        touch or cross: module docstring).
    T : (M, 3) int64
        Triangles, counter-clockwise in the map.
    """
    U = _validate_map(U)
    if (isinstance(target_vertices, bool) or not isinstance(target_vertices, (int, np.integer))
            or target_vertices < 3):
        raise InputError(f"target_vertices: expected an integer >= 3, got {target_vertices!r}")
    polygons = _polygons(U, loops)
    area = sum(_polygon_area(p) for part in polygons for p in part)  # holes: negative
    if area <= 0:
        raise InputError("loops: the holes cover the outer loop; the reconstruction would be empty")
    relative, density = _relative(U, relative_size)
    return _mesh_to_target(lambda size: polygons, area, target_vertices, relative, density)


def _relative(U: np.ndarray, relative_size):
    """The size callback of a relative size given at the map points (the mean of the 8
    nearest points' values) and the mean of its inverse square, or (None, 1) for uniform."""
    if relative_size is None:
        return None, 1.0
    from scipy.spatial import cKDTree

    r = np.asarray(relative_size, dtype=np.float64)
    if r.shape != (len(U),) or not (np.isfinite(r).all() and (r > 0).all()):
        raise InputError(f"relative_size: expected {len(U)} finite positive values")
    tree, k = cKDTree(U), min(8, len(U))

    def relative(x: float, y: float) -> float:
        return r[tree.query((x, y), k=k)[1]].mean()

    return relative, float(np.mean(r**-2.0))  # vertices per area scale with r^-2


def _mesh_to_target(polygons_at, area: float, target_vertices: int, relative,
                    density: float) -> tuple[np.ndarray, np.ndarray]:
    """gmsh meshes of ``polygons_at(size)`` (the parts to mesh at element size ``size``)
    with the size corrected until the vertex count is within 10% of ``target_vertices``
    (at most three meshes; module docstring)."""
    size = np.sqrt(2.0 * area * density / (np.sqrt(3.0) * target_vertices))
    Q, T = _gmsh_mesh(polygons_at(size), size, relative)
    if abs(len(Q) - target_vertices) <= 0.1 * target_vertices:
        return Q, T
    # Correct from the measured count: first with the interior's law (count ~ size^-2), then,
    # if still off by more than 10%, with the exponent measured between the two meshes (the
    # fixed loop points make the count fall slower than size^-2).
    size1 = size * np.sqrt(len(Q) / target_vertices)
    Q1, T1 = _gmsh_mesh(polygons_at(size1), size1, relative)
    if abs(len(Q1) - target_vertices) <= 0.1 * target_vertices or len(Q1) == len(Q):
        return Q1, T1
    p = float(np.clip(np.log(len(Q1) / len(Q)) / np.log(size / size1), 0.5, 3.0))
    size2 = size1 * (len(Q1) / target_vertices) ** (1.0 / p)
    return _gmsh_mesh(polygons_at(size2), size2, relative)


def lift(points, U, triangles, Q) -> tuple[np.ndarray, np.ndarray]:
    """Lift map points ``Q`` to 3D by barycentric interpolation over ``triangles``.

    Parameters
    ----------
    points : (N, 3) array_like
        The cloud.
    U : (N, 2) array_like
        Its map.
    triangles : (M, 3) array_like of int
        Triangles of the map (rows of ``U``) that do not overlap, e.g.
        ``BoundaryLoops.triangles``.
    Q : (K, 2) array_like
        Points to lift.

    Returns
    -------
    V : (K, 3) float64
        The lifted points.
    outside : (K,) bool
        Points in no triangle, lifted from the nearest point of the triangles' boundary
        edges (module docstring).
    """
    import matplotlib.tri as mtri
    from scipy.spatial import cKDTree

    P = np.asarray(points, dtype=np.float64)
    U = np.asarray(U, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64)
    Q = np.asarray(Q, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or U.shape != (len(P), 2):
        raise InputError(f"points, U: expected shapes (N, 3) and (N, 2), got {P.shape} and "
                         f"{U.shape}")
    if Q.ndim != 2 or Q.shape[1] != 2:
        raise InputError(f"Q: expected shape (K, 2), got {Q.shape}")
    if len(T) == 0:
        raise InputError("triangles: none; the reconstruction would be empty")
    used, local = np.unique(T, return_inverse=True)
    local = local.reshape(-1, 3)
    tri = mtri.Triangulation(U[used, 0], U[used, 1], local)
    found = np.asarray(tri.get_trifinder()(Q[:, 0], Q[:, 1]), dtype=np.int64)  # -1: outside
    V = np.empty((len(Q), 3))
    inside = found >= 0
    t = T[found[inside]]  # (k, 3)
    ab, ac, aq = (U[t[:, 1]] - U[t[:, 0]], U[t[:, 2]] - U[t[:, 0]],
                  Q[inside] - U[t[:, 0]])  # (k, 2) each
    det = ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0]  # twice the signed area
    wb = (aq[:, 0] * ac[:, 1] - aq[:, 1] * ac[:, 0]) / det
    wc = (ab[:, 0] * aq[:, 1] - ab[:, 1] * aq[:, 0]) / det
    wa = 1.0 - wb - wc
    V[inside] = wa[:, None] * P[t[:, 0]] + wb[:, None] * P[t[:, 1]] + wc[:, None] * P[t[:, 2]]

    outside = ~inside
    if outside.any():
        # Boundary edges of the triangles: directed edges whose reverse is not an edge.
        half = np.stack([T, np.roll(T, -1, axis=1)], axis=2).reshape(-1, 2)
        K = int(T.max()) + 1
        key = half[:, 0] * K + half[:, 1]
        E = half[~np.isin(half[:, 1] * K + half[:, 0], key)]  # (E, 2)
        A, B = U[E[:, 0]], U[E[:, 1]]
        # Candidates: the edges with the nearest midpoints; an edge is never longer than
        # the span of the candidates' midpoints in practice, and 32 leaves a wide margin.
        k = min(32, len(E))
        _, cand = cKDTree(0.5 * (A + B)).query(Q[outside], k=k)
        cand = np.asarray(cand).reshape(-1, k)  # (o, k)
        q = Q[outside][:, None, :]  # (o, 1, 2)
        d = B[cand] - A[cand]  # (o, k, 2)
        s = np.clip(np.sum((q - A[cand]) * d, axis=2)
                    / np.maximum(np.sum(d * d, axis=2), np.finfo(float).tiny), 0.0, 1.0)
        dist = np.linalg.norm(A[cand] + s[..., None] * d - q, axis=2)  # (o, k)
        best = np.argmin(dist, axis=1)
        e = cand[np.arange(len(cand)), best]
        s = s[np.arange(len(cand)), best][:, None]
        V[outside] = (1.0 - s) * P[E[e, 0]] + s * P[E[e, 1]]
    return V, outside


def mesh_report(V, F, points) -> dict:
    """Quality of a reconstructed mesh ``(V, F)`` against its cloud ``points``.

    Returns a dict: ``n_vertices``, ``n_faces``, ``n_boundary_loops`` (libigl),
    ``edge_manifold`` (libigl), ``oriented`` (no directed edge used twice: neighbours agree),
    ``hausdorff_rel`` and ``mean_distance_rel`` (the largest and the mean distance from each
    mesh *vertex* to its nearest cloud point, vertex-to-point, over the cloud's bounding-box
    diagonal; a vertex between cloud points is up to half a spacing from every point even on
    the true surface), ``min_angle_deg`` and ``max_aspect_ratio`` (circumradius over twice
    the inradius, 1 for an equilateral triangle) of the triangles in 3D.
    """
    import igl
    from scipy.spatial import cKDTree

    V = np.asarray(V, dtype=np.float64)
    F = np.ascontiguousarray(F, dtype=np.int64)
    P = np.asarray(points, dtype=np.float64)
    manifold = bool(igl.is_edge_manifold(F)[0])
    half = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    oriented = len(np.unique(half, axis=0)) == len(half)
    loops = igl.boundary_loop_all(F) if manifold else []
    diag = float(np.linalg.norm(P.max(axis=0) - P.min(axis=0)))
    dist, _ = cKDTree(P).query(V, k=1)
    L = np.linalg.norm(V[F] - V[np.roll(F, -1, axis=1)], axis=2)  # (M, 3), edge k opposite k+2
    a, b, c = L[:, 0], L[:, 1], L[:, 2]
    area = 0.25 * np.sqrt(np.maximum((a + b + c) * (-a + b + c) * (a - b + c) * (a + b - c), 0))
    cos = np.clip(np.stack([(b**2 + c**2 - a**2) / (2 * b * c), (a**2 + c**2 - b**2) / (2 * a * c),
                            (a**2 + b**2 - c**2) / (2 * a * b)], axis=1), -1.0, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        aspect = (a * b * c / (4 * area)) / (2 * area / (0.5 * (a + b + c)))
    return {
        "n_vertices": len(V),
        "n_faces": len(F),
        "n_boundary_loops": len(loops),
        "boundary_loop_vertices": [len(loop) for loop in loops],
        "edge_manifold": manifold,
        "oriented": bool(oriented),
        "hausdorff_rel": float(dist.max() / diag),
        "mean_distance_rel": float(dist.mean() / diag),
        "min_angle_deg": float(np.degrees(np.arccos(cos).min())),
        "max_aspect_ratio": float(np.nan_to_num(aspect, nan=np.inf).max()),
    }


def reconstruct_surface(points, U, loops: BoundaryLoops, *, size: str = "uniform",
                        target_vertices: int = 5000, lambda_inv=None):
    """Triangle mesh of the surface sampled by ``points``, remeshed in its free-boundary map.

    Parameters
    ----------
    points : (N, 3) array_like
        The cloud.
    U : (N, 2) array_like
        Its free-boundary map (``ParamResult.uv``).
    loops : BoundaryLoops
        ``detect_boundary(U)``: its loops bound the meshed region (one outer loop and its
        holes) and its kept triangles lift the new vertices to 3D.
    size : {"uniform", "adaptive"}
        Mesh size rule (module docstring). ``"adaptive"``: element size proportional to
        ``lambda_inv ** -0.5`` (the issue's lambda-adaptive rule), smoothed over the 8
        nearest points.
    target_vertices : int
        About how many vertices the mesh gets (measured within 20% on the tests; at least the
        loops' points).
    lambda_inv : (N,) array_like, optional
        ``ParamResult.lambda_inv``; needed by ``"adaptive"``, unused by ``"uniform"``.

    Returns
    -------
    V : (K, 3) float64
    F : (M, 3) int64
        Edge-manifold when the loops are simple, counter-clockwise in the map.
    report : dict
        :func:`mesh_report`, plus ``n_outside`` (vertices lifted by the outside rule),
        ``size`` and ``target_vertices``.

    Raises
    ------
    InputError
        Bad shapes, an unknown ``size``, no loop, loops sharing an edge, more than one outer
        loop, or an empty region.
    ImportError
        gmsh is not installed (the message names the install command).
    """
    P, U, relative = _checked_input(points, U, size, lambda_inv)
    if not isinstance(loops, BoundaryLoops):
        raise TypeError(f"loops: expected BoundaryLoops (from detect_boundary), "
                        f"got {type(loops).__name__}")
    try:
        Q, F = mesh_region(U, loops, target_vertices, relative)
    except Exception as exc:
        if isinstance(exc, (InputError, ImportError)):
            raise
        raise InputError(f"gmsh could not mesh the region: {_one_line(exc)}") from None
    V, outside = lift(P, U, loops.triangles, Q)
    report = mesh_report(V, F, P)
    report.update(n_outside=int(outside.sum()), size=size, target_vertices=int(target_vertices))
    return V, F, report


def _checked_input(points, U, size: str, lambda_inv) -> tuple[np.ndarray, np.ndarray, object]:
    """The cloud, its map and the relative element size of ``size`` (None: uniform)."""
    if size not in SIZES:
        raise InputError(f"size: expected one of {', '.join(SIZES)}, got {size!r}")
    P = validate_points(points, name="points")
    U = _validate_map(U)
    if len(U) != len(P):
        raise InputError(f"U: expected {len(P)} rows (one per point), got {len(U)}")
    if size != "adaptive":
        return P, U, None
    if lambda_inv is None:
        raise InputError("lambda_inv: needed by size='adaptive' (ParamResult.lambda_inv)")
    lam = np.asarray(lambda_inv, dtype=np.float64)
    if lam.shape != (len(P),) or not (np.isfinite(lam).all() and (lam > 0).all()):
        raise InputError(f"lambda_inv: expected {len(P)} finite positive values, "
                         f"got shape {lam.shape}")
    return P, U, lam**-0.5


CORNER_DEG = 15.0
"""A domain polyline's vertex where it turns by more than this is a corner, kept when the
polyline is resampled to the element size (:func:`mesh_domain`)."""


def _resample(loop: np.ndarray, size: float) -> np.ndarray:
    """A closed polyline (last row = first) resampled by arc length to about one point per
    ``size``, through its corners (turns over :data:`CORNER_DEG`); at least 3 points."""
    ring = loop[:-1] if np.allclose(loop[0], loop[-1]) else loop
    d_out = np.roll(ring, -1, axis=0) - ring
    d_in = ring - np.roll(ring, 1, axis=0)
    turn = np.abs(np.arctan2(d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0],
                             np.einsum("ij,ij->i", d_in, d_out)))
    corners = np.flatnonzero(turn > np.radians(CORNER_DEG))
    if len(corners) == 0:
        corners = np.array([0])
    out = []
    for a, b in zip(corners, np.roll(corners, -1)):
        # The run of polyline from corner a to the next corner b (all the way round if one).
        idx = np.arange(a, a + ((b - a) % len(ring) or len(ring)) + 1) % len(ring)
        run = ring[idx]
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(run, axis=0), axis=1))])
        n = max(1, int(round(s[-1] / size)), 3 if len(corners) == 1 else 1)
        t = np.linspace(0.0, s[-1], n + 1)[:-1]  # the next corner starts the next run
        out.append(np.column_stack([np.interp(t, s, run[:, 0]), np.interp(t, s, run[:, 1])]))
    return np.concatenate(out)


def mesh_domain(domain, target_vertices: int, U=None,
                relative_size=None) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate a bounded domain with about ``target_vertices`` vertices.

    The domain's boundary polylines (:meth:`pcgeom.domains.Domain.boundary_loops`; arcs are
    fine polylines) are resampled to the element size through their corners, so the mesh
    size does not depend on how finely the domain draws its arcs.

    Parameters
    ----------
    domain : Domain
        A bounded domain (``domain.bounded``).
    target_vertices : int
        Wanted vertex count (>= 3).
    U : (N, 2) array_like, optional
        Map points at which ``relative_size`` is given.
    relative_size : (N,) array_like, optional
        Relative element size at the points ``U`` (as in :func:`mesh_region`).

    Returns
    -------
    Q : (K, 2) float64
    T : (M, 3) int64
        Counter-clockwise.
    """
    from ..domains import Domain

    if not isinstance(domain, Domain):
        raise TypeError(f"domain: expected a Domain (pcgeom.get_domain), "
                        f"got {type(domain).__name__}")
    if not domain.bounded:
        raise InputError(f"domain: expected a bounded domain, got {domain.spec!r}; a "
                         "free-boundary map is meshed inside its detected loops "
                         "(reconstruct_surface)")
    if (isinstance(target_vertices, bool) or not isinstance(target_vertices, (int, np.integer))
            or target_vertices < 3):
        raise InputError(f"target_vertices: expected an integer >= 3, got {target_vertices!r}")
    loops = [np.asarray(loop, dtype=np.float64) for loop in domain.boundary_loops()]
    relative, density = (None, 1.0) if relative_size is None else _relative(
        _validate_map(U), relative_size)

    def polygons_at(size: float) -> list[list[np.ndarray]]:
        return _split_shared([[_resample(loop, size) for loop in loops]])

    return _mesh_to_target(polygons_at, float(domain.area), target_vertices, relative, density)


def map_delaunay(U) -> np.ndarray:
    """The Delaunay triangles of a map ``U`` (N, 2), as its rows (a duplicated map point by
    its first row), counter-clockwise. (M, 3) int64"""
    from ..cloud import deduplicate
    from .boundary import _delaunay

    U = _validate_map(U)
    unique, inverse = deduplicate(U)
    if len(unique) < 3:
        raise InputError(f"U: {len(unique)} distinct points (of {len(U)}), need at least 3")
    row = np.empty(len(unique), dtype=np.int64)
    row[inverse[::-1]] = np.arange(len(U))[::-1]  # first input row of each distinct point
    return row[_delaunay(unique)]


def reconstruct_on_domain(points, U, domain, *, size: str = "uniform",
                          target_vertices: int = 5000, lambda_inv=None):
    """Triangle mesh of the surface sampled by ``points``, remeshed on the bounded domain its
    map was made onto (e.g. ``pcgeom param X --domain disk``).

    1. The domain itself is meshed with gmsh (:func:`mesh_domain`), uniform or adaptive as in
       :func:`reconstruct_surface`.
    2. Each vertex is lifted to 3D by barycentric interpolation over the Delaunay
       triangulation of the map (:func:`map_delaunay`, :func:`lift`). A vertex outside its
       convex hull (between the mapped points and the domain's boundary) takes the nearest
       point of the hull's edges, as in :func:`lift`: the rim of the mesh is then the rim of
       the cloud, never extrapolated.

    The mesh's boundary is the domain's: one loop per domain loop, edge-manifold and
    counter-clockwise in the domain (so consistently oriented in 3D wherever the map is
    one-to-one). Where the cloud has holes that the map does not leave open (a map onto a
    disk covers the disk), the mesh bridges them.

    Parameters
    ----------
    points : (N, 3) array_like
    U : (N, 2) array_like
        Its map onto ``domain`` (``ParamResult.uv``).
    domain : Domain
        The bounded domain of the map (``ParamResult.domain``).
    size, target_vertices, lambda_inv
        As in :func:`reconstruct_surface`.

    Returns
    -------
    V : (K, 3) float64
    F : (M, 3) int64
    report : dict
        :func:`mesh_report`, plus ``n_outside``, ``n_domain_loops``, ``size``,
        ``target_vertices`` and ``domain`` (its spec).

    Raises
    ------
    InputError
        Bad shapes, an unknown ``size``, a free (unbounded) domain.
    ImportError
        gmsh is not installed.
    """
    P, U, relative = _checked_input(points, U, size, lambda_inv)
    try:
        Q, F = mesh_domain(domain, target_vertices, U, relative)
    except Exception as exc:
        if isinstance(exc, (InputError, ImportError, TypeError)):
            raise
        raise InputError(f"gmsh could not mesh the domain: {_one_line(exc)}") from None
    V, outside = lift(P, U, map_delaunay(U), Q)
    report = mesh_report(V, F, P)
    report.update(n_outside=int(outside.sum()), n_domain_loops=len(domain.boundary_loops()),
                  size=size, target_vertices=int(target_vertices), domain=domain.spec)
    return V, F, report
