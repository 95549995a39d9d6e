"""Closed genus-0 meshes from a map onto the unit sphere (``pcgeom param --domain sphere``):
the sphere itself meshed with gmsh and lifted to 3D by the interpolated inverse map.

1. The mapped points ``U`` (N, 3), unit vectors, are triangulated on the sphere: by the map's
   own mesh when it comes with one (``ParamResult.mesh_faces``), otherwise by the convex hull
   of ``U`` (the spherical Delaunay triangulation). Either must cover the sphere once
   (:func:`sphere_triangulation`): every triangle counter-clockwise seen from outside and
   their spherical areas summing to ``4 pi``. A map that folds fails there, before meshing.
2. The unit sphere is meshed with gmsh (OpenCASCADE's sphere, Frontal-Delaunay), uniform or
   adaptive as for the planar domains (:mod:`.gmsh_mesh`): element size ``s * r(q)`` with
   ``r = lambda_inv ** -0.5``, where ``lambda_inv`` is the map's compression, surface length
   per sphere length; without the map's own it is measured on the triangulation,
   ``lambda_inv_i = sqrt(A_i / S_i)`` with ``A_i`` and ``S_i`` the surface and spherical
   areas of point ``i``'s triangles (a third of each). ``s`` is corrected to the target
   vertex count from trial meshes.
3. Each sphere vertex ``q`` is located in a spherical triangle ``(a, b, c)`` of step 1 and
   lifted by the barycentric coordinates of its central projection onto the flat triangle:
   ``w = (det(q, b, c), det(a, q, c), det(a, b, q)) / sum``, all >= 0 inside, and
   ``p = w . (X_a, X_b, X_c)``: the cloud's flat triangle through the map (``"linear"``),
   never extrapolated. By default (``"phong"``) ``p`` is then curved by Phong tessellation
   with the cloud's angle-weighted normals on the same triangles (:func:`lift_sphere`): the
   flat triangles' sag between points, O(h^2) in the spacing h, was twice screened
   Poisson's mean distance to the true surface on clean analytic clouds (0.00021 of the
   diagonal against 0.00010, 5000 points); Phong's is O(h^3).
4. gmsh's triangles are oriented outward on the sphere; where the map reverses orientation
   (the lifted mesh's signed volume is negative) all are turned. The result is checked with
   trimesh: watertight, winding-consistent, Euler characteristic 2 (genus 0); anything else
   is an :class:`pcgeom.errors.InputError`, never a mesh returned.
"""

from __future__ import annotations

import numpy as np

from ...cloud import validate_points
from ...errors import InputError, _one_line
from .gmsh_mesh import (_check_target_vertices, _first_size, _gmsh_triangles, _mesh_to_target,
                        gmsh_meshed)
from .report import mesh_report

__all__ = ["reconstruct_on_sphere", "sphere_triangulation", "lift_sphere", "mesh_sphere",
           "sphere_compression", "vertex_normals", "closed_checks", "INTERPOLATIONS",
           "VERTICES_PER_POINT", "MAX_DEFAULT_VERTICES", "default_vertices"]

VERTICES_PER_POINT = 3
"""The default target vertex count of a closed mesh, per point of the cloud: about what
screened Poisson at its default depth 8 makes of a clean closed cloud (2.8-3.3 vertices per
point on 5k clouds of the sphere, ellipsoid, bumpy sphere and peanut, 1.7-3.2 on 20k ones,
2.0 on closed_david_head_choi; depth 10: 2.8-3.3 on the analytic clouds), so that the
default mesh is compared at the resolution of Poisson's default. At one vertex per point, Poisson
was the closer on the 5k
analytic clouds (BENCHMARKS.md, bench_reconstruct_sphere)."""

MAX_DEFAULT_VERTICES = 200_000
"""The default target vertex count's ceiling (Poisson's depth 8 is a 256-cell grid: at most
about 65k vertices on these shapes, whatever the cloud's size)."""


def default_vertices(n_points: int) -> int:
    """The default target vertex count of a closed mesh of ``n_points`` points:
    :data:`VERTICES_PER_POINT` per point, at most :data:`MAX_DEFAULT_VERTICES`."""
    return int(min(VERTICES_PER_POINT * int(n_points), MAX_DEFAULT_VERTICES))

UNIT_TOLERANCE = 1e-6
"""Largest ``| |u| - 1 |`` accepted of a sphere map's rows."""

COVER_TOLERANCE = 1e-6
"""Largest relative error of the spherical triangles' total area against ``4 pi``."""


def _sphere_map(U, n: int) -> np.ndarray:
    """``U`` as (n, 3) unit vectors, renormalised; InputError if it is not a sphere map."""
    U = np.asarray(U, dtype=np.float64)
    if U.ndim != 2 or U.shape[1] != 3:
        raise InputError(f"U: a sphere map has shape (N, 3), got {U.shape} (a planar map "
                         "has (N, 2): use its domain)")
    if len(U) != n:
        raise InputError(f"U: expected {n} rows (one per point), got {len(U)}")
    if not np.isfinite(U).all():
        raise InputError("U: contains NaN or inf")
    norm = np.linalg.norm(U, axis=1)
    worst = float(np.abs(norm - 1.0).max())
    if worst > UNIT_TOLERANCE:
        raise InputError(f"U: a sphere map's rows are unit vectors; one has length off by "
                         f"{worst:.3g}")
    return U / norm[:, None]


def _det(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Row-wise ``det(a, b, c) = a . (b x c)``. (..., 3) -> (...)"""
    return np.einsum("...i,...i->...", a, np.cross(b, c))


def _spherical_areas(U: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Signed areas of the spherical triangles ``U[T]`` (Van Oosterom and Strackee:
    ``tan(E / 2) = det(a, b, c) / (1 + a.b + b.c + c.a)``), positive when counter-clockwise
    seen from outside. (M,)"""
    a, b, c = U[T[:, 0]], U[T[:, 1]], U[T[:, 2]]
    den = 1.0 + np.sum(a * b, axis=1) + np.sum(b * c, axis=1) + np.sum(c * a, axis=1)
    return 2.0 * np.arctan2(_det(a, b, c), den)


def sphere_triangulation(U, faces=None) -> tuple[np.ndarray, str]:
    """Triangles of a sphere map that cover the sphere once, counter-clockwise from outside.

    Parameters
    ----------
    U : (N, 3) array_like
        Unit vectors.
    faces : (M, 3) array_like of int, optional
        The map's own triangulation (``ParamResult.mesh_faces``), either orientation: used
        when it covers the sphere once. None turned over and less than the whole sphere (a
        mesh with holes, or without some points): the convex hull instead, since the map is
        one-to-one on the mesh.
        Default: the convex hull of ``U`` (scipy's Qhull), the spherical Delaunay
        triangulation; a duplicated point is left out of it.

    Returns
    -------
    T : (M, 3) int64
        Rows of ``U``; ``det(U[a], U[b], U[c]) > 0`` for each (zero for a degenerate one of
        ``faces``).
    source : str
        ``"mesh_faces"``, ``"convex_hull"``, or ``"convex_hull (mesh_faces cover X pi)"``.

    Raises
    ------
    InputError
        The triangles overlap (some turned over against the others, or covering more than
        the sphere) or the hull leaves part of the sphere uncovered (areas summing to other
        than ``4 pi``: the points lie on one side of a plane through the centre): the map is
        not one-to-one.
    """
    U = np.asarray(U, dtype=np.float64)
    source = "convex_hull"
    if faces is not None:
        T = np.asarray(faces, dtype=np.int64)
        if T.ndim != 2 or T.shape[1] != 3 or len(T) == 0 or T.min() < 0 or T.max() >= len(U):
            raise InputError(f"faces: expected (M, 3) rows of U (0..{len(U) - 1}), "
                             f"got shape {T.shape}")
        if _spherical_areas(U, T).sum() < 0:  # the mesh is wound the other way
            T = T[:, [0, 2, 1]]
        areas = _spherical_areas(U, T)
        total = float(np.abs(areas).sum())
        if (areas < 0).any() or total > (1 + COVER_TOLERANCE) * 4 * np.pi:
            _overlap("mesh_faces", T, areas)
        if total >= (1 - COVER_TOLERANCE) * 4 * np.pi:
            return T, "mesh_faces"
        source = f"convex_hull (mesh_faces cover {total / np.pi:.3f} pi)"
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(U)
    except QhullError as exc:
        raise InputError(f"U: its convex hull fails ({_one_line(exc)}); the map does not "
                         "cover the sphere") from None
    T = np.asarray(hull.simplices, dtype=np.int64)
    a, b, c = U[T[:, 0]], U[T[:, 1]], U[T[:, 2]]
    outward = np.einsum("ij,ij->i", np.cross(b - a, c - a), hull.equations[:, :3]) > 0
    T[~outward] = T[~outward][:, [0, 2, 1]]
    areas = _spherical_areas(U, T)
    if (areas < 0).any() or abs(np.abs(areas).sum() - 4 * np.pi) > COVER_TOLERANCE * 4 * np.pi:
        _overlap("convex_hull", T, areas)
    return T, source


def _overlap(source: str, T: np.ndarray, areas: np.ndarray):
    """The one-line InputError of a triangulation that does not cover the sphere once."""
    raise InputError(f"the sphere map's triangulation ({source}) overlaps: "
                     f"{int((areas < 0).sum())} of {len(T)} triangles turned over, areas "
                     f"summing to {np.abs(areas).sum() / np.pi:.4f} pi (one cover is 4 pi); "
                     "the map is not one-to-one")


def sphere_compression(X, U, T) -> np.ndarray:
    """The map's compression at each point, surface length per sphere length:
    ``sqrt(A_i / S_i)``, ``A_i`` and ``S_i`` the surface (flat) and spherical areas of the
    point's triangles, a third of each. A point in no triangle (a duplicate left out of the
    hull) takes its nearest neighbour's value on the sphere. (N,) float64"""
    X, U, T = (np.asarray(A) for A in (X, U, T))
    flat = 0.5 * np.linalg.norm(np.cross(X[T[:, 1]] - X[T[:, 0]], X[T[:, 2]] - X[T[:, 0]]),
                                axis=1)
    sph = np.abs(_spherical_areas(U, T))
    A = np.bincount(T.ravel(), np.repeat(flat / 3, 3), minlength=len(U))
    S = np.bincount(T.ravel(), np.repeat(sph / 3, 3), minlength=len(U))
    good = (S > 0) & (A > 0)
    rho = np.empty(len(U))
    rho[good] = np.sqrt(A[good] / S[good])
    if not good.all():
        from scipy.spatial import cKDTree

        rho[~good] = rho[good][cKDTree(U[good]).query(U[~good])[1]]
    return rho


def _incident(T: np.ndarray, n: int) -> np.ndarray:
    """Triangles around each point, padded with -1. (n, max valence) int64"""
    order = np.argsort(T.ravel(), kind="stable")
    vert = T.ravel()[order]
    count = np.bincount(vert, minlength=n)
    start = np.concatenate([[0], np.cumsum(count)[:-1]])
    out = np.full((n, max(int(count.max()), 1)), -1, dtype=np.int64)
    out[vert, np.arange(len(vert)) - start[vert]] = order // 3
    return out


def _cone_coords(U: np.ndarray, T: np.ndarray, Q: np.ndarray, cand: np.ndarray) -> np.ndarray:
    """``(det(q, b, c), det(a, q, c), det(a, b, q))`` of each query against each candidate
    triangle, each over the length of its cross product (the sine of ``q``'s angle to that
    side's great circle). (K, C, 3) for ``cand`` (K, C); -inf where ``cand`` is -1."""
    t = T[np.maximum(cand, 0)]  # (K, C, 3)
    a, b, c = U[t[..., 0]], U[t[..., 1]], U[t[..., 2]]
    q = Q[:, None, :]
    out = np.empty(cand.shape + (3,))
    for k, (n1, n2) in enumerate(((b, c), (c, a), (a, b))):
        n = np.cross(n1, n2)
        out[..., k] = np.einsum("...i,...i->...", q, n) / np.maximum(
            np.linalg.norm(n, axis=-1), np.finfo(float).tiny)
    out[cand < 0] = -np.inf
    return out


def _locate_sphere(U: np.ndarray, T: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, int]:
    """For each unit vector of ``Q`` the row of ``T`` whose spherical triangle holds it (the
    one it is deepest in, on a shared side), and how many needed the search over all.

    Candidates: the triangles around the 6 nearest map points; a query in none of them (a
    long triangle of a map's own mesh) is tested against every triangle, in chunks."""
    from scipy.spatial import cKDTree

    k = min(6, len(U))
    around = _incident(T, len(U))
    _, near = cKDTree(U).query(Q, k=k)
    cand = around[np.asarray(near).reshape(len(Q), k)].reshape(len(Q), -1)  # (K, k * val)
    depth = _cone_coords(U, T, Q, cand).min(axis=2)  # (K, C)
    best = np.argmax(depth, axis=1)
    found = cand[np.arange(len(Q)), best]
    miss = np.flatnonzero(depth[np.arange(len(Q)), best] < -1e-12)
    every = np.arange(len(T))
    chunk = max(1, 2_000_000 // len(T))
    for lo in range(0, len(miss), chunk):
        rows = miss[lo:lo + chunk]
        all_t = np.broadcast_to(every, (len(rows), len(T)))
        found[rows] = np.argmax(_cone_coords(U, T, Q[rows], all_t).min(axis=2), axis=1)
    return found, len(miss)


INTERPOLATIONS = ("phong", "linear")
"""How :func:`lift_sphere` interpolates inside a cloud triangle (module docstring, step 3)."""

PHONG_ALPHA = 0.5
"""Phong tessellation's blend: 1/2 reproduces a quadratic surface exactly (to second order
in the normals' tilt), so the lift's error falls from O(h^2) to O(h^3) in the spacing h."""


def vertex_normals(X, T) -> np.ndarray:
    """Unit normals of the mesh ``(X, T)`` at its vertices, libigl's with each triangle
    weighted by its angle there (as :func:`pcgeom.maps.localmesh.mesh_normals`), oriented as
    the triangles are; zero at a point in no triangle. (N, 3) float64"""
    import igl

    found = igl.per_vertex_normals(np.ascontiguousarray(X, dtype=np.float64),
                                   np.ascontiguousarray(T, dtype=np.int64),
                                   igl.PER_VERTEX_NORMALS_WEIGHTING_TYPE_ANGLE)
    length = np.linalg.norm(found, axis=1, keepdims=True)
    ok = np.isfinite(length) & (length > 0.5)
    return np.where(ok, found / np.where(ok, length, 1.0), 0.0)


def lift_sphere(X, U, T, Q, *, interpolation: str = "phong",
                normals=None) -> tuple[np.ndarray, int]:
    """Lift unit vectors ``Q`` (K, 3) to 3D through the sphere map ``U`` of the cloud ``X``
    and its triangulation ``T`` (:func:`sphere_triangulation`), with the barycentric
    coordinates ``w`` of each ``q``'s central projection onto its triangle (module
    docstring, step 3).

    ``"linear"``: ``p = sum_i w_i X_i``, the cloud's flat triangles.
    ``"phong"`` (Phong tessellation, Boubekeur and Alexa 2008): ``p`` blended with its
    projections onto the tangent planes at the triangle's corners,
    ``(1 - alpha) p + alpha sum_i w_i (p - ((p - X_i) . n_i) n_i)``, ``alpha`` =
    :data:`PHONG_ALPHA`: exact on quadratic surfaces, a curved triangle through the same
    corners; along a side it depends on that side's two points alone, so neighbours agree.

    Parameters
    ----------
    normals : (N, 3) array_like, optional
        Unit normals at the cloud's points for ``"phong"`` (either sign); default
        :func:`vertex_normals` of ``(X, T)``.

    Returns
    -------
    V : (K, 3) float64
    searched : int
        Vertices located by the search over all triangles (not near their nearest points).
    """
    if interpolation not in INTERPOLATIONS:
        raise InputError(f"interpolation: expected one of {', '.join(INTERPOLATIONS)}, "
                         f"got {interpolation!r}")
    X, U, T, Q = (np.asarray(A) for A in (X, U, T, Q))
    found, searched = _locate_sphere(U, T, Q)
    t = T[found]  # (K, 3)
    a, b, c = U[t[:, 0]], U[t[:, 1]], U[t[:, 2]]
    w = np.maximum(np.stack([_det(Q, b, c), _det(a, Q, c), _det(a, b, Q)], axis=1), 0.0)
    s = w.sum(axis=1, keepdims=True)
    w = np.where(s > 0, w / np.where(s > 0, s, 1.0), 1.0 / 3.0)  # (K, 3)
    corners = X[t]  # (K, 3, 3): corner, coordinate
    p = np.einsum("kj,kji->ki", w, corners)
    if interpolation == "linear":
        return p, searched
    n = (vertex_normals(X, T) if normals is None else np.asarray(normals, dtype=np.float64))[t]
    height = np.einsum("kji,kji->kj", p[:, None, :] - corners, n)  # (K, 3) above each plane
    return p - PHONG_ALPHA * np.einsum("kj,kj,kji->ki", w, height, n), searched


def _gmsh_sphere(size: float, relative=None) -> tuple[np.ndarray, np.ndarray]:
    """One gmsh session: the unit sphere (OpenCASCADE) meshed with element size ``size``,
    times ``relative(x, y, z)`` where given. Returns the vertices (K, 3), on the sphere,
    and the triangles (M, 3) int64, counter-clockwise from outside."""

    def build(gmsh) -> None:
        gmsh.model.occ.addSphere(0.0, 0.0, 0.0, 1.0)
        gmsh.model.occ.synchronize()

    Q, T = _gmsh_triangles(build, size, relative, model="pcgeom_sphere",
                           empty="gmsh made no triangles on the sphere")
    Q /= np.linalg.norm(Q, axis=1, keepdims=True)
    a, b, c = Q[T[:, 0]], Q[T[:, 1]], Q[T[:, 2]]
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), a + b + c) < 0
    T[inward] = T[inward][:, [0, 2, 1]]
    return Q, T


def mesh_sphere(target_vertices: int, U=None, relative_size=None,
                weights=None) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate the unit sphere with about ``target_vertices`` vertices.

    Parameters
    ----------
    target_vertices : int
        Wanted vertex count (>= 3).
    U : (N, 3) array_like, optional
        Sphere points at which ``relative_size`` is given.
    relative_size : (N,) array_like, optional
        Relative element size at the points ``U`` (positive); between them, the mean of the
        8 nearest points' values. Default: uniform.
    weights : (N,) array_like, optional
        The spherical area each point stands for (for the first size guess: vertices per
        area scale with ``relative_size ** -2``); default equal.

    Returns
    -------
    Q : (K, 3) float64
        Unit vectors.
    T : (M, 3) int64
        Counter-clockwise seen from outside.
    """
    _check_target_vertices(target_vertices)
    relative, density = None, 1.0
    if relative_size is not None:
        from scipy.spatial import cKDTree

        U = np.asarray(U, dtype=np.float64)
        r = np.asarray(relative_size, dtype=np.float64)
        if r.shape != (len(U),) or not (np.isfinite(r).all() and (r > 0).all()):
            raise InputError(f"relative_size: expected {len(U)} finite positive values")
        tree, k = cKDTree(U), min(8, len(U))

        def relative(x: float, y: float, z: float) -> float:
            return r[tree.query((x, y, z), k=k)[1]].mean()

        w = np.ones(len(U)) if weights is None else np.asarray(weights, dtype=np.float64)
        density = float(np.sum(w * r**-2.0) / np.sum(w))
    return _mesh_to_target(lambda s: _gmsh_sphere(s, relative),
                           _first_size(4.0 * np.pi, density, target_vertices), target_vertices)


def closed_checks(V, F) -> dict:
    """trimesh's verdict on a closed mesh: ``watertight`` (every edge in exactly two
    triangles), ``winding_consistent`` (neighbours agree), ``euler_characteristic``
    (``V - E + F``) and ``genus`` (``(2 - chi) / 2``), on the rows as given (no merging)."""
    import trimesh

    mesh = trimesh.Trimesh(vertices=V, faces=F, process=False)
    chi = int(mesh.euler_number)
    return {"watertight": bool(mesh.is_watertight),
            "winding_consistent": bool(mesh.is_winding_consistent),
            "euler_characteristic": chi, "genus": (2 - chi) / 2}


def reconstruct_on_sphere(X, U, *, faces=None, size: str = "uniform",
                          target_vertices: int | None = None, lambda_inv=None,
                          interpolation: str = "phong", return_uv: bool = False):
    """Closed triangle mesh of the genus-0 surface sampled by ``X``, remeshed on the sphere
    its map ``U`` is onto (module docstring).

    Parameters
    ----------
    X : (N, 3) array_like
        The cloud.
    U : (N, 3) array_like
        Its map onto the unit sphere (``ParamResult.uv`` of ``pcgeom param --domain
        sphere``), unit vectors.
    faces : (M, 3) array_like of int, optional
        The map's own triangulation (``ParamResult.mesh_faces``); default the convex hull of
        ``U``.
    size : {"uniform", "adaptive"}
        ``"adaptive"``: element size on the sphere proportional to ``lambda_inv ** -0.5``.
    target_vertices : int, optional
        About how many vertices the mesh gets; default :func:`default_vertices` of the
        cloud's points (three per point, at most 200000).
    lambda_inv : (N,) array_like, optional
        The map's compression, surface length per sphere length (for ``"adaptive"``);
        default :func:`sphere_compression` of the triangulation.
    interpolation : {"phong", "linear"}
        Inside a cloud triangle: Phong tessellation (curved) or the flat triangle
        (:func:`lift_sphere`).
    return_uv : bool
        Also return the vertices on the sphere (``V`` lifts them).

    Returns
    -------
    V : (K, 3) float64
    F : (M, 3) int64
        Watertight, winding-consistent, genus 0, outward where the map keeps orientation.
    Q : (K, 3) float64
        Only with ``return_uv``.
    report : dict
        :func:`mesh_report` and :func:`closed_checks`, plus ``domain`` ("sphere"),
        ``triangulation`` (:func:`sphere_triangulation`'s source), ``n_searched`` (vertices
        located by the search over all triangles), ``interpolation``, ``orientation_reversed``
        (the map turns the surface inside out, so the triangles were turned), ``size``,
        ``target_vertices``.

    Raises
    ------
    InputError
        Bad shapes or a map whose rows are not unit vectors (a planar map), an unknown
        ``size`` or ``interpolation``, a triangulation that overlaps
        (:func:`sphere_triangulation`), or a result that is not a closed genus-0 mesh.
    ImportError
        gmsh is not installed.
    """
    from .surface import SIZES

    if size not in SIZES:
        raise InputError(f"size: expected one of {', '.join(SIZES)}, got {size!r}")
    if interpolation not in INTERPOLATIONS:
        raise InputError(f"interpolation: expected one of {', '.join(INTERPOLATIONS)}, "
                         f"got {interpolation!r}")
    P = validate_points(X, name="points")
    U = _sphere_map(U, len(P))
    if target_vertices is None:
        target_vertices = default_vertices(len(P))
    _check_target_vertices(target_vertices)
    T, source = sphere_triangulation(U, faces)
    relative = weights = None
    if size == "adaptive":
        if lambda_inv is None:
            lam = sphere_compression(P, U, T)
        else:
            lam = np.asarray(lambda_inv, dtype=np.float64)
            if lam.shape != (len(P),) or not (np.isfinite(lam).all() and (lam > 0).all()):
                raise InputError(f"lambda_inv: expected {len(P)} finite positive values, "
                                 f"got shape {lam.shape}")
        relative = lam**-0.5
        weights = np.bincount(T.ravel(), np.repeat(np.abs(_spherical_areas(U, T)) / 3, 3),
                              minlength=len(U))
    Q, F = gmsh_meshed("the sphere", mesh_sphere, target_vertices, U, relative, weights)
    V, searched = lift_sphere(P, U, T, Q, interpolation=interpolation)
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    reversed_ = bool(_det(a, b, c).sum() < 0)  # six times the signed volume
    if reversed_:
        F = F[:, [0, 2, 1]]
    checks = closed_checks(V, F)
    if not (checks["watertight"] and checks["winding_consistent"]
            and checks["euler_characteristic"] == 2):
        raise InputError(f"the lifted sphere mesh is not closed and genus 0 (watertight "
                         f"{checks['watertight']}, winding-consistent "
                         f"{checks['winding_consistent']}, Euler characteristic "
                         f"{checks['euler_characteristic']}); nothing written")
    report = mesh_report(V, F, P)
    report.update(checks, domain="sphere", triangulation=source, n_searched=int(searched),
                  orientation_reversed=reversed_, size=size, interpolation=interpolation,
                  target_vertices=int(target_vertices))
    return (V, F, Q, report) if return_uv else (V, F, report)
