"""A cloud's neighbourhoods: one k-d tree query its steps share (:class:`Neighbours`), stray
points (:func:`find_outliers`) and the neighbourhood PCA (:func:`local_pca`,
:func:`adaptive_pca`, :func:`surface_variation`) that the surface test, the normals and the
noise estimate read."""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = [
    "Neighbours",
    "find_outliers",
    "local_pca",
    "adaptive_pca",
    "RULES",
    "SHEET_GAP",
    "own_sheet",
    "scale_ladder",
    "surface_variation",
    "quadric_basis",
    "voted_normals",
    "on_a_sheet",
    "OUTLIER_FACTOR",
    "OFFSET_FACTOR",
]


OUTLIER_FACTOR = 4.0
"""A point is an outlier when its mean distance to its neighbours exceeds this many times the
median of that distance over its neighbours."""

OFFSET_FACTOR = 3.0
"""... or when it sits farther than this many median spacings off its neighbours' plane."""


def _workers() -> int:
    """Threads for the k-d tree queries: torch's thread count, the one budget of a run (the
    CLI's ``--threads``, a batch task's ``--threads-per-worker``), so that a Dask worker's
    queries do not take every core."""
    import torch

    return max(1, torch.get_num_threads())


@dataclasses.dataclass(frozen=True, eq=False)
class Neighbours:
    """Each point's nearest points, itself first: one k-d tree query that a cloud's steps
    share (strays, noise, normals, their orientation, the fans), each reading the first
    columns it needs.

    Six queries of one 300k-point cloud took 4.5 s (one thread) of a 45 s map; rows of a query
    with more neighbours are the same as a smaller query's first columns (ties between equally
    distant points aside).
    """

    dist: np.ndarray
    """(N, k + 1) float64: distances, ascending; column 0 (the point itself) is 0."""
    index: np.ndarray
    """(N, k + 1) int64: the neighbours' rows; column 0 is the row itself."""
    tree: object = None
    """The k-d tree (scipy's cKDTree) of the points queried, when :meth:`of` built it (the
    local mesh's repair queries it again, :func:`pcgeom.maps.topology.repair`)."""

    @classmethod
    def of(cls, X, k: int) -> "Neighbours":
        """The ``k`` nearest points of every point of ``X`` (distinct points; at most
        ``len(X) - 1``), by scipy's k-d tree on :func:`_workers` threads."""
        from scipy.spatial import cKDTree

        X = np.asarray(X, dtype=np.float64)
        tree = cKDTree(X)
        dist, index = tree.query(X, min(int(k), len(X) - 1) + 1, workers=_workers())
        return cls(dist.reshape(len(X), -1), index.reshape(len(X), -1), tree)

    @property
    def k(self) -> int:
        """Neighbours per point, the point itself not counted."""
        return self.index.shape[1] - 1

    def first(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Distances and rows of the ``k`` nearest, itself first (all the others in a cloud
        of at most ``k + 1`` points)."""
        if k > self.k and self.k < len(self.index) - 1:
            raise ValueError(f"{k} neighbours asked of a query of {self.k}")
        return self.dist[:, :k + 1], self.index[:, :k + 1]

    def among(self, keep: np.ndarray, X) -> "Neighbours":
        """The neighbours within the points ``keep`` (bool, (N,)), rows renumbered as in
        ``X[keep]``: a row that named a dropped point is queried again among the kept."""
        from scipy.spatial import cKDTree

        keep = np.asarray(keep, dtype=bool)
        rows = np.flatnonzero(keep)
        remap = np.full(len(keep), -1, dtype=np.int64)
        remap[rows] = np.arange(len(rows))
        index = remap[self.index[rows]]
        dist = self.dist[rows]
        k = min(self.k, len(rows) - 1)
        lost = np.flatnonzero((index < 0).any(axis=1) | (k < self.k))
        index, dist = index[:, :k + 1], dist[:, :k + 1]
        if len(lost):
            Xk = np.asarray(X, dtype=np.float64)[rows]
            d, i = cKDTree(Xk).query(Xk[lost], k + 1, workers=_workers())
            dist[lost], index[lost] = d.reshape(len(lost), -1), i.reshape(len(lost), -1)
        return Neighbours(dist, index)


def find_outliers(X, neighbours: int = 16, *, knn: Neighbours | None = None
                  ) -> np.ndarray:
    """Stray points: far from the others, or off the surface their neighbours sample.

    Two tests, each against the cloud's own scale (medians, which the strays cannot pull):

    - **isolated**: ``d_i``, the mean distance of ``x_i`` to its 8 nearest points, exceeds
      :data:`OUTLIER_FACTOR` times the median of ``d`` over its ``neighbours`` (the
      statistical outlier test of PCL and Open3D, with a robust and local scale: scans are
      denser in some places than others);
    - **off the surface**: its height over the least-squares quadric of its ``neighbours``
      nearest points on its own sheet (itself excluded, in their principal frame;
      :func:`own_sheet`: a fold's facing sheet left out) exceeds :data:`OFFSET_FACTOR` times
      the median nearest-neighbour spacing. Noise of about the spacing stays below it; a
      stray a few spacings off a surface has no sheet of its own (:func:`own_sheet` keeps all
      when fewer than 9 would be left), so it is measured against the surface as before.
      Fitted to both sheets (before issue 39), the facing wall of a groove pulled the quadric
      half-way and the points of unevenly sampled walls read as strays, which the local mesh
      then left out: :func:`pcgeom.synthetic_folds.deep_folds` of 6000 uniformly random
      points, walls 1.5 / 2 spacings apart, seed 0: 56 / 15 -> 24 / 2 points (bare ``fast``
      true triangles turned over 1.39 / 0.48% -> 1.19 / 0.45%, seed 1 1.23 / 0.44% -> 1.18 /
      0.18%); the shared surfaces, the pleats and the evenly sampled grooves none either way;
      :func:`pcgeom.synthetic.holey_heightfield` (6000 points, 2% strays, depth noise 0 to 1
      spacing, seeds 0-2) the same strays found, 3 more / 5 fewer surface points flagged at
      noise 0.5 / 1 (of 7 / 160). Where the uniform sampling leaves a wall's point more
      neighbours on the facing wall than on its own, the own-sheet test keeps both and the
      point still reads as a stray; one that lies amid a plane of its neighbours
      (:func:`on_a_sheet`) is kept (issue 39): the same grooves 1 / 1.5 spacings apart,
      seeds 0-1, 29, 29 / 24, 21 -> 10, 12 / 10, 10 points flagged (bare ``fast`` on the true
      triangles, 1.5 apart: seed 0 0.0380 rad, 0.93% flipped -> 0.0320, 0.67%, seed 1 0.0658,
      1.18% -> 0.0558, 0.94%; with their normals 0.0316, 0.48% -> 0.0223, 0.33%);
      ``holey_heightfield``'s strays (seeds 0-2, noise 0 / 0.5 / 1) all found as before,
      2 / 4 fewer surface points flagged at noise 0.5 / 1; nothing flagged on the shared
      surfaces, the pleats or the evenly sampled grooves either way.

    Parameters
    ----------
    X : (N, 3) array_like
        Distinct points.
    knn : Neighbours, optional
        Their nearest points, when already found (at least ``neighbours`` each).

    Returns
    -------
    (N,) bool
        True for an outlier.
    """
    X = np.asarray(X, dtype=np.float64)
    dist, nb = (knn if knn is not None else Neighbours.of(X, neighbours)).first(neighbours)
    d = dist[:, 1:9].mean(axis=1)
    # Against the neighbours' own d: scans are sampled more densely in some places.
    isolated = d > OUTLIER_FACTOR * np.median(d[nb[:, 1:]], axis=1)
    # Height of x_i over the quadric fitted to its neighbours in their PCA frame (a plane
    # would call the tip of a sharp, coarsely sampled peak an outlier). In blocks: a
    # million points' fits at once would hold 0.8 GB of basis values.
    offset = np.empty(len(X))
    for s in range(0, len(X), _FIT_CHUNK):
        P = X[nb[s:s + _FIT_CHUNK, 1:]]
        w = own_sheet(X[nb[s:s + _FIT_CHUNK]])[:, 1:].astype(np.float64)  # weights 0 or 1
        centre = (w[..., None] * P).sum(axis=1) / w.sum(axis=1, keepdims=True)
        Q = P - centre[:, None, :]
        _, frame = np.linalg.eigh(np.matmul(Q.transpose(0, 2, 1), w[..., None] * Q))
        local = np.matmul(Q, frame)  # (n, k, 3); frame's columns: n, e1, e2
        own = np.matmul((X[s:s + _FIT_CHUNK] - centre)[:, None, :], frame)  # (n, 1, 3)
        A = quadric_basis(local[..., 1], local[..., 2])  # (n, k, 6)
        At = A.transpose(0, 2, 1) * w[:, None, :]
        coef = np.linalg.solve(np.matmul(At, A) + 1e-12 * np.eye(6),
                               np.matmul(At, local[..., :1]))  # (n, 6, 1)
        height = np.matmul(quadric_basis(own[..., 1], own[..., 2]), coef)[:, 0, 0]
        offset[s:s + _FIT_CHUNK] = np.abs(own[:, 0, 0] - height)
    off = offset > OFFSET_FACTOR * np.median(dist[:, 1])
    # A point off its quadric that lies amid a plane of its neighbours is on a sheet whose
    # facing sheet the own-sheet test did not part from it.
    rows = np.flatnonzero(off & ~isolated)
    off[rows[on_a_sheet(X, rows, nb, float(np.median(dist[:, 1:7].mean(axis=1))))]] = False
    return isolated | off


_FIT_CHUNK = 65_536
"""Points per block of :func:`find_outliers`' quadric fits."""


def quadric_basis(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``[1, x, y, x^2, x y, y^2]`` along a new last axis: the quadric fits' basis here and in
    :mod:`pcgeom.denoise`."""
    return np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=-1)


def local_pca(X, neighbours: int = 16, *, knn: Neighbours | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
    """Eigen-decomposition of each point's neighbourhood covariance (itself and its
    ``neighbours`` nearest points; ``knn``: those points, when already found).

    Returns
    -------
    values : (N, 3) float64
        Eigenvalues, ascending.
    vectors : (N, 3, 3) float64
        Unit eigenvectors as columns; ``vectors[:, :, 0]`` is the (unoriented) normal.
    """
    X = np.asarray(X, dtype=np.float64)
    nb = (knn if knn is not None else Neighbours.of(X, neighbours)).first(neighbours)[1]
    Q = X[nb] - X[nb].mean(axis=1, keepdims=True)
    return np.linalg.eigh(np.einsum("nki,nkj->nij", Q, Q))


def scale_ladder(scales, n: int) -> np.ndarray:
    """The distinct neighbour counts of ``scales`` a cloud of ``n`` points allows (each at
    most ``n - 1``), increasing: the columns of :func:`adaptive_pca`'s ``per_scale``."""
    return np.array(sorted({min(int(k), n - 1) for k in scales}), dtype=np.int64)


RULES = ("flattest", "one_sheet", "own_sheet", "smallest_planar", "consistent")
"""How :func:`adaptive_pca` may pick a point's scale (its ``rule``); the first is the default,
the others were measured against it (issue 39) and are kept for ``benchmarks/bench_folds.py``."""

SHEET_GAP = 0.6
"""A neighbourhood is two-sheeted when its points' offsets along its normal, sorted, jump by
more than this many local spacings (the mean distance to the point's 6 nearest) with points
on both sides: a facing sheet a spacing or more away, not noise or a curve's steady rise."""


def adaptive_pca(X, scales=(6, 8, 12, 16, 24), tolerance: float = 0.03,
                 chunk: int = 100_000, *, knn: Neighbours | None = None,
                 rule: str = "flattest") -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each point's neighbourhood PCA at the scale that fits a plane best: the largest of
    ``scales`` (neighbour counts) whose surface variation is within ``tolerance`` of the
    smallest over all of them.

    One fixed neighbour count fails both ways: too few, and noise tilts the plane; too many,
    and where a surface doubles back (a fold, a sulcus, a closed eyelid) the neighbourhood
    takes in the facing sheet, and the plane of two sheets a couple of spacings apart stands
    across them. The surface variation (:func:`surface_variation`) is small for a plane and
    large for two sheets or a volume: the largest neighbourhood that is still nearly as flat
    as the flattest one averages the noise without reaching across. Measured on
    :func:`pcgeom.synthetic.pleated_sheet` (6000 points, sheets 2 spacings apart): normals
    more than 30 degrees off, 6.5% of the points with 16 neighbours, 0.1% with the adaptive
    scale; face_human_choi's orientation: 96.7% right with 16, 97.2% adaptive.

    Parameters
    ----------
    X : (N, 3) array_like
        Distinct points.
    scales : sequence of int
        Neighbour counts tried (the point itself excluded), each at least 3.
    tolerance : float
        How much more variation than the flattest scale a larger one may have.
    chunk : int
        Points per block (bounds the memory: ``chunk * max(scales) * 9`` floats).
    knn : Neighbours, optional
        The points' nearest points, when already found (at least ``max(scales)`` each).
    rule : str
        ``"flattest"`` (above); the others, measured and not kept (issue 39,
        ``benchmarks/bench_folds.py``): ``"one_sheet"``, the same among the scales below the
        first two-sheeted one (:func:`_one_sheet`; the smallest when that one is);
        ``"own_sheet"``, each scale's neighbours on the point's own sheet only
        (:func:`own_sheet`); ``"smallest_planar"``, the smallest one-sheeted scale within
        ``tolerance`` of the flattest one-sheeted one; ``"consistent"``, the flattest
        scale's PCA again with each neighbour weighted by how well its own normal agrees,
        ``|n_i . n_j| ** 8`` (:func:`_consistent`). On the deep-fold sheet
        (:func:`pcgeom.synthetic_folds.deep_folds`, walls 1.5-3 spacings apart) the first two
        map as the flattest does (within 0.0003 rad); the smallest planar scale maps better
        there (0.0111 against 0.0134 rad at 3 spacings) but face_human_choi at 0.0515 rad
        against 0.0312, and the pleat 1.5 spacings wide at 0.0505 against 0.0266; one
        sheet maps that pleat at 0.0369. Consistency weights map the grooves best (1.5 / 2 /
        3 spacings: 0.0160 / 0.0122 / 0.0091 against 0.0217 / 0.0112 / 0.0134) but that
        pleat at 0.0422 and 0.63% flipped (0.34%), face_human_choi 0.0330 against 0.0304,
        peaks_three_cgal 0.30% flipped against 0.19% (powers 2 and 4 worse on the grooves
        and no better elsewhere). What turned the deep folds over was the noise
        estimate reading the facing wall (:func:`own_sheet`), not the scale.

    Returns
    -------
    variation : (N,) float64
        The surface variation at the chosen scale.
    normals : (N, 3) float64
        Unit normals there (sign arbitrary).
    k : (N,) int64
        The chosen neighbour count.
    per_scale : (N, S) float64
        The surface variation at each of the ``S`` distinct scales, in increasing order.
    """
    if rule not in RULES:
        raise ValueError(f"rule: expected one of {', '.join(RULES)}, got {rule!r}")
    X = np.asarray(X, dtype=np.float64)
    ks = scale_ladder(scales, len(X))
    nb = (knn if knn is not None else Neighbours.of(X, int(ks[-1]))).first(int(ks[-1]))[1]
    variation = np.empty(len(X))
    normals = np.empty((len(X), 3))
    chosen = np.empty(len(X), dtype=np.int64)
    per_scale = np.empty((len(X), len(ks)))
    iu = np.triu_indices(3)
    for s in range(0, len(X), chunk):
        P = X[nb[s:s + chunk]]  # (n, K + 1, 3), the point itself first
        P = P - P[:, :1]  # about the point: better conditioned sums
        # Running sums over the neighbours in order of distance give every scale's
        # covariance at once (its six distinct entries).
        outer = P[..., iu[0]] * P[..., iu[1]]
        m = (ks + 1).astype(np.float64)[None, :, None]
        if rule == "own_sheet":
            W = own_sheet(P)[..., None].astype(np.float64)  # the facing sheet left out
            m = np.cumsum(W[..., 0], axis=1)[:, ks][..., None]
            P, outer = W * P, W * outer
        S1 = np.cumsum(P, axis=1)[:, ks]  # (n, scales, 3)
        S2 = np.cumsum(outer, axis=1)[:, ks]  # (n, scales, 6)
        del outer
        C6 = S2 - S1[..., iu[0]] * S1[..., iu[1]] / m
        var = _smallest_eigenvalue(C6) / np.maximum(C6[..., [0, 3, 5]].sum(axis=-1), 1e-300)
        per_scale[s:s + chunk] = var
        if rule in ("flattest", "own_sheet", "consistent"):
            ok = var <= var.min(axis=1, keepdims=True) + tolerance
        else:
            one = _one_sheet(P, C6, ks)
            flat = np.where(one, var, np.inf)
            ok = one & (flat <= flat.min(axis=1, keepdims=True) + tolerance)
            ok[:, 0] |= ~one[:, 0]  # every scale two-sheeted: the smallest
        if rule == "smallest_planar":
            pick = np.argmax(ok, axis=1)
        else:
            pick = len(ks) - 1 - np.argmax(ok[:, ::-1], axis=1)  # the largest scale within
        rows = np.arange(len(P))
        C = np.empty((len(P), 3, 3))
        C[:, iu[0], iu[1]] = C6[rows, pick]
        C[:, iu[1], iu[0]] = C6[rows, pick]
        values, vectors = np.linalg.eigh(C)
        variation[s:s + chunk] = values[:, 0] / np.maximum(values.sum(axis=1), 1e-300)
        normals[s:s + chunk] = vectors[:, :, 0]
        chosen[s:s + chunk] = ks[pick]
    if rule == "consistent":
        normals = _consistent(X, nb, normals, chosen)
    return variation, normals, chosen, per_scale


def _consistent(X, nb, normals, chosen, power: float = 8.0):
    """Each normal again: the PCA of its chosen scale's neighbours, each weighted by
    ``|n_i . n_j| ** power`` (how well its own normal agrees)."""
    out = np.empty_like(normals)
    K = nb.shape[1]
    for s in range(0, len(X), 50_000):
        rows = nb[s:s + 50_000]
        P = X[rows] - X[rows[:, :1]]
        w = np.abs(np.einsum("nd,nkd->nk", normals[s:s + 50_000], normals[rows])) ** power
        w = w * (np.arange(K)[None, :] <= chosen[s:s + 50_000, None])
        c = np.einsum("nk,nkd->nd", w, P) / w.sum(axis=1, keepdims=True)
        Q = P - c[:, None]
        C = np.einsum("nk,nki,nkj->nij", w, Q, Q)
        out[s:s + 50_000] = np.linalg.eigh(C)[1][:, :, 0]
    return out


def own_sheet(P: np.ndarray, near: int = 8) -> np.ndarray:
    """(n, k) bool: which of each neighbourhood's points (``P``, (n, k, 3), the point itself
    first and its nearest after) lie on the point's own sheet, for a cloud without normals.

    The offsets along the PCA normal of the ``near`` nearest, sorted, jump by more than
    :data:`SHEET_GAP` local spacings (the mean distance to the 6 nearest)
    where a fold's facing sheet begins; the points beyond the jump from the point's own
    offset (0) are another sheet. Noise and a curve rise without such jumps. All are kept
    when fewer than 9 would be left (a quadric fit needs 6).

    The noise estimate of a bare cloud (:func:`pcgeom.denoise.estimate_noise`) fits each
    point's quadric to these only. Before (issue 39), the facing walls of a groove 1.5
    spacings wide (:func:`pcgeom.synthetic_folds.deep_folds`) read as noise of 0.31 spacings
    (16 neighbours; 0.94 with 32), the pleat 2 spacings wide 0.24, so that ``"auto"``
    flattened the walls together (the groove's map: 0.115 rad, 20% turned over; now 0.022,
    0.01%); now 0.000. On the shared surfaces, clean, the same to 0.006; with depth noise of
    0.25 / 0.5 / 1 spacing 0.00-0.014 / 0.002-0.030 / 0.02-0.07 less (face_human_choi the
    most: 0.186 -> 0.172, 0.349 -> 0.319, 0.605 -> 0.539)."""
    Q = P - P[:, :1]
    C = np.einsum("nki,nkj->nij", Q[:, :near] - Q[:, :near].mean(axis=1, keepdims=True),
                  Q[:, :near] - Q[:, :near].mean(axis=1, keepdims=True))
    normal = np.linalg.eigh(C)[1][..., 0]
    offset = np.einsum("nkd,nd->nk", Q, normal)
    local = np.linalg.norm(Q[:, 1:7], axis=-1).mean(axis=1, keepdims=True)
    order = np.argsort(offset, axis=1)
    ranked = np.take_along_axis(offset, order, axis=1)
    jump = np.diff(ranked, axis=1) > SHEET_GAP * local  # (n, k - 1): a jump after rank r
    # The sheet of rank r: how many jumps lie below it; the point's own is the rank of 0.
    sheet = np.concatenate([np.zeros((len(P), 1), dtype=np.int64),
                            np.cumsum(jump, axis=1)], axis=1)
    own_rank = np.argmax(order == 0, axis=1)
    same_ranked = sheet == sheet[np.arange(len(P)), own_rank][:, None]
    same = np.empty_like(same_ranked)
    np.put_along_axis(same, order, same_ranked, axis=1)
    few = same.sum(axis=1) < 9
    same[few] = True
    return same


def _one_sheet(P: np.ndarray, C6: np.ndarray, ks: np.ndarray) -> np.ndarray:
    """(n, S) bool: scale ``ks[j]``'s neighbourhood of each point (``P``, about the point, its
    nearest first) lies on one sheet, and so does every smaller scale's. Two-sheeted: its
    offsets along its PCA normal, sorted, jump by more than :data:`SHEET_GAP` local spacings
    with points on both sides."""
    n, S = C6.shape[:2]
    iu = np.triu_indices(3)
    C = np.empty((n, S, 3, 3))
    C[..., iu[0], iu[1]] = C6
    C[..., iu[1], iu[0]] = C6
    normal = np.linalg.eigh(C)[1][..., 0]  # (n, S, 3)
    local = np.linalg.norm(P[:, 1:7], axis=-1).mean(axis=1)  # (n,)
    one = np.ones((n, S), dtype=bool)
    for j, k in enumerate(ks):
        offset = np.sort(np.einsum("nkd,nd->nk", P[:, :k + 1], normal[:, j]), axis=1)
        one[:, j] = np.diff(offset, axis=1).max(axis=1) <= SHEET_GAP * local
    return np.logical_and.accumulate(one, axis=1)


def _smallest_eigenvalue(C6: np.ndarray) -> np.ndarray:
    """The smallest eigenvalue of symmetric 3 x 3 matrices given by their upper triangles
    ``(..., 6)`` (xx, xy, xz, yy, yz, zz), in closed form (the trigonometric solution of the
    characteristic cubic; Smith 1961)."""
    a, b, c, d, e, f = np.moveaxis(C6, -1, 0)
    q = (a + d + f) / 3.0
    p1 = b * b + c * c + e * e
    p2 = (a - q) ** 2 + (d - q) ** 2 + (f - q) ** 2 + 2.0 * p1
    p = np.sqrt(np.maximum(p2 / 6.0, 0.0))
    safe = np.where(p > 0, p, 1.0)
    # det((C - q I) / p) / 2, clipped to the cosine's range against rounding.
    A, D, Fz = (a - q) / safe, (d - q) / safe, (f - q) / safe
    B, Cz, E = b / safe, c / safe, e / safe
    r = 0.5 * (A * (D * Fz - E * E) - B * (B * Fz - E * Cz) + Cz * (B * E - D * Cz))
    phi = np.arccos(np.clip(r, -1.0, 1.0)) / 3.0
    smallest = q + 2.0 * p * np.cos(phi + 2.0 * np.pi / 3.0)
    return np.where(p > 0, smallest, q)


def surface_variation(values: np.ndarray) -> np.ndarray:
    """``lambda_0 / (lambda_0 + lambda_1 + lambda_2)`` from :func:`local_pca`'s eigenvalues
    (Pauly et al. 2002): 0 on a plane, about 0.3 (up to 1/3) inside a volume."""
    return values[:, 0] / np.maximum(values.sum(axis=1), 1e-300)


VOTE_NEIGHBOURS = 16
"""Neighbours each point's planes are voted by (:func:`voted_normals`)."""

VOTE_PAIRS = 8
"""The planes tried: through the point and two of its this many nearest neighbours."""

VOTE_BAND = 0.2
"""A neighbour votes for a plane through the point when it lies within this many local
spacings (the mean distance to the 6 nearest) of it."""

VOTE_MARGIN = 4
"""Votes the best plane must have over the given normal's plane to replace it."""

VOTE_WEDGE = 1.05 * np.pi
"""... and the widest angle between consecutive voters around the point, in the plane: the
point lies among its voters, not at their end (a lip's point whose plane is the wall's below
it)."""


def voted_normals(X, normals, *, knn: Neighbours | None = None, chunk: int = 50_000
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Each point's normal again where one plane through it holds clearly more of its
    neighbours than the plane of ``normals`` does: at a groove's wall a spacing or two from
    the facing one, the PCA plane of a neighbourhood stands between both walls, while the
    plane of the point's own wall holds all its points (a RANSAC-style vote).

    The planes tried pass through the point and two of its :data:`VOTE_PAIRS` nearest
    neighbours; each of its :data:`VOTE_NEIGHBOURS` nearest within :data:`VOTE_BAND` local
    spacings of a plane votes for it. The plane with the most votes is fitted again (PCA of
    the point and its voters) and replaces the normal when it has :data:`VOTE_MARGIN` votes
    more than the given normal's plane through the point, its voters surround the point
    (:data:`VOTE_WEDGE`) and the neighbourhood has a facing sheet along it (its offsets along
    the new normal, sorted, jump by more than :data:`SHEET_GAP` local spacings: without that
    test the vote also turned face_human_choi's normals where one sheet curves, 630 by more
    than 30 degrees, not 429). The new normal keeps the old one's side. Measured on
    :func:`pcgeom.synthetic_folds.deep_folds` (6000 points, walls 1.5 spacings apart, given
    the adaptive PCA's normals): normals over 30 degrees off on the walls 67 -> 17, at the
    bottoms 47 -> 47, at the lips 10 -> 14, over the sheet 125 -> 79; the local mesh's own
    vertex normals then mend the bottoms (:func:`pcgeom.maps.free._voted`).

    Parameters
    ----------
    X : (N, 3) array_like
        Distinct points.
    normals : (N, 3) array_like
        Their unit normals (any side).
    knn : Neighbours, optional
        The points' nearest points, when already found.
    chunk : int
        Points per block.

    Returns
    -------
    normals : (N, 3) float64
        Unit normals.
    moved : (N,) bool
        Where the vote replaced the normal.
    """
    X = np.asarray(X, dtype=np.float64)
    given = np.asarray(normals, dtype=np.float64)
    k = min(VOTE_NEIGHBOURS, len(X) - 1)
    m = min(VOTE_PAIRS, k)
    nb = (knn if knn is not None else Neighbours.of(X, k)).first(k)[1]
    out, moved = given.copy(), np.zeros(len(X), dtype=bool)
    a, b = np.triu_indices(m, 1)
    for s in range(0, len(X), chunk):
        rows = np.arange(s, min(s + chunk, len(X)))
        P = X[nb[rows, 1:]] - X[rows, None, :]  # (n, k, 3) about the point
        local = np.maximum(np.linalg.norm(P[:, :6], axis=-1).mean(axis=1), 1e-300)
        band = VOTE_BAND * local[:, None]
        before = (np.abs(np.einsum("nd,nkd->nk", given[rows], P)) < band).sum(axis=1)
        # Only a point whose plane leaves out VOTE_MARGIN neighbours or more can be outvoted.
        open_ = before + VOTE_MARGIN <= k
        rows, P, local, band, before = (rows[open_], P[open_], local[open_], band[open_],
                                        before[open_])
        best = _best_planes(P, band, a, b)[0]  # the best plane's voters
        Q = np.concatenate([np.zeros((len(P), 1, 3)), P], axis=1)
        W = np.concatenate([np.ones((len(P), 1)), best], axis=1)[..., None]
        R = Q - (W * Q).sum(axis=1, keepdims=True) / W.sum(axis=1, keepdims=True)
        n = np.linalg.eigh(np.einsum("nki,nkj->nij", W * R, R))[1][..., 0]
        voters = np.abs(np.einsum("nd,nkd->nk", n, P)) < band
        offset = np.sort(np.einsum("nd,nkd->nk", n, P), axis=1)
        two = np.diff(offset, axis=1).max(axis=1, initial=0.0) > SHEET_GAP * local
        ok = (two & (voters.sum(axis=1) >= before + VOTE_MARGIN)
              & (_widest_wedge(P, n, voters) < VOTE_WEDGE))
        side = np.where(np.einsum("nd,nd->n", n, given[rows]) < 0, -1.0, 1.0)
        out[rows[ok]] = (n * side[:, None])[ok]
        moved[rows[ok]] = True
    return out, moved


def _best_planes(P: np.ndarray, band: np.ndarray, a: np.ndarray, b: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The plane through each point (the origin of its offsets ``P``, (n, k, 3)) and two of
    its neighbours (``P[:, a]``, ``P[:, b]``: the pairs tried) that the most neighbours lie
    within ``band`` ((n, 1)) of: its voters ((n, k) bool) and unit normal ((n, 3)). Pairs
    nearly in line with the point span no plane and are not tried."""
    N = np.cross(P[:, a], P[:, b])  # (n, pairs, 3): the planes through two neighbours
    length = np.linalg.norm(N, axis=-1)
    spread = length > 0.3 * np.linalg.norm(P[:, a], axis=-1) * np.linalg.norm(P[:, b], axis=-1)
    N = N / np.maximum(length, 1e-300)[..., None]
    near = np.abs(np.einsum("npd,nkd->npk", N, P)) < band[:, :, None]
    votes = np.where(spread, near.sum(axis=-1), -1)
    pick = np.argmax(votes, axis=1)
    rows = np.arange(len(P))
    return near[rows, pick], N[rows, pick]


def on_a_sheet(X: np.ndarray, rows: np.ndarray, nb: np.ndarray, scale: float) -> np.ndarray:
    """(len(rows),) bool: the points ``rows`` of ``X`` that lie amid a plane of their
    neighbours (``nb``, rows of :meth:`Neighbours.first`, itself first): a plane through the
    point and two of its :data:`VOTE_PAIRS` nearest holds :data:`SHEET_VOTES` of the others
    within :data:`VOTE_BAND` local spacings (the mean distance to its 6 nearest, at most
    ``scale``), and they lie all around it (the widest angle between consecutive ones, in
    the plane, under :data:`VOTE_WEDGE`).

    A point on a sheet passes whatever lies beside it; a stray a few spacings off a surface
    does not: the planes through it and the surface below hold a strip of the surface, all
    on one side of it (``scale``, the cloud's spacing, keeps the band of a stray among
    strays, whose own spacing is large, from holding them all)."""
    k = nb.shape[1] - 1
    m = min(VOTE_PAIRS, k)
    if len(rows) == 0 or m < 2:
        return np.zeros(len(rows), dtype=bool)
    a, b = np.triu_indices(m, 1)
    P = X[nb[rows, 1:]] - X[rows, None, :]
    local = np.minimum(np.linalg.norm(P[:, :6], axis=-1).mean(axis=1), scale)
    voters, n = _best_planes(P, VOTE_BAND * np.maximum(local, 1e-300)[:, None], a, b)
    return (voters.sum(axis=1) >= SHEET_VOTES) & (_widest_wedge(P, n, voters) < VOTE_WEDGE)


SHEET_VOTES = 6
"""Neighbours a plane through a point must hold for :func:`on_a_sheet` (of 16): a groove's
wall where the uniform sampling leaves the point more neighbours on the facing wall than on
its own holds 6 to 12."""


def _widest_wedge(P: np.ndarray, n: np.ndarray, voters: np.ndarray) -> np.ndarray:
    """(n,) the widest angle around each point between consecutive ``voters`` of ``P``
    (offsets, (n, k, 3)) seen in the plane of ``n``; 2 pi with fewer than two."""
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    e1 = np.cross(n, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(n, e1)
    angle = np.arctan2(np.einsum("nkd,nd->nk", P, e2), np.einsum("nkd,nd->nk", P, e1))
    count = voters.sum(axis=1)
    angle = np.sort(np.where(voters, angle, 4.0 * np.pi), axis=1)  # the others last
    first = angle[:, 0]
    last = np.take_along_axis(angle, np.maximum(count - 1, 0)[:, None], axis=1)[:, 0]
    steps = np.where(np.arange(1, angle.shape[1])[None, :] < count[:, None],
                     np.diff(angle, axis=1), 0.0)
    widest = np.maximum(steps.max(axis=1, initial=0.0), 2 * np.pi - (last - first))
    return np.where(count >= 2, widest, 2 * np.pi)
