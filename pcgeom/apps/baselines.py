"""Classical maps to compare against: libigl's LSCM and harmonic disk map, and the meshless
workaround users reach for (best-fit plane, Delaunay, LSCM).

On a closed genus-0 mesh, the anchor of a map onto the sphere is :func:`sphere_conformal`: the
better of the two published spherical conformal maps of the true mesh itself, the
stereographic method (Choi, Lam and Lui) and conformalized mean curvature flow.

The first two need the true mesh (and, for the harmonic map, its boundary loop); they are the
reference figures of BENCHMARKS.md and the notebooks, not something pcgeom needs to run.
"""

from __future__ import annotations

import numpy as np

from ..cloud import validate_faces, validate_points

__all__ = ["lscm", "harmonic_disk", "plane_delaunay_lscm", "sphere_conformal", "BASELINES",
           "SPHERE_BASELINES"]


def _igl():
    try:
        import igl
    except ImportError as exc:
        raise ImportError("the baselines need libigl: pip install 'libigl>=2.6'") from exc
    return igl


def _mesh_with_boundary(V, F, method: str):
    """libigl, validated contiguous (V, F) (libigl segfaults on some broken input), and the
    longest boundary loop."""
    igl = _igl()
    V = np.ascontiguousarray(validate_points(V, name="V"))
    F = np.ascontiguousarray(validate_faces(F, len(V), name="F", allow_empty=False))
    bnd = igl.boundary_loop(F)
    if len(bnd) < 3:
        raise ValueError(f"F: the mesh has no boundary loop; {method} needs one")
    return igl, V, F, bnd


def lscm(V, F) -> np.ndarray:
    """LSCM (libigl) with the boundary vertices ``bnd[0]`` and ``bnd[len // 2]`` pinned to
    (0, 0) and (1, 0).

    Parameters
    ----------
    V : (N, 3) array_like
    F : (M, 3) array_like of int
        A mesh with a boundary.

    Returns
    -------
    (N, 2) float64
    """
    igl, V, F, bnd = _mesh_with_boundary(V, F, "LSCM")
    b = np.array([bnd[0], bnd[len(bnd) // 2]], dtype=np.int64)
    bc = np.array([[0.0, 0.0], [1.0, 0.0]])
    U, _ = igl.lscm(V, F, b, bc)
    return np.asarray(U, dtype=np.float64)


def harmonic_disk(V, F) -> np.ndarray:
    """Harmonic map (libigl) with the longest boundary loop on the unit circle, spaced by arc
    length.

    Returns
    -------
    (N, 2) float64
    """
    igl, V, F, bnd = _mesh_with_boundary(V, F, "the harmonic disk map")
    # map_vertices_to_circle's binding asks for F-ordered float64 V and int32 bnd.
    bc = igl.map_vertices_to_circle(np.asfortranarray(V), np.ascontiguousarray(bnd, np.int32))
    U = igl.harmonic(V, F, bnd.astype(np.int64), np.ascontiguousarray(bc), 1)
    return np.asarray(U, dtype=np.float64)


def plane_delaunay_lscm(V) -> np.ndarray:
    """The meshless map a user builds without pcgeom: best-fit plane, Delaunay, LSCM.

    Uses the points only. Points that Delaunay leaves out (duplicates) take the map of their
    nearest kept point.

    Returns
    -------
    (N, 2) float64
    """
    from scipy.spatial import Delaunay, cKDTree

    V = validate_points(V, name="V")
    centred = V - V.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    P = centred @ vt[:2].T  # (N, 2) coordinates in the best-fit plane
    Fd = Delaunay(P).simplices.astype(np.int64)
    used = np.unique(Fd)
    remap = np.full(len(V), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    U_used = lscm(V[used], remap[Fd])
    U = np.empty((len(V), 2))
    U[used] = U_used
    missing = np.setdiff1d(np.arange(len(V)), used)
    if len(missing):
        _, nearest = cKDTree(V[used]).query(V[missing], k=1)
        U[missing] = U_used[nearest]
    return U


BASELINES = {
    "lscm": ("LSCM, 2 pinned vertices (libigl, true mesh)", "yes", "free",
             lambda V, F: lscm(V, F)),
    "harmonic_disk": ("harmonic disk map (libigl, true mesh)", "yes (+ boundary)", "disk",
                      lambda V, F: harmonic_disk(V, F)),
    "plane_delaunay_lscm": ("PCA plane + Delaunay + LSCM (points only)", "no", "free",
                            lambda V, F: plane_delaunay_lscm(V)),
}
"""name -> (label, needs a mesh?, domain it maps onto, function of (V, F))."""


def sphere_conformal(V, F, *, stats: dict | None = None) -> np.ndarray:
    """The mesh anchor of a sphere map: a spherical conformal map of the closed genus-0 mesh
    ``(V, F)`` itself, the better (smaller mean angle distortion on ``(V, F)``, then fewer
    flips) of the stereographic method as Choi, Lam and Lui publish it (one south-pole
    correction: :func:`pcgeom.maps.sphere.spherical_conformal` with ``poles=1``) and
    conformalized mean curvature flow (:func:`pcgeom.maps.sphere.cmcf`), as issue 37 names
    them. The mesh
    is oriented outward first (its enclosed volume positive). ``stats``, when given, receives
    ``method`` ("stereographic" or "cmcf") and each one's ``rad``.

    Returns
    -------
    (N, 3) float64
        Unit vectors.

    Raises
    ------
    ValueError
        The mesh is open or of genus above 0 (an ``InputError``).
    """
    from ..maps.sphere import cmcf, outward, spherical_conformal
    from ..metrics import angle_distortion

    V = np.ascontiguousarray(validate_points(V, name="V"))
    F = np.ascontiguousarray(validate_faces(F, len(V), name="F", allow_empty=False))
    F = outward(V, F)
    best, found = None, {}
    for name, fn in (("stereographic", lambda: spherical_conformal(V, F, poles=1)),
                     ("cmcf", lambda: cmcf(V, F))):
        S = fn()
        a = angle_distortion(V, F, S)
        found[f"{name}_rad"] = a.mean_abs
        if best is None or (a.mean_abs, a.flipped) < best[0]:
            best = ((a.mean_abs, a.flipped), name, S)
    if stats is not None:
        stats.update(method=best[1], **found)
    return best[2]


SPHERE_BASELINES = {
    "sphere_conformal": ("spherical conformal map (stereographic or CMCF, true mesh)", "yes",
                         "sphere", lambda V, F: sphere_conformal(V, F)),
}
"""The baselines of a map onto the sphere, as :data:`BASELINES`."""
