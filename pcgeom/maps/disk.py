"""The conformal map of the cloud onto the disk: the free map, then the Riemann map of the
planar region it covers (:func:`conformal_disk`); :func:`disk_map` is that map as a run."""

from __future__ import annotations

import time

import numpy as np

from ..config import ParamConfig
from ..domains import Disk
from ..errors import InputError
from ._sparse import spd_factor
from .free import conformal_factor, free_start
from ..mesh import boundary_loops, main_part, one_fan, peel_rim, shoelace, signed_areas
from .localmesh import LocalMesh, _interpolate_rest, _submesh, mesh_flips

__all__ = ["conformal_disk", "disk_map"]


def _planar_mesh(P: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """The Delaunay triangles (scipy) of the planar points ``P`` inside the closed polygon
    ``P[loop]``, counter-clockwise, with one fan per vertex.

    The polygon is filled: holes of the map inside it are triangulated over. Where the loop
    crosses itself (a fold of the map at its rim), its largest simple part is used (shapely's
    ``make_valid``). A triangle is kept when it lies inside the polygon (to a tolerance of
    1e-9 of its size), so the mesh's rim follows the loop into its concave notches instead of
    cutting across them, and the loop's points stay on the rim the disk map puts on the
    circle. Keeping the triangles whose centroid is inside instead cut those notches: on
    face_human_choi the mapped true surface then missed the circle by 0.019 (0.013 with this
    test; with its normals 0.0195 -> 0.010), at the same angles. Then the flat rim triangles
    over points just inside the loop are peeled (:func:`pcgeom.mesh.peel_rim`). Points on top of
    another (qhull leaves them out) or outside the polygon belong to no triangle.
    """
    import shapely
    from scipy.spatial import Delaunay

    region = shapely.make_valid(shapely.Polygon(P[loop]))
    parts = [g for g in getattr(region, "geoms", [region])
             if g.geom_type == "Polygon" and g.area > 0]
    if not parts or len(P) < 3:
        return np.empty((0, 3), dtype=np.int64)
    region = shapely.Polygon(max(parts, key=lambda g: g.area).exterior)
    region = region.buffer(1e-9 * np.sqrt(region.area))  # its own edges count as inside
    shapely.prepare(region)
    tri = Delaunay(P).simplices.astype(np.int64)
    tri = tri[shapely.contains(region, shapely.polygons(P[tri]))]
    cross = 2.0 * signed_areas(P, tri)
    tri[cross < 0] = tri[cross < 0][:, [0, 2, 1]]
    # qhull leaves flat triangles over collinear rim points (a grid's straight side): their
    # cotangent weights are infinite and the disk map's system singular.
    tri = tri[np.abs(cross) > 1e-12 * region.area]
    # Peeled (every sliver of a round, 20 rounds): the true surface of face_human_choi missed
    # the circle by 0.013 (0.010 with its normals), that face decimated to 6085 points by
    # 0.043; peeled: 0.0007, 0.0007 and 0.0006, with angles a little lower (0.0397 -> 0.0392
    # rad bare, 0.0257 -> 0.0253, 0.0458 -> 0.0448) and the same flips; the same from 100 to
    # 140 degrees.
    tri, _ = peel_rim(P, tri, rounds=20, one_per_vertex=False)
    return one_fan(tri, 5, bowties_only=True)[0]


def _harmonic_measure_disk(V: np.ndarray, F: np.ndarray, outer: np.ndarray,
                           centre: int) -> np.ndarray:
    """The discrete Riemann map of the mesh ``(V, F)`` onto the unit disk, ``centre`` to 0.

    The Green's function ``g`` of the centre (cotangent Laplacian ``L``, ``L g = delta``,
    ``g = 0`` on the loop ``outer``) gives the harmonic measure of the boundary seen from it,
    the flux ``-(L g)_b``. A conformal map sending the centre to 0 spreads the boundary on the
    circle by harmonic measure: vertex ``b`` goes to the angle ``2 pi`` times the cumulative
    flux up to it. The interior is the harmonic extension of those values (cotangent weights;
    other boundary loops free), the conformal map when the boundary values are.
    """
    import igl

    n = len(V)
    interior = np.setdiff1d(np.arange(n), outer)
    L = -igl.cotmatrix(V, F)  # positive semi-definite
    solve = spd_factor(L[interior][:, interior])  # one factor for the three solves
    g = np.zeros(n)
    g[interior] = solve((interior == centre).astype(np.float64))
    flux = np.maximum(-(L @ g)[outer], 0.0)
    if not np.isfinite(flux).all() or flux.sum() <= 0:
        raise InputError("the local mesh of the cloud is degenerate (no harmonic measure on "
                         "its boundary); try the 'networks' preset")
    theta = 2.0 * np.pi * (np.cumsum(flux) - 0.5 * flux) / flux.sum()
    circle = np.column_stack([np.cos(theta), np.sin(theta)])
    D = np.zeros((n, 2))
    D[outer] = circle
    D[interior] = solve(np.asarray(-(L[interior][:, outer] @ circle)))
    return D


def conformal_disk(X: np.ndarray, mesh: LocalMesh, free_uv: np.ndarray) -> np.ndarray:
    """A conformal map of the cloud onto the unit disk: its free map ``free_uv`` (LSCM),
    followed by the Riemann map of the planar region that map covers.

    1. The mesh is made vertex-manifold, so that its outer boundary is one simple loop: the
       loop of largest area in the free map.
    2. The free map's points inside that loop are triangulated in the plane (Delaunay,
       :func:`_planar_mesh`). The free map is already conformal, so a conformal map of this
       planar region onto the disk composes with it into a conformal map of the surface.
       Defects of the local mesh (flaps folded over where the estimated normals cross two
       sheets, slivers, handles) stay where LSCM put them instead of steering the disk map.
    3. That region's Riemann map (:func:`_harmonic_measure_disk`), centred at the point
       farthest from the loop. A Delaunay triangulation's cotangent weights are not negative
       inside, so the harmonic map onto the convex circle does not fold it.
    4. Points in no planar triangle (outside the mesh's main part, on top of another point or
       beyond the loop) are interpolated; a disk automorphism centres the points' mean
       (:func:`_balance`).

    Measured (angle distortion on the true triangles, flipped of them, Hausdorff distance to
    the disk of the mapped points and of the mapped true triangles): three peaks, estimated
    normals, 0.0167 rad, none, 0.025 and 0.0001; face_human_choi with its normals 0.0253 rad,
    28 of 34144, 0.066 and 0.0007, and without them 0.0392 rad, 1192 (the free map's own
    folds), 0.063 and 0.0007. The harmonic map of the local mesh itself, which this replaced:
    0.0228 rad with 12 flips, 0.0534 and 0.145 rad: the bare face's folded eyelid flaps bent
    the whole interior. libigl's harmonic map with the boundary spread by arc length, on the
    true meshes: 0.180 and 0.115 rad.

    Returns
    -------
    (N, 2) float64, inside the closed unit disk.
    """
    from scipy.spatial import cKDTree

    n_all = len(X)
    faces = one_fan(mesh.faces, 5, bowties_only=True)[0]
    main, _, F = _submesh(X, faces, main_part(faces, n_all))
    P = np.ascontiguousarray(free_uv[main])
    loops = boundary_loops(F)
    if not loops:
        raise InputError("the local mesh has no boundary loop; a disk map needs one")
    outer = np.array(max(loops, key=lambda loop: abs(shoelace(P[loop]))))
    T = _planar_mesh(P, outer)
    placed, V2, T = _submesh(np.column_stack([P, np.zeros(len(P))]), T, main_part(T, len(P)))
    plane = boundary_loops(T) if len(T) else []
    rim = np.array(max(plane, key=lambda loop: abs(shoelace(V2[loop, :2]))) if plane else [],
                   dtype=np.int64)
    inside = np.setdiff1d(np.arange(len(V2)), rim)
    if not len(rim) or not len(inside):
        raise InputError("the local mesh of the cloud is degenerate (its free map covers no "
                         "region with a point inside); try the 'networks' preset")
    centre = int(inside[np.argmax(cKDTree(V2[rim, :2]).query(V2[inside, :2])[0])])
    U = np.full((n_all, 2), np.nan)
    U[main[placed]] = _harmonic_measure_disk(V2, T, rim, centre)
    known = np.zeros(n_all, dtype=bool)
    known[main[placed]] = True
    return _balance(_interpolate_rest(X, U, known))


def _balance(U: np.ndarray, rounds: int = 50) -> np.ndarray:
    """Compose with disk automorphisms ``z -> (z - a) / (1 - conj(a) z)``, ``a`` the points'
    mean, until the mean is at the centre: the points sample the surface evenly, so this
    spreads the surface's area evenly around the disk (conformal, so no angle changes).
    Three peaks: Hausdorff distance to the disk 0.0312 -> 0.0293; face_human_choi 0.070 ->
    0.065."""
    z = U[:, 0] + 1j * U[:, 1]
    for _ in range(rounds):
        a = z.mean()
        if abs(a) < 1e-9:
            break
        z = (z - a) / (1.0 - np.conj(a) * z)
    return np.column_stack([z.real, z.imag])


def disk_map(Xn: np.ndarray, normals: np.ndarray | None, config: ParamConfig, domain: Disk, *,
             progress: bool, outlier: np.ndarray | None = None, start: tuple | None = None
             ) -> tuple[np.ndarray, np.ndarray, dict]:
    """The disk map of a run: :func:`conformal_disk` scaled and moved to the disk's radius and
    centre. Parameters (``start``: :func:`pcgeom.maps.free.free_start`'s result when the run
    has it already), returns and errors as :func:`pcgeom.maps.free.free_map` (the record adds
    ``onto``, the domain's spec)."""
    if start is None:
        start = free_start(Xn, normals, config, progress=progress, outlier=outlier,
                           onto=domain.label)
    t0 = time.perf_counter()
    uv, mesh, _, record = start
    uv = np.asarray(domain.center) + domain.radius * conformal_disk(Xn, mesh, uv)
    record.update(onto=domain.spec, flips=mesh_flips(Xn, mesh, uv),
                  seconds=record["seconds"] + time.perf_counter() - t0)
    return uv, conformal_factor(Xn, uv), record
