"""Synthetic real-scan stand-ins with ground truth: a holey, noisy height field with strays,
a simulated single-view range scan of a triangle mesh, a pleated sheet whose folds bring
its sheets within a few point spacings of each other, and the car shell (:func:`car_shell`,
the paper's 7.3 and 7.4 test of the ``car`` domain).

Both generators are deterministic for a given ``seed`` and return a small frozen dataclass
of NumPy arrays: the points as a scanner would deliver them (noise and strays included, one
row per point), oriented normals, an ``is_outlier`` mask, and reference triangles on the
inliers that are used only to *evaluate* a map (:func:`pcgeom.metrics.angle_distortion`),
never to make one.

Noise is given in mean spacings: the mean edge length of the reference triangles of the
clean sample, the scale the issue's targets use ("Gaussian noise of 0.25 mean edge lengths
on every coordinate").
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .examples import BUMPS, bump_height
from .mesh import mean_edge, signed_areas

__all__ = ["HeightFieldScan", "RangeScan", "PleatedSheet", "holey_heightfield", "range_scan",
           "pleated_sheet", "HEIGHT_BUMPS", "car_shell", "car_lift", "CAR_ROOF", "CAR_WINDOW",
           "CAR_EDGE_POINTS", "CAR_TARGET_LINES", "CAR_TARGET_SPACING"]

HEIGHT_BUMPS = BUMPS["holey"]
"""(amplitude, centre x, centre y, width) of the Gaussian bumps of :func:`holey_heightfield`'s
surface ``z = sum_k a_k exp(-|p - c_k|^2 / w_k^2)`` over ``[-1, 1]^2``
(:data:`pcgeom.examples.BUMPS`, ``"holey"``)."""

# R2 low-discrepancy sequence (Roberts 2018): the additive recurrence by the inverse powers of
# the plastic number. Its prefixes are area-uniform without a random sample's clumps, so the
# reference Delaunay triangles are well shaped, like a scanner's regular sampling.
_PLASTIC = 1.324717957244746
_R2_STEP = np.array([1.0 / _PLASTIC, 1.0 / _PLASTIC**2])  # (2,)

# Holes keep at least this many spacings between each other and from the square's edge, so
# the surface stays one piece with its outer boundary a square.
_HOLE_GAP = 3.0
# A stray lies at least this many spacings from every surface point (or every hit).
_STRAY_CLEARANCE = 4.0
# Rounds of candidate strays (4 per stray asked for) before giving up.
_STRAY_TRIES = 100


@dataclasses.dataclass(frozen=True)
class HeightFieldScan:
    """What :func:`holey_heightfield` returns. Rows ``0 .. n_surface - 1`` are the surface
    points, the strays follow."""

    points: np.ndarray
    """(N, 3) float64: surface points with noise, then the strays."""
    normals: np.ndarray
    """(N, 3) float64 unit normals: the surface's analytic normal at each point's parameter
    (``(-z_x, -z_y, 1)`` normalized, so +z-ish; noise does not tilt them); strays get a
    uniformly random unit direction, as a scanner's normal estimate of a lone return would."""
    faces: np.ndarray
    """(M, 3) int64 reference triangles: the Delaunay triangulation of the surface points'
    parameters ``uv_true``, without the triangles over a hole; counter-clockwise in the
    parameter plane (their normals point to +z). Strays are in none."""
    is_outlier: np.ndarray
    """(N,) bool: True for the strays."""
    uv_true: np.ndarray
    """(N, 2) float64: the parameter (x, y) of each surface point before noise; strays: their
    own x, y. A flip-free map of the clean surface, but not a conformal one: slopes reach
    54 degrees, and its mean angle distortion on ``faces`` is about 0.067 rad."""
    holes: np.ndarray
    """(holes, 3) float64: centre x, centre y and radius of each hole, in the parameter
    square ``[-1, 1]^2``."""
    spacing: float
    """Mean edge length of the reference triangles on the clean surface: the unit of
    ``noise``."""


@dataclasses.dataclass(frozen=True)
class RangeScan:
    """What :func:`range_scan` returns. Rows ``0 .. n_hits - 1`` are the returns of the rays
    that hit the mesh (in pixel order), the stray returns follow."""

    points: np.ndarray
    """(N, 3) float64: hit points moved along their ray by the range noise, then strays."""
    normals: np.ndarray
    """(N, 3) float64 unit normals: the hit triangle's normal, turned towards the viewpoint;
    strays: the direction back to the viewpoint."""
    faces: np.ndarray
    """(M, 3) int64 reference triangles of the range image: each pair of adjacent pixels
    gives two triangles, kept when the three rays' hit triangles pairwise are the same or
    share a vertex of the mesh (so no triangle spans an occlusion edge); oriented towards the
    viewpoint. Strays are in none."""
    is_outlier: np.ndarray
    """(N,) bool: True for the stray returns."""
    hit_triangle: np.ndarray
    """(N,) int64: index into the mesh's faces of the triangle each ray hit; -1 for strays."""
    pixel: np.ndarray
    """(N, 2) int64: (column, row) of each point's ray in the range image."""
    viewpoint: np.ndarray
    """(3,) float64: where the rays start."""
    spacing: float
    """Mean edge length of the reference triangles before noise: the unit of ``noise``."""


@dataclasses.dataclass(frozen=True)
class PleatedSheet:
    """What :func:`pleated_sheet` returns: a developable surface folded like an accordion."""

    points: np.ndarray
    """(N, 3) float64 points on the surface (no noise)."""
    normals: np.ndarray
    """(N, 3) float64 unit normals, oriented consistently along the surface (so on facing
    sheets of a fold they point towards each other or away from each other)."""
    faces: np.ndarray
    """(M, 3) int64 reference triangles: the Delaunay triangulation of ``uv_true``,
    counter-clockwise there. Used to evaluate a map, never to make one."""
    uv_true: np.ndarray
    """(N, 2) float64: each point's arc length across the folds and its height along them.
    The surface is isometric to this rectangle: a similarity of it is a perfect map."""
    spacing: float
    """Mean edge length of the reference triangles: the unit of ``gap``."""
    gap: float
    """Distance between facing sheets, in spacings (each fold's radius is half of it)."""
    sheet: np.ndarray
    """(N,) int64: the straight run (0 .. folds) each point lies on; -1 on a fold."""


def _r2_square(n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` points of a randomly shifted R2 sequence over ``[-1, 1]^2``, with a jitter of a
    tenth of the spacing (no lattice ties for Delaunay)."""
    k = np.arange(1, n + 1)[:, None]
    unit = (rng.uniform(size=2) + k * _R2_STEP) % 1.0  # (n, 2)
    h = 2.0 / np.sqrt(n)
    return np.clip(2.0 * unit - 1.0 + rng.uniform(-0.1 * h, 0.1 * h, (n, 2)), -1.0, 1.0)


def _height(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The height field of :data:`HEIGHT_BUMPS` at ``xy (n, 2)`` and its gradient ``(n, 2)``."""
    z, zx, zy = bump_height(xy[:, 0], xy[:, 1], HEIGHT_BUMPS)
    return z, np.column_stack([zx, zy])


def _place_holes(count: int, radii: tuple[float, float], gap: float,
                 rng: np.random.Generator) -> np.ndarray:
    """``count`` disjoint discs inside ``[-1, 1]^2``, ``gap`` apart and from the edge, by
    rejection sampling; (count, 3) rows of centre x, centre y, radius."""
    holes = np.zeros((0, 3))
    for _ in range(200 * max(count, 1)):
        if len(holes) == count:
            break
        r = rng.uniform(*radii)
        c = rng.uniform(-1.0 + r + gap, 1.0 - r - gap, 2)
        if len(holes) and (np.hypot(*(holes[:, :2] - c).T) < holes[:, 2] + r + gap).any():
            continue
        holes = np.vstack([holes, [c[0], c[1], r]])
    if len(holes) == count:
        return holes
    raise ValueError(f"holes: could not place {count} disjoint holes of radius {radii[0]:.3g} "
                     f"to {radii[1]:.3g} in the square; ask for fewer or smaller holes")


def _unit_rows(A: np.ndarray) -> np.ndarray:
    return A / np.linalg.norm(A, axis=1, keepdims=True)


def _check_fraction(value, name: str, upper: float = 1.0) -> float:
    value = float(value)
    if not (0.0 <= value < upper):
        raise ValueError(f"{name}: expected a number in [0, {upper:g}), got {value!r}")
    return value


def holey_heightfield(n: int = 6000, holes: int = 20, outliers: float = 0.01,
                      noise: float = 0.25, *, hole_radius: tuple[float, float] = (0.06, 0.14),
                      seed: int = 0) -> HeightFieldScan:
    """A noisy scan of a smooth height field with round holes and stray points.

    The surface is ``z = sum_k a_k exp(-|p - c_k|^2 / w_k^2)`` (:data:`HEIGHT_BUMPS`) over
    ``p in [-1, 1]^2``. It is sampled by ``n`` low-discrepancy parameters (a shifted R2
    sequence); the samples inside ``holes`` disjoint discs (radius uniform in
    ``hole_radius``, at least 3 spacings from each other and from the square's edge) are
    removed. Every coordinate of the remaining points gets Gaussian noise of standard
    deviation ``noise`` spacings; then ``round(outliers * n_surface)`` strays are added,
    uniform in the surface's bounding box enlarged by a fifth on each side, each at least 4
    spacings from every surface point.

    Parameters
    ----------
    n : int
        Samples of the whole square, holes included (the surface keeps about
        ``n * (1 - hole area / 4)``).
    holes : int
        Number of round holes.
    outliers : float
        Strays as a fraction of the surface points, in ``[0, 1)``.
    noise : float
        Standard deviation of the noise on each coordinate, in mean spacings (mean edge
        length of the clean reference triangles).
    hole_radius : (float, float)
        Smallest and largest hole radius, in parameter units (the square's side is 2).
    seed : int
        Seeds the sample's shift, the holes, the noise and the strays.

    Returns
    -------
    HeightFieldScan

    Raises
    ------
    ValueError
        ``n`` below 100, a negative ``holes`` or ``noise``, ``outliers`` outside ``[0, 1)``,
        a bad ``hole_radius``, or holes that do not fit.
    """
    from scipy.spatial import Delaunay, cKDTree

    n, holes = int(n), int(holes)
    if n < 100:
        raise ValueError(f"n: expected at least 100 samples, got {n}")
    if holes < 0:
        raise ValueError(f"holes: expected a count >= 0, got {holes}")
    outliers = _check_fraction(outliers, "outliers")
    noise = float(noise)
    if not noise >= 0.0:
        raise ValueError(f"noise: expected a number >= 0, got {noise!r}")
    r_min, r_max = (float(r) for r in hole_radius)
    if not 0.0 < r_min <= r_max < 1.0:
        raise ValueError(f"hole_radius: expected (smallest, largest) with 0 < smallest <= "
                         f"largest < 1, got {hole_radius!r}")
    rng = np.random.default_rng(seed)

    xy = _r2_square(n, rng)  # (n, 2)
    h = 2.0 / np.sqrt(n)  # about the mean spacing in the parameter plane
    discs = _place_holes(holes, (r_min, r_max), _HOLE_GAP * h, rng)
    inside = np.zeros(len(xy), dtype=bool)
    for cx, cy, r in discs:
        inside |= np.hypot(xy[:, 0] - cx, xy[:, 1] - cy) < r
    uv = xy[~inside]
    z, grad = _height(uv)
    clean = np.column_stack([uv, z])  # (n_surface, 3)
    normals = _unit_rows(np.column_stack([-grad, np.ones(len(uv))]))

    F = Delaunay(uv).simplices.astype(np.int64)
    # Drop the triangles over a hole: all their corners lie outside it, so a triangle that
    # spans it has its centroid inside or an edge far longer than the spacing.
    centroid = uv[F].mean(axis=1)
    over_hole = np.zeros(len(F), dtype=bool)
    for cx, cy, r in discs:
        over_hole |= np.hypot(centroid[:, 0] - cx, centroid[:, 1] - cy) < r
    edge = np.linalg.norm(uv[F] - uv[np.roll(F, 1, axis=1)], axis=2).max(axis=1)
    F = F[~over_hole & (edge < 3.0 * h)]
    area2 = 2.0 * signed_areas(uv, F)
    F[area2 < 0] = F[area2 < 0][:, ::-1]  # counter-clockwise in the parameter plane
    spacing = mean_edge(clean, F)

    points = clean + rng.normal(scale=noise * spacing, size=clean.shape)
    n_stray = int(round(outliers * len(clean)))
    low, high = clean.min(axis=0), clean.max(axis=0)
    margin = 0.2 * (high - low)
    tree = cKDTree(clean)
    strays = np.zeros((0, 3))
    for _ in range(_STRAY_TRIES):
        if len(strays) == n_stray:
            break
        cand = rng.uniform(low - margin, high + margin, (4 * n_stray, 3))
        far = tree.query(cand)[0] > _STRAY_CLEARANCE * spacing
        strays = np.vstack([strays, cand[far]])[:n_stray]
    if len(strays) < n_stray:
        raise ValueError(f"outliers: found room for {len(strays)} of {n_stray} strays 4 "
                         f"spacings off the surface; ask for fewer")
    stray_normals = _unit_rows(rng.normal(size=(n_stray, 3)))
    return HeightFieldScan(
        points=np.vstack([points, strays]),
        normals=np.vstack([normals, stray_normals]),
        faces=F,
        is_outlier=np.arange(len(clean) + n_stray) >= len(clean),
        uv_true=np.vstack([uv, strays[:, :2]]),
        holes=discs,
        spacing=spacing,
    )


def _camera(V: np.ndarray, viewpoint: np.ndarray, resolution: tuple[int, int]
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A pinhole camera at ``viewpoint`` looking at the centre of ``V``'s bounding box, its
    square field of view just holding ``V``'s bounding sphere.

    Returns
    -------
    frame : (3, 3) float64
        Rows: right, up, forward (unit, orthogonal).
    x : (W,) float64, y : (H,) float64
        Image-plane coordinates of the pixel columns (left to right) and rows (top to
        bottom), at unit distance: pixel ``(i, j)``'s ray is ``forward + x[j] right + y[i] up``.
    """
    centre = 0.5 * (V.min(axis=0) + V.max(axis=0))
    radius = np.linalg.norm(V - centre, axis=1).max()
    forward = centre - viewpoint
    distance = np.linalg.norm(forward)
    forward = forward / distance
    # Any up vector not along the look direction: z unless looking along z.
    up = np.array([0.0, 0.0, 1.0]) if abs(forward[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    half = np.tan(np.arcsin(min(radius / distance, 0.999)))  # half-width of the image plane
    W, H = resolution
    x = np.linspace(-half, half, W)
    y = np.linspace(half * H / W, -half * H / W, H)  # row 0 at the top
    return np.stack([right, up, forward]), x, y


def _first_hits(V: np.ndarray, F: np.ndarray, origin: np.ndarray, frame: np.ndarray,
                x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The first triangle each pixel's ray hits, and the distance to it.

    Broad phase by projection: every vertex lies in front of the camera, so the ray of pixel
    ``(x_j, y_i)`` can only hit a triangle whose projected bounding box holds ``(x_j, y_i)``
    (pinhole rays and perspective projection are the same lines). Each such pair then gets
    the exact Moller-Trumbore ray/triangle test, and each pixel keeps its nearest hit.

    Returns
    -------
    first : (H * W,) int64
        Triangle index per pixel (row-major), -1 where the ray misses.
    t : (H * W,) float64
        Distance from ``origin`` along the unit ray to the hit; inf where it misses.
    """
    W, H = len(x), len(y)
    q = (V - origin) @ frame.T  # (n, 3): right, up, depth
    proj = q[:, :2] / q[:, 2:]  # (n, 2) image-plane coordinates
    P = proj[F]  # (m, 3, 2)
    step_x, step_y = x[1] - x[0], y[0] - y[1]
    # Pixel ranges [c0, c1) and [r0, r1) inside each triangle's projected bounding box.
    # Widened by a millionth of a pixel: a ray through a vertex must reach the exact test.
    lo, hi = P.min(axis=1) - 1e-6 * step_x, P.max(axis=1) + 1e-6 * step_x  # (m, 2) each
    c0 = np.clip(np.ceil((lo[:, 0] - x[0]) / step_x), 0, W).astype(np.int64)
    c1 = np.clip(np.floor((hi[:, 0] - x[0]) / step_x) + 1, 0, W).astype(np.int64)
    r0 = np.clip(np.ceil((y[0] - hi[:, 1]) / step_y), 0, H).astype(np.int64)
    r1 = np.clip(np.floor((y[0] - lo[:, 1]) / step_y) + 1, 0, H).astype(np.int64)
    nc, nr = np.maximum(c1 - c0, 0), np.maximum(r1 - r0, 0)
    count = nc * nr
    tri = np.repeat(np.arange(len(F)), count)  # (pairs,)
    k = np.arange(len(tri)) - np.repeat(np.cumsum(count) - count, count)  # index in the box
    col = c0[tri] + k % nc[tri]
    row = r0[tri] + k // nc[tri]
    D = frame[2] + x[col, None] * frame[0] + y[row, None] * frame[1]
    D /= np.linalg.norm(D, axis=1, keepdims=True)  # (pairs, 3) unit rays
    # Moller-Trumbore: origin + t D = a + u (b - a) + v (c - a).
    a, b, c = V[F[tri, 0]], V[F[tri, 1]], V[F[tri, 2]]
    e1, e2 = b - a, c - a
    p = np.cross(D, e2)
    det = np.einsum("kd,kd->k", e1, p)
    ok = np.abs(det) > 1e-300
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = origin - a
    u = np.einsum("kd,kd->k", s, p) * inv
    qv = np.cross(s, e1)
    v = np.einsum("kd,kd->k", D, qv) * inv
    t = np.einsum("kd,kd->k", e2, qv) * inv
    eps = 1e-12  # rays through an edge or a vertex hit at least one of its triangles
    hit = ok & (u >= -eps) & (v >= -eps) & (u + v <= 1.0 + eps) & (t > 0.0)
    pixel = (row * W + col)[hit]
    tri, t = tri[hit], t[hit]
    order = np.lexsort((t, pixel))  # by pixel, nearest first
    pixel, tri, t = pixel[order], tri[order], t[order]
    lead = np.ones(len(pixel), dtype=bool)
    lead[1:] = pixel[1:] != pixel[:-1]
    first = np.full(H * W, -1, dtype=np.int64)
    distance = np.full(H * W, np.inf)
    first[pixel[lead]] = tri[lead]
    distance[pixel[lead]] = t[lead]
    return first, distance


def _grid_triangles(hit: np.ndarray) -> np.ndarray:
    """Pixel-index triangles ``(M, 3)`` of a ``(H, W)`` hit mask: the two halves of each 2x2
    block (split along its top-left to bottom-right diagonal) whose three corners all hit."""
    H, W = hit.shape
    idx = np.arange(H * W).reshape(H, W)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()  # top-left, top-right
    c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()  # bottom-left, bottom-right
    # Row 0 is the top and column 0 the left: (a, c, d) and (a, d, b) run counter-clockwise
    # as seen by the camera.
    T = np.concatenate([np.column_stack([a, c, d]), np.column_stack([a, d, b])])
    flat = hit.ravel()
    return T[flat[T].all(axis=1)]


def _share_a_vertex(F: np.ndarray, s: np.ndarray, t: np.ndarray) -> np.ndarray:
    """True where mesh triangles ``s`` and ``t`` are the same or share a vertex."""
    A, B = F[s], F[t]  # (m, 3)
    return (A[:, :, None] == B[:, None, :]).any(axis=(1, 2))


def range_scan(V, F, *, viewpoint=None, resolution: tuple[int, int] = (120, 120),
               noise: float = 0.25, strays: float = 0.01, max_incidence: float = 80.0,
               seed: int = 0) -> RangeScan:
    """A simulated range scan of the mesh ``(V, F)`` from one viewpoint.

    A pinhole camera at ``viewpoint`` looks at the centre of the mesh's bounding box with a
    square field of view that just holds the mesh's bounding sphere, and casts one ray per
    pixel of a ``W x H`` image. Each ray keeps its first hit (an exact ray/triangle test after
    a broad phase by projection into the image; trimesh's ray queries would need rtree or
    embree), so whatever the mesh hides from the viewpoint leaves a hole; hits at more than
    ``max_incidence`` degrees between the ray and the surface normal are dropped, as a
    scanner drops grazing returns. Each hit then moves along its ray by Gaussian range noise
    of ``noise`` spacings (mean edge length of the reference triangles), and
    ``round(strays * hits)`` stray returns are added: along the rays of random pixels, at a
    uniform range between the near and far side of the bounding sphere, each at least 4
    spacings from every hit.

    Parameters
    ----------
    V : (n, 3) array_like
        Mesh vertices.
    F : (m, 3) array_like of int
        Mesh triangles.
    viewpoint : (3,) array_like, optional
        Where the rays start; default: on the +z axis through the bounding box's centre, at
        2.5 bounding-sphere radii from it.
    resolution : (int, int)
        Image width and height in pixels; 120 x 120 of a 20k-triangle mesh takes about
        0.1 s.
    noise : float
        Standard deviation of the range noise, in spacings.
    strays : float
        Stray returns as a fraction of the hits, in ``[0, 1)``.
    max_incidence : float
        Largest angle, in degrees, between a ray and the normal of the triangle it hits.
    seed : int
        Seeds the noise and the strays.

    Returns
    -------
    RangeScan

    Raises
    ------
    ValueError
        Bad shapes, a viewpoint inside the bounding sphere, a bad resolution, ``noise``,
        ``strays`` or ``max_incidence``, or fewer than 3 returns.
    """
    from scipy.spatial import cKDTree

    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F)
    if V.ndim != 2 or V.shape[1] != 3:
        raise ValueError(f"V: expected shape (n, 3), got {V.shape}")
    if F.ndim != 2 or F.shape[1] != 3 or F.dtype.kind not in "iu":
        raise ValueError(f"F: expected integer faces of shape (m, 3), got {F.shape} {F.dtype}")
    F = F.astype(np.int64)
    if len(F) == 0 or F.min() < 0 or F.max() >= len(V):
        raise ValueError(f"F: expected indices in [0, {len(V)}), got faces referencing "
                         f"{F.min() if len(F) else 'nothing'} to {F.max() if len(F) else ''}")
    W, H = (int(v) for v in resolution)
    if W < 2 or H < 2:
        raise ValueError(f"resolution: expected (W, H) of at least 2 pixels each, got {resolution}")
    noise = float(noise)
    if not noise >= 0.0:
        raise ValueError(f"noise: expected a number >= 0, got {noise!r}")
    strays = _check_fraction(strays, "strays")
    max_incidence = float(max_incidence)
    if not 0.0 < max_incidence <= 90.0:
        raise ValueError(f"max_incidence: expected degrees in (0, 90], got {max_incidence!r}")
    lo, hi = V.min(axis=0), V.max(axis=0)
    centre = 0.5 * (lo + hi)
    radius = float(np.linalg.norm(V - centre, axis=1).max())
    if viewpoint is None:
        viewpoint = centre + np.array([0.0, 0.0, 2.5 * radius])
    viewpoint = np.asarray(viewpoint, dtype=np.float64)
    if viewpoint.shape != (3,):
        raise ValueError(f"viewpoint: expected shape (3,), got {viewpoint.shape}")
    if np.linalg.norm(viewpoint - centre) <= radius:
        raise ValueError("viewpoint: must lie outside the mesh's bounding sphere")
    rng = np.random.default_rng(seed)

    frame, x, y = _camera(V, viewpoint, (W, H))
    first, distance = _first_hits(V, F, viewpoint, frame, x, y)  # (H W,) each
    gx, gy = np.meshgrid(x, y, indexing="xy")  # (H, W)
    D = frame[2] + gx.reshape(-1, 1) * frame[0] + gy.reshape(-1, 1) * frame[1]
    D /= np.linalg.norm(D, axis=1, keepdims=True)  # (H W, 3) unit rays, row-major pixels
    # Grazing returns off: the angle between the ray and the hit triangle's normal.
    face_normal = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    face_normal /= np.maximum(np.linalg.norm(face_normal, axis=1, keepdims=True), 1e-300)
    hit = np.flatnonzero(first >= 0)
    cos = np.abs(np.einsum("nd,nd->n", face_normal[first[hit]], D[hit]))
    keep = hit[cos >= np.cos(np.radians(max_incidence))]
    if len(keep) < 3:
        raise ValueError(f"range_scan: {len(keep)} rays hit the mesh, need at least 3; check "
                         f"the viewpoint")
    hit = np.zeros(len(D), dtype=bool)
    hit[keep] = True

    T = _grid_triangles(hit.reshape(H, W))  # pixel indices
    t = first[T]
    same_patch = (_share_a_vertex(F, t[:, 0], t[:, 1]) & _share_a_vertex(F, t[:, 1], t[:, 2])
                  & _share_a_vertex(F, t[:, 2], t[:, 0]))
    T = T[same_patch]
    row = np.full(len(D), -1, dtype=np.int64)
    row[keep] = np.arange(len(keep))
    faces = row[T]
    clean = viewpoint + distance[keep, None] * D[keep]  # exact hit points
    spacing = mean_edge(clean, faces) if len(faces) else float(
        np.median(cKDTree(clean).query(clean, 2)[0][:, 1]))

    rng_noise = rng.normal(scale=noise * spacing, size=len(keep))
    points = clean + rng_noise[:, None] * D[keep]
    normals = face_normal[first[keep]]
    normals = normals * np.where(np.einsum("nd,nd->n", normals, D[keep]) > 0, -1.0, 1.0)[:, None]

    n_stray = int(round(strays * len(keep)))
    tree = cKDTree(clean)
    view_distance = np.linalg.norm(centre - viewpoint)
    stray_pixels = np.zeros(0, dtype=np.int64)
    stray_points = np.zeros((0, 3))
    for _ in range(_STRAY_TRIES):
        if len(stray_points) == n_stray:
            break
        pix = rng.integers(0, len(D), 4 * n_stray)
        rng_range = rng.uniform(view_distance - radius, view_distance + radius, len(pix))
        cand = viewpoint + rng_range[:, None] * D[pix]
        far = tree.query(cand)[0] > _STRAY_CLEARANCE * spacing
        stray_pixels = np.concatenate([stray_pixels, pix[far]])[:n_stray]
        stray_points = np.vstack([stray_points, cand[far]])[:n_stray]
    if len(stray_points) < n_stray:
        raise ValueError(f"strays: found room for {len(stray_points)} of {n_stray} stray "
                         f"returns 4 spacings off the surface; ask for fewer")
    pixels = np.concatenate([keep, stray_pixels])
    return RangeScan(
        points=np.vstack([points, stray_points]),
        normals=np.vstack([normals, -D[stray_pixels]]),
        faces=faces,
        is_outlier=np.arange(len(pixels)) >= len(keep),
        hit_triangle=np.concatenate([first[keep], np.full(n_stray, -1, dtype=np.int64)]),
        pixel=np.column_stack([pixels % W, pixels // W]).astype(np.int64),
        viewpoint=viewpoint,
        spacing=spacing,
    )


def _serpentine(s: np.ndarray, run: float, radius: float, folds: int
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The accordion's cross-section at arc lengths ``s``: straight runs of length ``run``
    along x, alternately rightwards and leftwards, each joined to the next by a half circle of
    ``radius`` turning upwards. Returns (x, z), the unit normal (nx, nz) on the side the
    first run's +z faces, and each point's run (-1 on a half circle)."""
    period = run + np.pi * radius
    k = np.minimum((s // period).astype(np.int64), folds)  # the run (and the fold after it)
    t = s - k * period  # arc length since run k began
    direction = np.where(k % 2 == 0, 1.0, -1.0)  # run k goes along +x (even) or -x (odd)
    x0 = np.where(k % 2 == 0, 0.0, run)
    z0 = 2.0 * radius * k
    on_run = (t <= run) | (k == folds)
    x = np.where(on_run, x0 + direction * np.minimum(t, run), 0.0)
    z = np.where(on_run, z0, 0.0)
    nx = np.zeros_like(s)
    nz = np.where(on_run, direction, 0.0)  # +z on even runs, -z on odd ones
    # A half circle about (x0 + direction * run, z0 + radius), from angle -pi/2 through 0
    # (a rightward run's end) or from -pi/2 through pi (a leftward one's).
    phi = (t - run) / radius
    turn = ~on_run
    cx = x0 + direction * run
    ang = -np.pi / 2 + direction * phi
    x = np.where(turn, cx + radius * np.cos(ang), x)
    z = np.where(turn, z0 + radius + radius * np.sin(ang), z)
    # The normal turns with the curve: towards the centre after a rightward run (+z there),
    # away from it after a leftward one (-z there).
    nx = np.where(turn, -direction * np.cos(ang), nx)
    nz = np.where(turn, -direction * np.sin(ang), nz)
    return np.column_stack([x, z]), np.column_stack([nx, nz]), np.where(on_run, k, -1)


def even_rectangle(n: int, width: float, rng) -> tuple[np.ndarray, np.ndarray]:
    """About ``n`` points of the rectangle [0, 1] x [0, width]: its sides sampled evenly at
    the spacing ``sqrt(width / n)`` (the rim, ``(m, 2)``), and inside the square's R2
    sequence stretched, less the samples closer than half a spacing to the rim's."""
    from scipy.spatial import cKDTree

    h = np.sqrt(width / n)
    sides = []
    for (x0, y0), (x1, y1) in (((0, 0), (1, 0)), ((1, 0), (1, width)),
                               ((1, width), (0, width)), ((0, width), (0, 0))):
        m = max(int(np.ceil(np.hypot(x1 - x0, y1 - y0) / h)), 1)
        t = np.arange(m)[:, None] / m
        sides.append([x0, y0] + t * [x1 - x0, y1 - y0])
    rim = np.vstack(sides)
    inside = ((_r2_square(n, rng) + 1.0) / 2.0) * [1.0, width]
    return rim, inside[cKDTree(rim).query(inside)[0] > 0.5 * h]


def pleated_sheet(n: int = 6000, folds: int = 4, gap: float = 2.0, *, width: float = 1.0,
                  seed: int = 0) -> PleatedSheet:
    """A sheet folded like an accordion: ``folds`` half-circle folds whose facing sheets lie
    ``gap`` point spacings apart, as the walls of a sulcus or a closed eyelid.

    The cross-section is a serpentine of ``folds + 1`` straight runs joined by half circles of
    radius ``gap * spacing / 2`` (:func:`_serpentine`); the surface sweeps it along y over
    ``width``. It is developable: its points are sampled area-uniformly (a shifted R2
    sequence, and the sides evenly) in the rectangle of arc length by height, which is also
    the true map.

    Parameters
    ----------
    n : int
        Points of the rectangle's sample, at least 100 (a few are dropped near its sides, and
        the sides' own points added).
    folds : int
        Half-circle folds, at least 1.
    gap : float
        Distance between facing sheets, in mean spacings (mean edge length of the reference
        triangles), > 0.
    width : float
        The sheet's extent along the folds; the arc length across them is 1.
    seed : int
        Seeds the sample's shift and jitter.

    Returns
    -------
    PleatedSheet

    Raises
    ------
    ValueError
        A bad ``n``, ``folds``, ``gap`` or ``width``, or folds too tight for the sheet (the
        half circles would take more than half of the arc length).
    """
    from scipy.spatial import Delaunay

    n, folds = int(n), int(folds)
    if n < 100:
        raise ValueError(f"n: expected at least 100 points, got {n}")
    if folds < 1:
        raise ValueError(f"folds: expected at least 1, got {folds}")
    gap, width = float(gap), float(width)
    if not gap > 0 or not width > 0:
        raise ValueError(f"gap, width: expected positive numbers, got {gap!r}, {width!r}")
    rng = np.random.default_rng(seed)
    # The rectangle [0, 1] x [0, width]: its sides sampled evenly (so that the Delaunay
    # triangulation has no slivers along them), its inside by the square's R2 sequence
    # stretched, without the samples closer than half a spacing to a side's.
    h = np.sqrt(width / n)
    rim, inside = even_rectangle(n, width, rng)
    inside = inside[(inside > 0.5 * h).all(axis=1) & (inside < [1.0, width] - 0.5 * h).all(axis=1)]
    uv = np.vstack([inside, rim])
    F = Delaunay(uv).simplices.astype(np.int64)
    area2 = 2.0 * signed_areas(uv, F)
    F = F[np.abs(area2) > 1e-12 * width]  # collinear side points
    area2 = area2[np.abs(area2) > 1e-12 * width]
    F[area2 < 0] = F[area2 < 0][:, ::-1]
    spacing = mean_edge(np.column_stack([uv, np.zeros(len(uv))]), F)
    radius = gap * spacing / 2.0
    run = (1.0 - folds * np.pi * radius) / (folds + 1)
    if run < 1.0 / (2 * (folds + 1)):
        raise ValueError(f"gap: {folds} folds of {gap:g} spacings take more than half of the "
                         f"sheet; ask for fewer folds, a smaller gap or more points")
    xz, nxz, sheet = _serpentine(uv[:, 0], run, radius, folds)
    points = np.column_stack([xz[:, 0], uv[:, 1], xz[:, 1]])
    normals = np.column_stack([nxz[:, 0], np.zeros(len(uv)), nxz[:, 1]])
    return PleatedSheet(points=points, normals=normals, faces=F, uv_true=uv, spacing=spacing,
                        gap=gap, sheet=sheet)


# --------------------------------------------------------------------------- the car shell

CAR_ROOF = 0.32
"""|y| of the side windows' upper edge (the roof's edge) in the car shell's construction."""
CAR_WINDOW = (-0.55, 0.45)
"""x range of the side windows in the construction."""
CAR_EDGE_POINTS = 67
"""Points on each window's upper edge (the paper: 134 in all)."""
CAR_TARGET_LINES = [[[-0.5, -0.25], [0.5, -0.25]], [[-0.5, 0.25], [0.5, 0.25]]]
"""The paper's landmark target lines ``[-0.5, 0.5] x {-0.25, 0.25}`` in the car domain."""
CAR_TARGET_SPACING = 1.0 / 199
"""200 points on each target line of length 1, 400 in all (the paper: 400)."""


def _step(x, a, b, width):
    """About 1 on [a, b], 0 outside, smooth over ``width``."""
    return 0.5 * (np.tanh((x - a) / width) - np.tanh((x - b) / width))


def car_lift(P: np.ndarray) -> np.ndarray:
    """The car shell's point of each point ``(x, y)`` (K, 2) of the ``car`` domain, (K, 3).

    Roof band ``|y| <= CAR_ROOF``: ``(x, 0.9 y, z_top(x) + 0.05 (1 - (y / CAR_ROOF)^2))``;
    sides ``|y| > CAR_ROOF``, with ``s = (|y| - CAR_ROOF) / (0.7 - CAR_ROOF)`` from the roof's
    edge (0) to the bottom (1): ``(x, sign(y) (0.9 CAR_ROOF + 0.12 s), z_top(x) (1 - s))``.
    ``z_top`` is 0.08 plus 0.12 over the body (bonnet to boot) plus 0.22 over the cabin.
    The bending is not conformal: the sides are tall (0.4) in the cabin and short (0.1-0.2)
    on the bonnet and boot, and the roof is 0.58 wide where the domain's middle band is 0.5.
    """
    x, y = P[:, 0], P[:, 1]
    t, sg = np.abs(y), np.where(y < 0, -1.0, 1.0)
    z_top = 0.08 + 0.12 * _step(x, -0.95, 0.9, 0.12) + 0.22 * _step(x, *CAR_WINDOW, 0.08)
    s = np.clip((t - CAR_ROOF) / (0.7 - CAR_ROOF), 0.0, None)
    roof = t <= CAR_ROOF
    Y = np.where(roof, 0.9 * y, sg * (0.9 * CAR_ROOF + 0.12 * s))
    Z = np.where(roof, z_top + 0.05 * (1 - (y / CAR_ROOF) ** 2), z_top * (1 - s))
    return np.column_stack([x, Y, Z])


def car_shell(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A car-like shell: a roof, bonnet and boot on top and two sides hanging from them, open
    underneath, with the wheel arches cut out of the sides' lower edges; the image of the
    ``car`` domain under :func:`car_lift`. The window edges, the curves ``|y| = CAR_ROOF,
    x in CAR_WINDOW`` of the construction, do not fall on the domain's window lines
    (:data:`CAR_TARGET_LINES`) by themselves: the paper's landmark test.

    The cloud is the lift of ``n`` area-uniform samples of the car domain, of its boundary
    (so the triangulation has a clean edge) and of the window edges (:data:`CAR_EDGE_POINTS`
    per side, evenly spaced); samples closer than half a spacing to a boundary or edge point
    are dropped. The triangles are the parameter-space Delaunay triangles whose centroid is in
    the domain, counter-clockwise there.

    Returns
    -------
    V : (N, 3) float64
    F : (M, 3) int64
    edges : (2 * CAR_EDGE_POINTS,) int64 rows of V on the window edges
    """
    from scipy.spatial import Delaunay, cKDTree

    from .domains import get_domain

    car = get_domain("car")
    inner = car.sample(n, seed=seed)
    spacing = np.sqrt(car.area / n)
    border = car.boundary(int(np.ceil(car.geometry.length / spacing)))
    ex = np.linspace(*CAR_WINDOW, CAR_EDGE_POINTS)
    edge = np.vstack([np.column_stack([ex, np.full_like(ex, -CAR_ROOF)]),
                      np.column_stack([ex, np.full_like(ex, CAR_ROOF)])])
    near, _ = cKDTree(np.vstack([edge, border])).query(inner)
    inner = inner[near > 0.5 * spacing]
    P = np.vstack([inner, border, edge])
    F = Delaunay(P).simplices.astype(np.int64)
    F = F[car.contains(P[F].mean(axis=1))]
    flip = signed_areas(P, F) < 0
    F[flip] = F[flip][:, [0, 2, 1]]
    edges = np.arange(len(P) - len(edge), len(P), dtype=np.int64)
    return car_lift(P), F, edges
