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
from ..mesh import (boundary_loops, face_keys, half_edges, main_part, one_fan, peel_rim,
                    shoelace, signed_areas)
from .localmesh import LocalMesh, _interpolate_rest, _submesh, mesh_flips

__all__ = ["conformal_disk", "disk_map"]


def _planar_mesh(P: np.ndarray, loop: np.ndarray, *, slivers: bool = False
                 ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
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
    another (qhull leaves them out) or outside the polygon belong to no triangle. With
    ``slivers``, also the peeled triangles (counter-clockwise), for :func:`_release`.
    """
    import shapely
    from scipy.spatial import Delaunay

    region = shapely.make_valid(shapely.Polygon(P[loop]))
    parts = [g for g in getattr(region, "geoms", [region])
             if g.geom_type == "Polygon" and g.area > 0]
    if not parts or len(P) < 3:
        none = np.empty((0, 3), dtype=np.int64)
        return (none, none) if slivers else none
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
    peeled, _ = peel_rim(P, tri, rounds=20, one_per_vertex=False)
    kept = one_fan(peeled, 5, bowties_only=True)[0]
    if not slivers:
        return kept
    return kept, tri[~np.isin(face_keys(tri, len(P)), face_keys(peeled, len(P)))]


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


RELEASE_ANGLE_DEG = 150.0
"""A peeled rim sliver of the local mesh (:func:`_planar_mesh`) whose widest angle is below
this (degrees) may get its apex back inside the disk (:func:`_release`). On the shared
surfaces the slivers that were true triangles had 121 to 142 degrees (peaks_three_cgal's,
face_3holes_small_choi's and peaks_7holes_choi's five turned rim triangles), the slivers the
peel is for (rim points a little inside their neighbours) from 159 degrees on face_human_choi:
released up to 170 degrees, its mapped surface missed the circle by 0.012 instead of 0.0007."""

RELEASE_SAGITTA = 0.005
"""... and when the chord of the unit circle between its base corners misses the circle by
less than this at its middle: the least a released apex leaves of the disk uncovered. A
stretched grid clipped to the car's outline (tests/test_domains.py) has 34 such slivers at
its staircase rim that are not true triangles; released all, its disk map's angle error rose
0.0629 -> 0.0794 rad and its surface missed the disk by 0.135 instead of 0.061; with a bound
of 0.01 the 1600-point car patch of that test missed the car by 0.079 (its bound 0.07, 0.051
before). With 0.005 it passes and the shared surfaces keep every release (peaks_three_cgal
2 -> 0, peaks_7holes_choi 2 -> 0, face_3holes_small_choi 1 -> 0 flipped true triangles onto
the disk); at 0.003 face_3holes_small_choi's one stays turned."""


def _apexes(P: np.ndarray, tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each triangle of ``tri`` (M, 3) rolled to start at its widest corner in the planar
    points ``P`` (apex, then the two base corners in the triangle's order), (M, 3), and the
    cosine of that angle, (M,)."""
    cos = np.empty((len(tri), 3))
    for k in range(3):
        u = P[tri[:, (k + 1) % 3]] - P[tri[:, k]]
        w = P[tri[:, (k + 2) % 3]] - P[tri[:, k]]
        cos[:, k] = (u * w).sum(axis=1) / np.maximum(
            np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1), 1e-300)
    k = np.argmin(cos, axis=1)
    rows = np.arange(len(tri))[:, None]
    return tri[rows, (k[:, None] + np.arange(3)) % 3], cos[rows[:, 0], k]


def _restore(F: np.ndarray, slivers: np.ndarray, n: int) -> np.ndarray:
    """The peeled ``slivers`` that fit back onto the mesh ``F`` (n vertices), each over its
    two rim edges at its apex with its third edge in no triangle, repeated while one more
    fits (a sliver peeled in a later round first). (K, 3), oriented as ``F``."""
    key = lambda a, b: int(min(a, b)) * n + int(max(a, b))  # noqa: E731
    edges = half_edges(F)
    ids = np.minimum(edges[:, 0], edges[:, 1]) * n + np.maximum(edges[:, 0], edges[:, 1])
    uses = dict(zip(*np.unique(ids, return_counts=True)))
    pending, back = [tuple(t) for t in slivers], []
    while pending:
        left = []
        for t in pending:
            sides = [key(t[k], t[(k + 1) % 3]) for k in range(3)]
            if sorted(uses.get(e, 0) for e in sides) != [0, 1, 1]:
                left.append(t)
                continue
            back.append(t)
            for e in sides:
                uses[e] = uses.get(e, 0) + 1
        if len(left) == len(pending):
            break
        pending = left
    return np.array(back, dtype=np.int64).reshape(-1, 3)


def _release(V: np.ndarray, F: np.ndarray, slivers: np.ndarray, D: np.ndarray) -> np.ndarray:
    """The disk map ``D`` of the planar mesh ``(V, F)`` with the apexes of its peeled rim
    ``slivers`` (triangles of the local mesh) released into the disk: those narrower than
    :data:`RELEASE_ANGLE_DEG` over a chord within :data:`RELEASE_SAGITTA` of the circle put
    back where they fit (:func:`_restore`), the rim points still on the rim left where the
    harmonic measure put them and the rest solved again (the harmonic extension on the mesh
    with the slivers: the apex goes in as deep as the free map has it, and the Delaunay
    mesh's cotangent weights fold nothing inside the convex rim). Kept when it turns over
    fewer of the mesh's triangles (slivers put back included), else ``D``.

    A sliver's three corners on the circle, its apex between the other two, turn it over.
    Measured beside the map without this (angle error, flipped true triangles): onto the disk
    peaks_three_cgal 0.05416 rad, 2 -> 0.05397, 0; peaks_7holes_choi 0.03357, 2 -> 0.03327,
    0; face_3holes_small_choi 0.01339, 1 -> 0.01336, 0; peaks3 and face_human_choi (bare and
    with normals) unchanged. Onto the square 6 -> 4, 2 -> 0 and 2 -> 0 flips at lower angles.
    The mapped true surface of peaks_three_cgal misses the circle by 0.0072 instead of
    0.0024: its two released apexes are inside the true boundary. A point cloud does not say
    whether a sliver is a true triangle; :data:`RELEASE_SAGITTA` has the cost where it is not.
    """
    import igl

    if not len(slivers):
        return D
    rolled, cos = _apexes(V[:, :2], slivers)
    chord = 1.0 - np.linalg.norm(0.5 * (D[rolled[:, 1]] + D[rolled[:, 2]]), axis=1)
    keep = (cos > np.cos(np.radians(RELEASE_ANGLE_DEG))) & (chord < RELEASE_SAGITTA)
    back = _restore(F, rolled[keep], len(V))
    if not len(back):
        return D
    full = np.vstack([F, back])
    loops = boundary_loops(full)
    rim = np.array(max(loops, key=lambda loop: abs(shoelace(V[loop, :2]))), dtype=np.int64)
    interior = np.setdiff1d(np.arange(len(V)), rim)
    L = -igl.cotmatrix(V, full)
    out = D.copy()
    out[interior] = spd_factor(L[interior][:, interior])(
        np.asarray(-(L[interior][:, rim] @ D[rim])))
    before = int((signed_areas(D, full) <= 0).sum())
    return out if int((signed_areas(out, full) <= 0).sum()) < before else D


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
       inside, so the harmonic map onto the convex circle does not fold it. The apexes of the
       rim slivers the planar mesh peeled, where they are the local mesh's triangles, then go
       back inside (:func:`_release`): three corners on the circle turn a triangle over.
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
    T, slivers = _planar_mesh(P, outer, slivers=True)
    # Only the local mesh's own triangles: the pleats' other slivers, released, cost them
    # 0.02994 -> 0.03016 rad onto the disk (0.03004 with this).
    slivers = slivers[np.isin(face_keys(slivers, len(P)), face_keys(F, len(P)))]
    placed, V2, T = _submesh(np.column_stack([P, np.zeros(len(P))]), T, main_part(T, len(P)))
    slivers = _submesh(P, slivers, np.isin(np.arange(len(P)), placed))[2]
    plane = boundary_loops(T) if len(T) else []
    rim = np.array(max(plane, key=lambda loop: abs(shoelace(V2[loop, :2]))) if plane else [],
                   dtype=np.int64)
    inside = np.setdiff1d(np.arange(len(V2)), rim)
    if not len(rim) or not len(inside):
        raise InputError("the local mesh of the cloud is degenerate (its free map covers no "
                         "region with a point inside); try the 'networks' preset")
    centre = int(inside[np.argmax(cKDTree(V2[rim, :2]).query(V2[inside, :2])[0])])
    U = np.full((n_all, 2), np.nan)
    U[main[placed]] = _release(V2, T, slivers, _harmonic_measure_disk(V2, T, rim, centre))
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
