"""gmsh meshes of plane regions, sized to a target vertex count: the map's region inside its
detected loops (:func:`mesh_region`) or a bounded domain (:func:`mesh_domain`).

Size: uniform, the element size ``s = sqrt(2 A / (sqrt(3) n))`` of ``n`` equilateral
triangles covering the area ``A``, then corrected from the vertex counts of up to two
trial meshes (the loop points, all kept, add vertices the formula does not see).
Adaptive: ``s * r(x)`` with ``r = lambda_inv ** -0.5`` (the issue's lambda-adaptive rule)
given to gmsh as a size callback, ``s`` from the same formula with the area weighted by
``mean(r ** -2)`` and the same correction. Under LEG's model (``|f(x) - f(y)|`` about
``|x - y| / (2 lambda_inv)``) a map size ``s`` is a surface size ``2 s lambda_inv``, so
this rule refines where the map compresses the surface, by the square root of the
compression.

Every triangle is counter-clockwise in the map.
"""

from __future__ import annotations

import threading

import numpy as np

from ...errors import InputError, _one_line
from ...mesh import shoelace, signed_areas
from ..boundary import BoundaryLoops
from ..planar import validate_map
from .polygons import _polygons, _resample, _split_shared

_GMSH_LOCK = threading.Lock()  # one gmsh session at a time in a process

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


def _gmsh_triangles(build, size: float, relative=None, *, model: str, empty: str
                    ) -> tuple[np.ndarray, np.ndarray]:
    """One gmsh session: ``build(gmsh)`` adds the geometry to the model ``model`` (and
    synchronizes it); it is meshed with element size ``size``, times ``relative(x, y, z)``
    where that callable is given.

    Returns the vertices (K, 3) that triangles use (gmsh keeps geometry-only nodes) and the
    triangles (M, 3) int64 as gmsh made them; :class:`InputError` ``empty`` when it made none.
    """
    gmsh = require_gmsh()
    # gmsh is one global session per process: threads of one process (a Dask worker's) take
    # turns. Its Python API installs a SIGINT handler, which only the main thread may do
    # ("signal only works in main thread"): elsewhere it is initialised without one.
    main = threading.current_thread() is threading.main_thread()
    with _GMSH_LOCK:
        gmsh.initialize(readConfigFiles=False, interruptible=main)
        try:
            return _meshed_session(gmsh, build, size, relative, model=model, empty=empty)
        finally:
            gmsh.finalize()


def _meshed_session(gmsh, build, size: float, relative, *, model: str, empty: str
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The body of :func:`_gmsh_triangles` inside an initialised gmsh session."""
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add(model)
    build(gmsh)
    if relative is None:
        gmsh.option.setNumber("Mesh.MeshSizeMin", size)
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    else:
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.model.mesh.setSizeCallback(
            lambda dim, tag, x, y, z, lc: size * float(relative(x, y, z)))
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    # The size inside must not be interpolated from the boundary segments' lengths (that
    # would tie the vertex count to how many times each segment is split).
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.model.mesh.generate(2)
    tags, coords, _ = gmsh.model.mesh.getNodes()
    types, _, node_tags = gmsh.model.mesh.getElements(2)
    if 2 not in list(types):
        raise InputError(empty)
    index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    index[tags.astype(np.int64)] = np.arange(len(tags))
    T = index[np.asarray(node_tags[list(types).index(2)], dtype=np.int64).reshape(-1, 3)]
    Q = np.asarray(coords, dtype=np.float64).reshape(-1, 3)
    used = np.unique(T)
    remap = np.full(len(Q), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return Q[used], remap[T]


def gmsh_meshed(what: str, mesher, *args, keep: tuple = (InputError, ImportError)):
    """``mesher(*args)``, an error of gmsh's (anything but ``keep``) turned into a one-line
    :class:`InputError` ``"gmsh could not mesh {what}: ..."``."""
    try:
        return mesher(*args)
    except keep:
        raise
    except Exception as exc:
        raise InputError(f"gmsh could not mesh {what}: {_one_line(exc)}") from None


def _gmsh_mesh(parts: list[list[np.ndarray]], size: float,
               relative=None) -> tuple[np.ndarray, np.ndarray]:
    """One gmsh session: the plane regions ``parts`` (each an outer ring and its holes)
    meshed with element size ``size``, times ``relative(x, y)`` where that callable is
    given.

    Returns the 2D vertices (K, 2) and the triangles (M, 3) int64, counter-clockwise.
    """

    def build(gmsh) -> None:
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

    Q, T = _gmsh_triangles(build, size, None if relative is None
                           else (lambda x, y, z: relative(x, y)), model="pcgeom_region",
                           empty="gmsh made no triangles; the reconstruction would be empty")
    Q = Q[:, :2]
    flip = signed_areas(Q, T) < 0
    T[flip] = T[flip][:, [0, 2, 1]]
    return Q, T


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
        touch or cross: :mod:`pcgeom.apps.reconstruct.polygons`).
    T : (M, 3) int64
        Triangles, counter-clockwise in the map.
    """
    U = validate_map(U)
    _check_target_vertices(target_vertices)
    polygons = _polygons(U, loops)
    area = sum(shoelace(p) for part in polygons for p in part)  # holes: negative
    if area <= 0:
        raise InputError("loops: the holes cover the outer loop; the reconstruction would be empty")
    relative, density = _relative(U, relative_size)
    return _mesh_to_target(lambda size: _gmsh_mesh(polygons, size, relative),
                           _first_size(area, density, target_vertices), target_vertices)


def _check_target_vertices(target_vertices) -> None:
    """InputError unless ``target_vertices`` is an integer >= 3 (a bool is not)."""
    if (isinstance(target_vertices, bool) or not isinstance(target_vertices, (int, np.integer))
            or target_vertices < 3):
        raise InputError(f"target_vertices: expected an integer >= 3, got {target_vertices!r}")


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


def _mesh_to_target(mesh_at, size: float,
                    target_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """The meshes ``mesh_at(size)`` with the element size corrected from ``size`` until the
    vertex count is within 10% of ``target_vertices`` (at most three meshes; module
    docstring)."""
    Q, T = mesh_at(size)
    if abs(len(Q) - target_vertices) <= 0.1 * target_vertices:
        return Q, T
    # Correct from the measured count: first with the interior's law (count ~ size^-2), then,
    # if still off by more than 10%, with the exponent measured between the two meshes (the
    # fixed loop points make the count fall slower than size^-2).
    size1 = size * np.sqrt(len(Q) / target_vertices)
    Q1, T1 = mesh_at(size1)
    if abs(len(Q1) - target_vertices) <= 0.1 * target_vertices or len(Q1) == len(Q):
        return Q1, T1
    p = float(np.clip(np.log(len(Q1) / len(Q)) / np.log(size / size1), 0.5, 3.0))
    size2 = size1 * (len(Q1) / target_vertices) ** (1.0 / p)
    return mesh_at(size2)


def _first_size(area: float, density: float, target_vertices: int) -> float:
    """``sqrt(2 A density / (sqrt(3) n))``: the size of ``n`` equilateral triangles over the
    area ``A`` (``density``: the mean of the relative size's inverse square)."""
    return float(np.sqrt(2.0 * area * density / (np.sqrt(3.0) * target_vertices)))


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
    from ...domains import Domain

    if not isinstance(domain, Domain):
        raise TypeError(f"domain: expected a Domain (pcgeom.get_domain), "
                        f"got {type(domain).__name__}")
    if not domain.bounded:
        raise InputError(f"domain: expected a bounded domain, got {domain.spec!r}; a "
                         "free-boundary map is meshed inside its detected loops "
                         "(reconstruct_surface)")
    _check_target_vertices(target_vertices)
    loops = [np.asarray(loop, dtype=np.float64) for loop in domain.boundary_loops()]
    relative, density = (None, 1.0) if relative_size is None else _relative(
        validate_map(U), relative_size)

    def polygons_at(size: float) -> list[list[np.ndarray]]:
        return _split_shared([[_resample(loop, size) for loop in loops]])

    return _mesh_to_target(lambda size: _gmsh_mesh(polygons_at(size), size, relative),
                           _first_size(float(domain.area), density, target_vertices),
                           target_vertices)
