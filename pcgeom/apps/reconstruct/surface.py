"""The reconstruction as one call: the map's region or its domain meshed with gmsh
(:mod:`.gmsh_mesh`), the mesh lifted to 3D (:mod:`.lifting`) and reported (:mod:`.report`)."""

from __future__ import annotations

import numpy as np

from ...cloud import validate_points
from ...errors import InputError
from ..boundary import BoundaryLoops
from ..planar import validate_map
from .gmsh_mesh import gmsh_meshed, mesh_domain, mesh_region
from . import lifting
from .lifting import lift, map_delaunay
from .report import mesh_report

SIZES = ("uniform", "adaptive")
"""Mesh size rules that :func:`reconstruct_surface` implements."""


def reconstruct_surface(points, U, loops: BoundaryLoops, *, size: str = "uniform",
                        target_vertices: int = 5000, lambda_inv=None, return_uv: bool = False,
                        smooth_rim: bool = False):
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
        Mesh size rule (:mod:`pcgeom.apps.reconstruct.gmsh_mesh`). ``"adaptive"``: element
        size proportional to ``lambda_inv ** -0.5`` (the issue's lambda-adaptive rule),
        smoothed over the 8 nearest points.
    target_vertices : int
        About how many vertices the mesh gets (measured within 20% on the tests; at least the
        loops' points).
    lambda_inv : (N,) array_like, optional
        ``ParamResult.lambda_inv``; needed by ``"adaptive"``, unused by ``"uniform"``.
    return_uv : bool
        Also return each vertex's position in the map (the mesh was made there): its texture
        coordinates up to :func:`pcgeom.apps.texture.uv_scaling`.
    smooth_rim : bool
        For a denoised cloud (``ParamResult.fitted``): the loops' points smoothed along their
        loops before lifting (:func:`pcgeom.apps.reconstruct.lifting.smooth_rim`: a rim
        point's fit is one-sided, the least certain).

    Returns
    -------
    V : (K, 3) float64
    F : (M, 3) int64
        Edge-manifold when the loops are simple, counter-clockwise in the map.
    UV : (K, 2) float64
        Only with ``return_uv``: the vertices in the map (``V`` lifts them).
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
    Q, F = gmsh_meshed("the region", mesh_region, U, loops, target_vertices, relative)
    lifted = lifting.smooth_rim(P, loops.loops) if smooth_rim else P
    V, outside = lift(lifted, U, loops.triangles, Q)
    report = mesh_report(V, F, P)
    report.update(n_outside=int(outside.sum()), size=size, target_vertices=int(target_vertices),
                  smooth_rim=bool(smooth_rim))
    return (V, F, Q, report) if return_uv else (V, F, report)


def _checked_input(points, U, size: str, lambda_inv) -> tuple[np.ndarray, np.ndarray, object]:
    """The cloud, its map and the relative element size of ``size`` (None: uniform)."""
    if size not in SIZES:
        raise InputError(f"size: expected one of {', '.join(SIZES)}, got {size!r}")
    P = validate_points(points, name="points")
    U = validate_map(U)
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


def reconstruct_on_domain(points, U, domain, *, size: str = "uniform",
                          target_vertices: int = 5000, lambda_inv=None, return_uv: bool = False):
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
    size, target_vertices, lambda_inv, return_uv
        As in :func:`reconstruct_surface`.

    Returns
    -------
    V : (K, 3) float64
    F : (M, 3) int64
    UV : (K, 2) float64
        Only with ``return_uv``: the vertices in the domain.
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
    Q, F = gmsh_meshed("the domain", mesh_domain, domain, target_vertices, U, relative,
                       keep=(InputError, ImportError, TypeError))
    V, outside = lift(P, U, map_delaunay(U), Q)
    report = mesh_report(V, F, P)
    report.update(n_outside=int(outside.sum()), n_domain_loops=len(domain.boundary_loops()),
                  size=size, target_vertices=int(target_vertices), domain=domain.spec)
    return (V, F, Q, report) if return_uv else (V, F, report)
