"""The variables of a map: free vertices, and loop vertices sliding on their rings by arc
length (:class:`_Rings`, :class:`_Layout`); the region the rings bound."""

from __future__ import annotations

import math

import numpy as np

from ...mesh import shoelace


class _Rings:
    """Loops sliding on their rings: each vertex by its unwrapped arc length ``t``.

    A ring is followed through its points by a cubic Hermite curve whose tangent at a point is
    the direction from the point before to the point after (one-sided at a corner, a turn
    sharper than ``corner``): smooth between corners, so a sliding vertex meets no kink to
    park on (on the polyline itself an optimizer parks vertices at its points, where the
    step's first-order model breaks). On arcs sampled from circles the curve is closer to
    the circle than the polyline; on straight sides it is the side."""

    def __init__(self, loops: list[np.ndarray], rings: list[np.ndarray], U: np.ndarray,
                 t: list[np.ndarray] | None = None, corner: float = math.radians(20.0)):
        """Arc lengths ``t`` as given (unwrapped, increasing), else those of the nearest
        ring points to ``U``."""
        self.loops = loops
        self.rings, self.cum, self.length, self.t, self.ends = [], [], [], [], []
        for k, (loop, ring) in enumerate(zip(loops, rings)):
            if not np.allclose(ring[0], ring[-1]):
                ring = np.vstack([ring, ring[:1]])
            seg = np.linalg.norm(np.diff(ring, axis=0), axis=1)
            ring = ring[np.concatenate([[True], seg > 0])]
            ring[-1] = ring[0]
            cum = np.concatenate([[0.0], np.cumsum(seg[seg > 0])])
            L = float(cum[-1])
            self.rings.append(ring)
            self.cum.append(cum)
            self.length.append(L)
            self.ends.append(self._tangents(ring, corner))
            if t is not None:
                self.t.append(np.asarray(t[k], dtype=np.float64))
                continue
            s = self._project(ring, cum, U[loop])
            gaps = np.diff(np.concatenate([s, s[:1] + L])) % L
            if (gaps > 0).all() and abs(gaps.sum() - L) <= 1e-9 * L:
                self.t.append(s[0] + np.concatenate([[0.0], np.cumsum(gaps[:-1])]))
                continue
            # A start laid on the ring by interpolation (the conformal map's rim near a
            # corner) can swap a few neighbours: the longest run in order keeps its arc
            # lengths, the others are spread between them by their place in the loop.
            u = (s - s[0]) % L
            keep = _increasing(u)
            if len(keep) < 0.8 * len(loop):
                raise ValueError(f"loops[{k}]: its vertices are not in order along rings[{k}] "
                                 "(once around, in the ring's direction: outer ring "
                                 "counter-clockwise, holes clockwise)")
            at = np.concatenate([keep, [len(loop)]])
            self.t.append(s[0] + np.interp(np.arange(len(loop)), at,
                                           np.concatenate([u[keep], [L]])))

    @staticmethod
    def _tangents(ring: np.ndarray, corner: float) -> tuple[np.ndarray, np.ndarray]:
        """Unit tangents at the start and the end of each segment, (r, 2) each."""
        P = ring[:-1]
        e = np.diff(ring, axis=0)
        e = e / np.linalg.norm(e, axis=1, keepdims=True)  # segment i: P[i] -> P[i + 1]
        before = np.roll(e, 1, axis=0)  # the segment ending at P[i]
        turn = np.abs(np.arctan2(before[:, 0] * e[:, 1] - before[:, 1] * e[:, 0],
                                 (before * e).sum(axis=1)))
        mid = np.roll(P, -1, axis=0) - np.roll(P, 1, axis=0)
        mid = mid / np.maximum(np.linalg.norm(mid, axis=1, keepdims=True), 1e-300)
        sharp = (turn > corner)[:, None]
        start = np.where(sharp, e, mid)  # at P[i], leaving along segment i
        end = np.roll(np.where(sharp, before, mid), -1, axis=0)  # at P[i + 1], arriving
        return start, end

    @staticmethod
    def _project(ring, cum, P) -> np.ndarray:
        """Arc length of the nearest point of the closed polyline ``ring`` to each of ``P``."""
        a, ab = ring[:-1], np.diff(ring, axis=0)  # (r, 2) segments
        w = P @ ab.T - (a * ab).sum(axis=1)[None]
        s = np.clip(w / (ab ** 2).sum(axis=1)[None], 0.0, 1.0)  # (k, r)
        d = ((a[None] + s[..., None] * ab[None] - P[:, None]) ** 2).sum(axis=2)
        j = np.argmin(d, axis=1)
        return cum[j] + s[np.arange(len(P)), j] * (cum[j + 1] - cum[j])

    def positions(self, k: int, t: np.ndarray
                  ) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
        """Points at arc lengths ``t`` on ring ``k``, and their first and second
        derivatives in ``t``."""
        ring, cum = self.rings[k], self.cum[k]
        m0, m1 = self.ends[k]
        s = np.mod(t, self.length[k])
        j = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(cum) - 2)
        h = (cum[j + 1] - cum[j])[:, None]
        u = (s - cum[j])[:, None] / h
        p0, p1, a0, a1 = ring[j], ring[j + 1], h * m0[j], h * m1[j]
        u2, u3 = u * u, u * u * u
        P = ((2 * u3 - 3 * u2 + 1) * p0 + (u3 - 2 * u2 + u) * a0 + (3 * u2 - 2 * u3) * p1
             + (u3 - u2) * a1)
        dP = ((6 * u2 - 6 * u) * p0 + (3 * u2 - 4 * u + 1) * a0 + (6 * u - 6 * u2) * p1
              + (3 * u2 - 2 * u) * a1) / h
        d2P = ((12 * u - 6) * p0 + (6 * u - 4) * a0 + (6 - 12 * u) * p1
               + (6 * u - 2) * a1) / h ** 2
        return P, (dP, d2P)

    def in_order(self, k: int, t: np.ndarray) -> bool:
        """The loop's vertices strictly increase along the ring and stay within one turn."""
        return not len(t) or bool((np.diff(t) > 0).all() and t[-1] - t[0] < self.length[k])


class _Layout:
    """A map as a vector of variables: the ``free`` vertices by their coordinates, the
    vertices of ``rings``' loops by their arc lengths, the others held where ``U`` has them."""

    def __init__(self, U: np.ndarray, free: np.ndarray, rings: _Rings | None):
        self.U = U.copy()
        self.free = free
        self.rings = rings
        self.loops = rings.loops if rings is not None else []
        self.nf = 2 * len(free)
        self.z0 = np.concatenate([U[free].ravel()] + (rings.t if rings is not None else []))

    def unpack(self, z: np.ndarray) -> tuple[np.ndarray, list]:
        """The map ``(n, 2)`` and, for each loop, the first and second derivatives of its
        vertices in their arc lengths."""
        W = self.U.copy()
        W[self.free] = z[:self.nf].reshape(-1, 2)
        frames, at = [], self.nf
        for k, loop in enumerate(self.loops):
            W[loop], frame = self.rings.positions(k, z[at:at + len(loop)])
            frames.append(frame)
            at += len(loop)
        return W, frames

    def pull(self, gU: np.ndarray, frames: list) -> np.ndarray:
        """A gradient on the vertices ``(n, 2)`` as a gradient in the variables."""
        parts = [gU[self.free].ravel()]
        parts += [(gU[loop] * T).sum(axis=1) for loop, (T, _) in zip(self.loops, frames)]
        return np.concatenate(parts)

    def push(self, d: np.ndarray, frames: list) -> np.ndarray:
        """A step in the variables as a displacement of the vertices ``(n, 2)``: exact for
        the free vertices, to first order for the sliding ones."""
        D = np.zeros_like(self.U)
        D[self.free] = d[:self.nf].reshape(-1, 2)
        at = self.nf
        for loop, (T, _) in zip(self.loops, frames):
            D[loop] = d[at:at + len(loop), None] * T
            at += len(loop)
        return D

    def matrix(self, frames: list):
        """The sparse ``(2n, nz)`` derivative of the vertex coordinates in the variables."""
        import scipy.sparse as sp

        n = len(self.U)
        rows = [2 * self.free, 2 * self.free + 1]
        cols = [np.arange(0, self.nf, 2), np.arange(1, self.nf, 2)]
        vals = [np.ones(len(self.free)), np.ones(len(self.free))]
        at = self.nf
        for loop, (T, _) in zip(self.loops, frames):
            q = at + np.arange(len(loop))
            rows += [2 * loop, 2 * loop + 1]
            cols += [q, q]
            vals += [T[:, 0], T[:, 1]]
            at += len(loop)
        return sp.csr_matrix((np.concatenate(vals),
                              (np.concatenate(rows), np.concatenate(cols))),
                             shape=(2 * n, at))

    def curvature(self, gU: np.ndarray, frames: list) -> np.ndarray:
        """The term ``g . d2x/dt2`` each sliding variable adds to the Hessian's diagonal
        (the ring's bending), cut at zero; zero for the free variables."""
        out = [np.zeros(self.nf)]
        out += [np.maximum((gU[loop] * C).sum(axis=1), 0.0)
                for loop, (_, C) in zip(self.loops, frames)]
        return np.concatenate(out)

    def in_order(self, z: np.ndarray) -> bool:
        at = self.nf
        for k, loop in enumerate(self.loops):
            if not self.rings.in_order(k, z[at:at + len(loop)]):
                return False
            at += len(loop)
        return True


def _increasing(u: np.ndarray) -> np.ndarray:
    """Indices of a longest strictly increasing subsequence of ``u`` that starts at ``u[0]``
    (patience sorting)."""
    import bisect

    tails: list[float] = []
    tail_index: list[int] = []
    parent = np.full(len(u), -1)
    for i, x in enumerate(u.tolist()):
        if i and x <= u[0]:
            continue
        j = bisect.bisect_left(tails, x)
        if j == len(tails):
            tails.append(x)
            tail_index.append(i)
        else:
            tails[j] = x
            tail_index[j] = i
        parent[i] = tail_index[j - 1] if j else -1
    out = [tail_index[-1]]
    while parent[out[-1]] >= 0:
        out.append(int(parent[out[-1]]))
    return np.asarray(out[::-1])


def _region(rings: list[np.ndarray]):
    """The shapely polygon the rings bound: the ring of largest area outside, the rest
    holes."""
    import shapely

    areas = [abs(shoelace(r)) for r in rings]
    outer = int(np.argmax(areas))
    return shapely.Polygon(rings[outer], [r for k, r in enumerate(rings) if k != outer])
