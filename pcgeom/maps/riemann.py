"""Conformal maps onto a simply connected domain: the disk map composed with the inverse Riemann
map of the domain (not in the paper).

The conformal disk map (:func:`pcgeom.maps.disk.conformal_disk`) takes the surface onto the
unit disk without folding it. A simply connected domain ``Omega`` (square, rectangle, car, a
polygon without holes) has its own Riemann map ``g : Omega -> disk``, computed the same way on
a mesh of the domain. Then ``g^-1 o R o d``, with ``R`` a rotation (or a mirror, since
estimated normals have no preferred side), maps the surface onto ``Omega``:

1. **The domain's mesh.** The domain's ring, its edges split to a spacing ``h``, and the
   domain's own quasi-uniform sample (points closer than ``h / 2`` to the ring dropped) are
   Delaunay-triangulated; the triangles inside the ring are kept.
2. **Its Riemann map** (:func:`pcgeom.maps.disk._harmonic_measure_disk`): the boundary spread
   on the circle by harmonic measure, the interior harmonic; then balanced by disk
   automorphisms so that the area-weighted mean of the domain's image is the centre, as the
   cloud's disk map is balanced so that its points' mean is (the points sample the surface's
   area evenly). Both disks then have their area's centre at 0.
3. **The rotation.** Among :data:`ROTATIONS` rotations, mirrored or not, the one whose
   composed map stretches the local mesh's triangles most evenly: the smallest area-weighted
   variance of ``log(area in Omega / area in 3D)``, clipped about its median
   (:func:`area_spread`); with landmarks, plus the Chamfer distance of the mapped landmark
   points to their targets, over the domain's area; from there the
   whole disk automorphism (turn, mirror and the point ``c`` sent to the centre) is fitted to
   the landmarks by least squares (:func:`pcgeom.maps.moebius.fit_landmarks`; the targets are
   carried into the disk by the domain's Riemann map, :meth:`DomainDisk.forward`).
4. **The inverse.** Each point's image in the disk is located in the domain mesh's disk image
   (among the triangles of the nearest centroids) and takes the barycentric combination of that
   triangle's domain positions. Points just outside the polygon that approximates the circle
   take the nearest point of its rim.

Both maps are conformal, so is their composition: only the discretization and the domain's
corners (where ``g`` is singular) distort angles. Each step is a bijection (the Riemann map
of a Delaunay mesh onto the convex disk does not fold; the inverse is piecewise linear), so
the composition folds no triangle whose corners lie in one domain triangle; a surface
triangle across several domain triangles could only turn over where it is larger than the
domain mesh's features. The surface's own holes stay holes.
"""

from __future__ import annotations

import json
import math

import numpy as np

from ..domains import Domain
from ..domains.base import CORNER_DEG
from ..errors import InputError
from ..mesh import barycentric, shoelace, signed_areas
from .disk import _harmonic_measure_disk

__all__ = ["DomainDisk", "CircleDisk", "domain_disk", "riemann_onto", "simply_connected",
           "snap_corners", "area_spread", "DOMAIN_MESH_POINTS", "ROTATIONS"]

DOMAIN_MESH_POINTS = 20_000
"""Interior points of the domain's mesh (about twice as many triangles)."""

ROTATIONS = 72
"""Evenly spaced rotations the composition tries, each mirrored or not."""

_SCORE_FACES = 4000
"""Triangles of the local mesh (a fixed random subset) that judge the rotations."""


class DomainDisk:
    """A mesh of a simply connected domain and its Riemann map onto the unit disk.

    Attributes
    ----------
    V : (n, 2) float64
        Vertices in the domain.
    F : (m, 3) int64
        Counter-clockwise triangles.
    D : (n, 2) float64
        The vertices' images in the unit disk.
    rim : (k,) int64
        The boundary loop, counter-clockwise.
    corners : (c,) int64
        The rim vertices at the domain's corners (its ring turns there by more than
        :data:`CORNER_DEG`).
    """

    def __init__(self, V: np.ndarray, F: np.ndarray, D: np.ndarray, rim: np.ndarray,
                 corners: np.ndarray) -> None:
        import shapely
        from scipy.spatial import cKDTree

        self.V, self.F, self.D, self.rim, self.corners = V, F, D, rim, corners
        self._centroids = cKDTree(D[F].mean(axis=1))
        self._ring = shapely.LinearRing(D[rim])
        seg = np.linalg.norm(np.roll(D[rim], -1, axis=0) - D[rim], axis=1)
        self._cum = np.concatenate([[0.0], np.cumsum(seg)])
        self._domain_side = None  # forward's locator, built when first asked

    def _carry(self, Z: np.ndarray, source: str, candidates: int) -> np.ndarray:
        """The points ``Z`` (k, 2) of the mesh's ``source`` side (``"D"``: the disk, ``"V"``:
        the domain) carried to the other side: barycentric in the triangle holding each
        (among those of the ``candidates`` nearest centroids), or, outside the polygon of
        the rim, at the nearest point of the rim."""
        import shapely

        Z = np.asarray(Z, dtype=np.float64)
        if source == "D":
            S, out_of, tree, ring, cum = self.D, self.V, self._centroids, self._ring, self._cum
        else:
            S, out_of = self.V, self.D
            if self._domain_side is None:
                from scipy.spatial import cKDTree

                seg = np.linalg.norm(np.roll(self.V[self.rim], -1, axis=0) - self.V[self.rim],
                                     axis=1)
                self._domain_side = (cKDTree(self.V[self.F].mean(axis=1)),
                                     shapely.LinearRing(self.V[self.rim]),
                                     np.concatenate([[0.0], np.cumsum(seg)]))
            tree, ring, cum = self._domain_side
        _, T = tree.query(Z, min(candidates, len(self.F)))
        T = T.reshape(len(Z), -1)
        W = barycentric(S, self.F, Z, T)  # (k, c, 3)
        worst = W.min(axis=2)
        best = np.argmax(worst, axis=1)
        rows = np.arange(len(Z))
        inside = worst[rows, best] >= -1e-9
        out = np.empty_like(Z)
        w = np.clip(W[rows, best], 0.0, 1.0)
        w /= np.maximum(w.sum(axis=1, keepdims=True), 1e-300)
        tri = self.F[T[rows, best]]  # (k, 3)
        out[inside] = np.einsum("kq,kqd->kd", w[inside], out_of[tri[inside]])
        if (~inside).any():
            s = shapely.line_locate_point(ring, shapely.points(Z[~inside]))
            k = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(self.rim) - 1)
            t = (s - cum[k]) / np.maximum(cum[k + 1] - cum[k], 1e-300)
            a, b = self.rim[k], self.rim[(k + 1) % len(self.rim)]
            out[~inside] = (1.0 - t)[:, None] * out_of[a] + t[:, None] * out_of[b]
        return out

    def inverse(self, Z: np.ndarray, candidates: int = 12) -> np.ndarray:
        """The domain points whose images are ``Z`` (k, 2): barycentric in the triangle
        holding each (among those of the ``candidates`` nearest centroids), or, outside the
        disk's polygon, at the nearest point of its rim."""
        return self._carry(Z, "D", candidates)

    def forward(self, Q: np.ndarray, candidates: int = 12) -> np.ndarray:
        """The images in the disk (k, 2) of the domain points ``Q`` (k, 2), as
        :meth:`inverse` the other way."""
        return self._carry(Q, "V", candidates)


class CircleDisk:
    """The disk's own Riemann map onto the unit disk, exact: ``u -> (u - center) / radius``
    (what :class:`DomainDisk` approximates on a mesh of it)."""

    corners = np.zeros(0, dtype=np.int64)

    def __init__(self, center, radius: float, rim_points: int = 0) -> None:
        self.center = np.asarray(center, dtype=np.float64)
        self.radius = float(radius)
        self.V = np.zeros((rim_points, 2))

    def inverse(self, Z: np.ndarray) -> np.ndarray:
        Z = np.asarray(Z, dtype=np.float64)
        r = np.maximum(np.linalg.norm(Z, axis=1, keepdims=True), 1.0)  # onto the rim
        return self.center + self.radius * Z / r

    def forward(self, Q: np.ndarray) -> np.ndarray:
        return (np.asarray(Q, dtype=np.float64) - self.center) / self.radius


def _ring_points(ring: np.ndarray, h: float) -> np.ndarray:
    """The closed ``ring`` (k + 1, 2) with each edge split into pieces no longer than ``h``
    (its own vertices, corners included, kept)."""
    pieces = []
    for a, b in zip(ring[:-1], ring[1:]):
        k = max(1, math.ceil(np.linalg.norm(b - a) / h))
        pieces.append(a + (b - a) * (np.arange(k) / k)[:, None])
    return np.vstack(pieces)


def _turns(P: np.ndarray) -> np.ndarray:
    """The turning angle (radians, left positive) of the closed polygon ``P`` (k, 2) at each
    vertex."""
    a = P - np.roll(P, 1, axis=0)
    b = np.roll(P, -1, axis=0) - P
    return np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], (a * b).sum(axis=1))


def _corner_points(ring: np.ndarray, h: float) -> np.ndarray:
    """A point ``h`` inside each convex corner of the counter-clockwise ``ring`` (k + 1, 2),
    on its bisector: it ties the corner to the interior. Without it, the Delaunay triangle at
    a corner has three rim corners, and the corner gets no flux of harmonic measure (two rim
    points on one spot of the circle, a degenerate triangle)."""
    P = ring[:-1]
    a = P - np.roll(P, 1, axis=0)
    b = np.roll(P, -1, axis=0) - P
    a /= np.maximum(np.linalg.norm(a, axis=1, keepdims=True), 1e-300)
    b /= np.maximum(np.linalg.norm(b, axis=1, keepdims=True), 1e-300)
    # Convex corners only (a left turn of more than CORNER_DEG): along a smooth arc the
    # Delaunay triangles reach the interior anyway.
    turn = _turns(P)
    inward = b - a
    norm = np.linalg.norm(inward, axis=1)
    keep = (turn > math.radians(CORNER_DEG)) & (norm > 1e-9)
    return P[keep] + h * inward[keep] / norm[keep, None]


def _vertex_areas(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    area = np.abs(signed_areas(V, F))
    return np.bincount(F.ravel(), np.repeat(area / 3.0, 3), minlength=len(V))


def _balance_weighted(D: np.ndarray, w: np.ndarray, rounds: int = 50) -> np.ndarray:
    """Disk automorphisms ``z -> (z - a) / (1 - conj(a) z)`` until the ``w``-weighted mean of
    the points is the centre."""
    z = D[:, 0] + 1j * D[:, 1]
    w = w / w.sum()
    for _ in range(rounds):
        a = (w * z).sum()
        if abs(a) < 1e-9:
            break
        z = (z - a) / (1.0 - np.conj(a) * z)
    return np.column_stack([z.real, z.imag])


def simply_connected(domain: Domain) -> bool:
    """A bounded domain of one region without holes: one boundary loop."""
    return domain.bounded and len(domain.boundary_loops()) == 1


_DISKS: dict[tuple[str, int, int], DomainDisk] = {}
"""The last :data:`_DISKS_KEPT` domain meshes and Riemann maps :func:`domain_disk` made, by
domain (its ``to_dict``), ``n`` and ``seed``."""
_DISKS_KEPT = 4


def domain_disk(domain: Domain, n: int = DOMAIN_MESH_POINTS, seed: int = 0) -> DomainDisk:
    """Mesh a simply connected bounded domain and compute its balanced Riemann map (steps 1-2
    of the module).

    The result depends on the domain, ``n`` and ``seed`` only, and takes seconds (the car:
    21 708 vertices, about 10 s on one core): the last few are kept, read-only, and given
    again to a later call with the same arguments (a batch of scans onto one domain, or a
    landmark run that maps twice).

    Raises
    ------
    InputError
        The domain has holes or several parts (it is not simply connected).
    """
    if not simply_connected(domain):
        rings = domain.boundary_loops() if domain.bounded else [None]
        raise InputError(f"domain {domain.label!r} is not simply connected (it has "
                         f"{len(rings) - 1} hole(s)); its Riemann map needs one boundary loop")
    key = (json.dumps(domain.to_dict(), sort_keys=True), int(n), int(seed))
    if key not in _DISKS:
        dd = _domain_disk(domain, int(n), int(seed))
        for array in (dd.V, dd.F, dd.D, dd.rim, dd.corners):
            array.flags.writeable = False
        while len(_DISKS) >= _DISKS_KEPT:
            del _DISKS[next(iter(_DISKS))]
        _DISKS[key] = dd
    return _DISKS[key]


def _domain_disk(domain: Domain, n: int, seed: int) -> DomainDisk:
    """:func:`domain_disk`, made anew."""
    import shapely
    from scipy.spatial import Delaunay, cKDTree

    ring = np.asarray(domain.boundary_loops()[0], dtype=np.float64)
    if np.linalg.norm(ring[0] - ring[-1]) > 0:
        ring = np.vstack([ring, ring[:1]])
    if shoelace(ring[:-1]) < 0:
        ring = ring[::-1].copy()
    h = math.sqrt(domain.area / n)
    B = _ring_points(ring, 0.5 * h)
    line = shapely.LineString(np.vstack([B, B[:1]]))
    inner = domain.sample(n, seed=seed)
    inner = inner[shapely.distance(line, shapely.points(inner)) > 0.5 * h]
    inner = np.vstack([_corner_points(ring, 0.3 * h), inner])
    V = np.vstack([B, inner])
    polygon = shapely.Polygon(B).buffer(1e-9 * math.sqrt(domain.area))
    shapely.prepare(polygon)
    F = Delaunay(V).simplices.astype(np.int64)
    F = F[shapely.contains(polygon, shapely.polygons(V[F]))]
    cross = 2.0 * signed_areas(V, F)
    F[cross < 0] = F[cross < 0][:, [0, 2, 1]]
    # qhull leaves flat triangles over runs of collinear rim points (straight sides).
    F = F[np.abs(cross) > 1e-9 * h * h]
    rim = np.arange(len(B))
    # The ring's own corners are among the rim points (_ring_points keeps them).
    ring_corners = ring[:-1][np.abs(_turns(ring[:-1])) > math.radians(CORNER_DEG)]
    corners = np.unique(cKDTree(B).query(ring_corners)[1]) if len(ring_corners) else \
        np.zeros(0, dtype=np.int64)
    # The centre of the first map: the inner point farthest from the rim.
    centre = len(B) + int(np.argmax(shapely.distance(line, shapely.points(inner))))
    D = _harmonic_measure_disk(np.column_stack([V, np.zeros(len(V))]), F, rim, centre)
    return DomainDisk(V, F, _balance_weighted(D, _vertex_areas(V, F)), rim, corners)


def snap_corners(dd: DomainDisk, angles: np.ndarray) -> tuple[DomainDisk, float]:
    """Step 5: the domain's rim moved along the circle so that each corner lands on the
    nearest of ``angles`` (the cloud's rim points on the circle), piecewise linearly in angle
    between corners; the interior harmonic again (cotangent weights).

    A conformal map sends a corner of the domain to one point of the circle and shrinks its
    surroundings to nothing, so without this the mapped surface cuts each corner where its
    nearest rim point falls (three peaks onto the square: 0.084 from the corner). Returns the
    moved map and the largest move (radians).
    """
    import igl

    from ._sparse import spd_factor

    if not len(dd.corners) or not len(angles):
        return dd, 0.0
    theta = np.arctan2(dd.D[dd.rim, 1], dd.D[dd.rim, 0])
    position = np.empty(len(dd.V), dtype=np.int64)
    position[dd.rim] = np.arange(len(dd.rim))
    beta = theta[position[dd.corners]]
    alpha = np.unique(np.mod(angles, 2 * np.pi))
    # Each corner, in circular order from the first rim point, to the nearest rim point not
    # taken by the corner before it: two corners close together (a wheel arch) never share
    # one, and the order is kept.
    x = alpha[0] + np.mod(beta - alpha[0], 2 * np.pi)
    order = np.argsort(x)
    nearest = np.round(np.interp(x[order], np.append(alpha, alpha[0] + 2 * np.pi),
                                 np.arange(len(alpha) + 1))).astype(np.int64)
    if len(alpha) >= len(beta):
        offset = np.maximum.accumulate(nearest - np.arange(len(nearest)))
        nearest = offset + np.arange(len(nearest))
    delta = np.zeros(len(beta))
    delta[order] = np.angle(np.exp(1j * (alpha[nearest % len(alpha)] - beta[order])))
    order = np.argsort(beta)
    shift = np.interp(theta, beta[order], delta[order], period=2 * np.pi)
    circle = np.column_stack([np.cos(theta + shift), np.sin(theta + shift)])
    n = len(dd.V)
    inner = np.setdiff1d(np.arange(n), dd.rim)
    L = (-igl.cotmatrix(np.column_stack([dd.V, np.zeros(n)]), dd.F)).tocsr()
    D = np.zeros((n, 2))
    D[dd.rim] = circle
    D[inner] = spd_factor(L[inner][:, inner])(np.asarray(-(L[inner][:, dd.rim] @ circle)))
    return DomainDisk(dd.V, dd.F, D, dd.rim, dd.corners), float(np.abs(delta).max())


def _tri_areas(P: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Unsigned areas of the triangles ``F`` of the points ``P`` (2D or 3D)."""
    if P.shape[1] == 2:
        return np.abs(signed_areas(P, F))
    e1, e2 = P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]]
    return 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)


def area_spread(mapped: np.ndarray, area3: np.ndarray, weight: np.ndarray,
                clip: float = 2.0) -> float:
    """Step 3's criterion: the ``weight``-weighted standard deviation of the log area ratios
    ``r = log(mapped / area3)`` of the triangles, each clipped to ``clip`` about their
    weighted median (``weight`` sums to 1).

    Clipped, because the corners of the domain shrink their triangles to nothing whatever the
    rotation, and would decide it alone; about the median, not the mean: a triangle laid
    flat along a straight side has an area of 0 or 1e-17 as the last bit of its corners
    rounds (log ratio -686 or -35 with the 1e-300 floor), which moved a mean-centred window
    by 2 and chose another rotation from one CPU to another (the car-shaped test patch).
    """
    ratio = np.log(np.maximum(mapped, 1e-300) / np.maximum(area3, 1e-300))
    order = np.argsort(ratio, kind="stable")
    cum = np.cumsum(weight[order])
    middle = ratio[order[min(int(np.searchsorted(cum, 0.5 * cum[-1])), len(ratio) - 1)]]
    ratio = np.clip(ratio, middle - clip, middle + clip)
    mean = float((weight * ratio).sum())
    return math.sqrt(float((weight * (ratio - mean) ** 2).sum()))


def riemann_onto(X: np.ndarray, faces: np.ndarray, disk_uv: np.ndarray, domain: Domain, *,
                 landmarks=(), seed: int = 0, bend=None) -> tuple[np.ndarray, dict]:
    """Map the cloud onto a simply connected domain by composing its disk map with the
    domain's inverse Riemann map (steps 1-4 of the module).

    Parameters
    ----------
    X : (N, 3) float64
        The normalized points.
    faces : (M, 3) int64
        Their local mesh's triangles (to weigh the rotations by the area they stretch).
    disk_uv : (N, 2) float64
        The cloud's map onto the unit disk (:func:`pcgeom.maps.disk.conformal_disk`).
    domain : Domain
        Bounded, one boundary loop.
    landmarks : sequence of ((n_k,) int, (m_k, 2) float64)
        Rows of ``X`` standing for each landmark set, and its targets: the disk automorphism
        is fitted to them (:func:`pcgeom.maps.moebius.fit_landmarks`).
    bend : callable, optional
        With landmarks: ``bend(Z, to_disk)`` takes the fitted disk map ``Z`` (N, 2) and the
        domain's Riemann map (domain points to disk points) and returns a map of the disk
        and a record of what it did (``info["linear_bend"]``), composed with the inverse
        Riemann map in place of ``Z``.

    Returns
    -------
    U : (N, 2) float64
    info : dict
        ``rotation_deg``, ``mirror``, ``domain_mesh_vertices``, ``area_spread`` (the
        area-weighted standard deviation of the log area ratio of the local mesh's
        triangles, the criterion of step 3 without the landmarks).
    """
    from scipy.spatial import cKDTree

    from ..domains import Disk

    dd = CircleDisk(domain.center, domain.radius) if isinstance(domain, Disk) else \
        domain_disk(domain, seed=seed)
    rng = np.random.default_rng(seed)
    if len(faces) > _SCORE_FACES:
        faces = faces[np.sort(rng.choice(len(faces), _SCORE_FACES, replace=False))]
    area3 = _tri_areas(X, faces)
    weight = area3 / max(area3.sum(), 1e-300)
    # Only the judging triangles' corners are mapped for each candidate.
    used = np.unique(faces)
    z0 = disk_uv[:, 0] + 1j * disk_uv[:, 1]
    marks = [(np.asarray(i, dtype=np.int64), np.asarray(q, dtype=np.float64),
              cKDTree(np.asarray(q, dtype=np.float64))) for i, q in landmarks]

    def turn(z: np.ndarray, theta: float, mirror: bool, a: complex = 0j) -> np.ndarray:
        z = np.conj(z) if mirror else z
        return np.exp(1j * theta) * (z - a) / (1 - np.conj(a) * z)

    def image(theta: float, mirror: bool, rows: np.ndarray, a: complex = 0j) -> np.ndarray:
        z = turn(z0[rows], theta, mirror, a)
        return dd.inverse(np.column_stack([z.real, z.imag]))

    def score(theta: float, mirror: bool, a: complex = 0j) -> tuple[float, float]:
        U = np.zeros((len(X), 2))
        U[used] = image(theta, mirror, used, a)
        spread = area_spread(_tri_areas(U, faces), area3, weight)
        fit = 0.0
        for index, targets, tree in marks:
            P = image(theta, mirror, index, a)
            fit += (float(np.mean(tree.query(P)[0] ** 2))
                    + float(np.mean(cKDTree(P).query(targets)[0] ** 2))) / domain.area
        return spread ** 2 + fit, spread

    best = None
    for mirror in (False, True):
        for theta in 2 * np.pi * np.arange(ROTATIONS) / ROTATIONS:
            total, spread = score(float(theta), mirror)
            if best is None or total < best[0]:
                best = (total, spread, float(theta), mirror)
    _, spread, theta, mirror = best
    a = 0j
    fitted = None
    if marks:
        # Landmarks fix more than a turn: every automorphism of the disk keeps the map
        # conformal, so the one whose landmark images lie nearest their targets is fitted by
        # least squares (maps/moebius.py), from the best turn.
        from .moebius import Moebius, fit_landmarks

        def fit(dd, start: Moebius, rounds: int) -> tuple[Moebius, dict]:
            def to_disk(Q: np.ndarray) -> np.ndarray:
                D = dd.forward(Q)
                return D[:, 0] + 1j * D[:, 1]

            def from_disk(z: np.ndarray) -> np.ndarray:
                return dd.inverse(np.column_stack([z.real, z.imag]))

            return fit_landmarks(X, z0, [(i, q) for i, q, _ in marks], to_disk, from_disk,
                                 start=start, rounds=rounds)

        fitted, fit_info = fit(dd, Moebius(theta, 0j, mirror), 10)
        theta, a, mirror = fitted.theta, fitted.c, fitted.mirror
        spread = score(theta, mirror, a)[1]
    # The cloud's rim points are those its disk map put on the circle.
    on_rim = np.abs(z0) > 1.0 - 1e-9
    rim_angles = np.angle(turn(z0[on_rim], theta, mirror, a))
    dd, moved = snap_corners(dd, rim_angles)
    if fitted is not None and moved > 0:
        # The corners moved the domain's map a little: fitted again on the moved one.
        fitted, fit_info = fit(dd, fitted, 3)
        theta, a, mirror = fitted.theta, fitted.c, fitted.mirror
    if bend is None or not marks:
        U = image(theta, mirror, np.arange(len(X)), a)
        bent = None
    else:
        z = turn(z0, theta, mirror, a)
        Z, bent = bend(np.column_stack([z.real, z.imag]), dd.forward)
        U = dd.inverse(Z)
    info = {"rotation_deg": round(math.degrees(theta), 3), "mirror": mirror,
            "automorphism": [round(a.real, 6), round(a.imag, 6)],
            "domain_mesh_vertices": len(dd.V), "area_spread": round(spread, 4),
            "corners": len(dd.corners), "corner_move_deg": round(math.degrees(moved), 4)}
    if fitted is not None:
        info["moebius"] = fit_info
    if bent is not None:
        info["linear_bend"] = bent
    return U, info
