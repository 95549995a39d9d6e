"""Small false loops held open at a pinched vertex, closed by taking off the vertex's smaller
fan (not in the paper; step 2c of :mod:`pcgeom.maps.topology`).

After the fills and the re-meshes (:mod:`pcgeom.maps.fills`), the small false loops of an
open local mesh that are left nearly all pass through a pinched vertex: a vertex with two
fans, one of which (often one to three triangles, a flap) lies over the hole or at its
edge. Every fill of the loop as it is folds or needs an edge the flap has, so the loop stays.
Here each fan of such a vertex but its largest is taken off in turn; the loops the mesh has
then round the fan's points (the false loop merged with the flap's outline) get the fill
pass's flat fills (:func:`pcgeom.maps.topology.fill_loop`, over their points and the points
the fan alone held), and the change is kept only when every such loop is closed, every
point the fan held is in a fill, and each fill is flat (each triangle within
:data:`pcgeom.maps.fills.REFILL_TURN` of each corner's normal) and no wider than the bound
(the widest empty circle the sampling leaves, times :data:`PINCH_WIDTH`), nor leaves an
empty circle wider, nor do the mesh's triangles round it (a hole of the surface that the
fans' long triangles span but for a small loop at its edge). A flap whose removal does not
lead to such a fill stays: nothing changes where no loop closes.

Measured side by side (``fast``, mend off / on, one run each, 2026-12-06; angle and flips on
the true triangles; the repaired mesh's loops as the run's record gives them):

- loops: face_human_choi 39 / 37 bare, 26 / 22 with its mesh's normals (true 1);
  peaks_three_cgal 4 / 4, 7 / 6 (true 1); the pleats 26 / 22; the lips sheet (11k) with its
  normals 31 / 25; peaks_7holes_choi 8 / 8 and face_3holes_small_choi 4 / 4 (their true
  loops); 9 holed sheets (holes of 1-5 spacings, uniform, grid and scan, seeds 2-4) the
  same holes and loops.
- maps: the four shared open surfaces free (bare, normals) and disk within 1e-5 rad and the
  same flips (face_human_choi's disk 0.03406 / 0.03407, peaks_three_cgal with normals
  0.04049 / 0.04039); the pleats 0.01543 / 0.01550 free, 0.02428 / 0.02435 disk, the same
  flips (of the 41 triangles the mends of a run took off 7 are true ones, of the 41 they
  added 12); the lips sheet (11k) with normals 0.0298 / 0.0275 rad, 170 / 163 flipped, bare
  0.0806 / 0.0798, 986 / 983 (loops 53 / 44). (Before the outlier rule of 2026-12-06 the
  bare lips read 0.0739 / 0.0860: their normal rounds stopped after the second, 258 then 274
  own flips against 281 then 273; at 11k seeds 1-2, 5k and 8k as good or better, 0.0827 /
  0.0767, 0.0662 / 0.0639, 0.0779 / 0.0779, 0.0712 / 0.0712 rad.)

The mend's CPU seconds in a bare free run (its 11-20 repairs, one round): the pleats 0.44 of
4.3 s, the lips sheet 0.34 of 4.8 s, face_human_choi 0.36 of 6.0 s (two rounds 0.48, 0.47,
0.46).

Without the empty-circle test on the triangles round a fill, peaks_7holes_choi lost a true
hole (its last loop of three points, 0.68 spacings wide, beside triangles 1.23 wide against
the limit of 1.09); with loops up to 2.5 bound circles tried (the fill pass's), a scan
holed sheet lost a hole of 2 spacings (its loop 0.89 circles long).
"""

from __future__ import annotations

import numpy as np

from ..mesh import fan_counts, half_edges as _directed, twins
from .topology_batch import (CloudTree, Corners, FillMemo, cut_at_repeats, isin, setdiff,
                             unmeshed)

__all__ = ["mend_pinches"]

PINCH_RINGS = 1
"""Rings of triangles round the fan's triangles' ring in which the loops it opens must lie
(measured on face_human_choi: 2 or 3 rings close no more loops, at up to twice the time)."""

PINCH_ROUNDS = 1
"""Rounds of the mend (a round's regions are disjoint; one next to a region mended in the
round waits for the next, as do the pinches within two rings of a change). Measured: a
second round closed one loop more on the lips sheet with its normals (25 -> 24) and none
elsewhere (the shared surfaces, the pleats), at up to 1.4x the mend's CPU time."""

PINCH_WIDTH = 0.75
"""A fill is kept when no triangle of it is wider, nor leaves a wider empty circle, than this
times the bound, and no triangle of the mesh at its points leaves a wider empty circle (as
:data:`pcgeom.maps.fills.REFILL_WIDTH`). The mends kept: up to 1.41 spacings on
face_human_choi (limit 2.24), 1.11 on peaks_three_cgal (1.14)."""

PINCH_LOOP = 0.8
"""Pinched vertices on boundary loops no longer than a circle of this many times the bound's
radius (in local spacings), or of :data:`pcgeom.maps.fills.REFILL_SHORT` spacings, are tried
(the re-mesh's small loops, :data:`pcgeom.maps.fills.REFILL_LOOP`)."""


def mend_pinches(X: np.ndarray, normals: np.ndarray, faces: np.ndarray, h: np.ndarray,
                 bound: float, exclude: np.ndarray | None = None, *, cloud=None,
                 twins_of=twins, memo: FillMemo | None = None, fans_of=fan_counts
                 ) -> tuple[np.ndarray, int]:
    """The open mesh ``faces`` with the small loops held open at pinched vertices closed
    (the module's rule), and how many fans were taken off for a fill.

    Parameters
    ----------
    X, normals : (N, 3) float64
        The points and their oriented unit normals.
    faces : (M, 3) int64
        The mesh: edge-manifold, consistently oriented.
    h : (N,) float64
        Each point's local spacing.
    bound : float
        The widest triangle (enclosing radius in local spacings) the sampling leaves.
    exclude : (N,) bool, optional
        Points no fill may use.
    cloud : pcgeom.maps.topology_batch.CloudTree, optional
        The points not excluded (``X[~exclude]``) and their k-d tree, built when first needed
        and shared with the caller's other steps (the repair's own).
    twins_of : callable
        :func:`pcgeom.mesh.twins`, or one that knows those of faces it has seen
        (:class:`pcgeom.maps.topology_batch.KnownTwins`).
    memo : pcgeom.maps.topology_batch.FillMemo, optional
        The fills' figures that earlier repairs of the cloud found (bound to it); None: a
        memo of this call's own.
    fans_of : callable
        :func:`pcgeom.mesh.fan_counts`, or a KnownTwins' ``fans`` (found once per faces).
    """
    from .fills import REFILL_SHORT, _empty_radius, _flat, _least_cosine
    from .topology import enclosing_radius, fill_loop, rim_walks

    n = len(X)
    faces = np.asarray(faces, dtype=np.int64)
    mended = 0
    reach = max(PINCH_LOOP * bound, REFILL_SHORT)
    cloud = CloudTree(X, exclude) if cloud is None else cloud  # its tree built when first needed
    memo = FillMemo() if memo is None else memo

    again = None  # after a round: the points whose tries may go otherwise now
    for _ in range(PINCH_ROUNDS):
        if not len(faces):
            break
        m = len(faces)
        twin, consistent = twins_of(faces)
        if not consistent:
            break
        fans_at = np.zeros(n, dtype=np.int64)
        counted = fans_of(faces, twin)
        fans_at[:len(counted)] = counted
        rim, walks = rim_walks(faces, twin)
        short = np.zeros(n, dtype=bool)
        on_long = np.zeros(n, dtype=bool)  # on a loop that is not small
        for w in walks:
            loop = rim[w, 0]
            length = float(np.linalg.norm(X[rim[w, 1]] - X[loop], axis=1).sum())
            if length <= 2.0 * np.pi * reach * float(np.median(h[loop])):
                short[loop] = True
            else:
                on_long[loop] = True
        pick = short & (fans_at > 1)
        if again is not None:
            pick &= again
        tried = np.flatnonzero(pick)
        if not len(tried):
            break
        H = _directed(faces)
        corners = Corners(faces, n)  # (its radix sort; no sort of every half-edge)
        corner, cstart = corners.order, corners.start
        free, tree = unmeshed(X, faces, exclude)
        busy = np.zeros(m, dtype=bool)
        deferred = np.zeros(n, dtype=bool)
        gone, fills = [], []
        taken: set = set()  # the fills' directed edges this round

        tris_at = corners.triangles

        def has_half(keys: np.ndarray) -> np.ndarray:
            return corners.has_half(keys // n, keys % n)

        def attempt(v: int, T_off: np.ndarray):
            """Take the triangles ``T_off`` (a fan at ``v``) off: the fills of the loops
            round their points, or None."""
            pts = np.unique(faces[T_off])
            if on_long[pts].any():
                # The loops round the fan's points would take in that loop's rim: no small
                # loop to fill (the same answer as the walk of the patch, sooner).
                return None
            patch = tris_at(pts)
            for _ in range(PINCH_RINGS):
                patch = tris_at(np.unique(faces[patch]))
            if busy[patch].any():
                deferred[v] = True
                return None
            keep = setdiff(patch, T_off)
            if not len(keep):
                return None
            off_keys = set((H[np.concatenate([T_off + q * m for q in range(3)])] @ [n, 1]
                            ).tolist())
            P = faces[keep]
            prim, pwalks = rim_walks(P)
            at_pts = isin(prim, pts).any(axis=1)  # (each rim edge's, for all walks at once)
            back = prim[:, 1] * n + prim[:, 0]
            genuine = ~has_half(back) | isin(back, off_keys)
            found = []
            for w in pwalks:
                if not at_pts[w].any():
                    continue
                if not genuine[w].all():
                    return None  # the loop runs out of the patch: not a small one
                found.append(prim[w, 0])
            orphans = setdiff(pts, P)
            if exclude is not None:
                orphans = orphans[~np.asarray(exclude, dtype=bool)[orphans]]
            out = []
            for walk in found:
                for loop in cut_at_repeats(walk):
                    inner = orphans
                    if tree is not None:
                        centre = X[loop].mean(axis=0)
                        radius = float(np.linalg.norm(X[loop] - centre, axis=1).max())
                        near = free[np.asarray(tree.query_ball_point(centre, radius),
                                               dtype=np.int64)]
                        inner = np.union1d(inner, near)
                    E = np.sort(_directed(faces[setdiff(tris_at(loop), T_off)]), axis=1)
                    Ek = np.unique(E[:, 0] * n + E[:, 1])
                    key = ("pinch", loop.tobytes(), inner.tobytes(), Ek.tobytes(),
                           normals[loop].tobytes(), normals[inner].tobytes())
                    figures = memo.get(key, lambda: _figures(loop, inner, Ek))
                    G = figures[0]
                    if G is None or not _flat(figures[1]):
                        return None
                    if figures[2] is None:  # (its widths found once it is flat)
                        width = np.maximum(enclosing_radius(X, G),
                                           _empty_radius(X, G, cloud.tree)
                                           ) / np.maximum(h[G].mean(axis=1), 1e-300)
                        figures[2] = float(width.max())
                    if figures[2] > PINCH_WIDTH * bound:
                        return None
                    out.append(G)
            if not out:
                return None
            G = np.concatenate(out)
            if not isin(orphans, G).all():
                return None
            # No empty circle wider than the fills may be among the triangles round them:
            # a hole of the surface that the mesh's long triangles span but for this loop.
            R = faces[setdiff(tris_at(np.unique(G)), T_off)]
            if len(R):
                gap = _empty_radius(X, R, cloud.tree) / np.maximum(h[R].mean(axis=1), 1e-300)
                if float(gap.max()) > PINCH_WIDTH * bound:
                    return None
            D = _directed(G)
            keys = D[:, 0] * n + D[:, 1]
            clash = has_half(keys) & ~isin(keys, off_keys)
            if clash.any() or len(set(keys.tolist())) != len(keys) or not taken.isdisjoint(
                    keys.tolist()):
                return None
            return patch, G, keys

        def _figures(loop: np.ndarray, inner: np.ndarray, Ek: np.ndarray) -> list:
            """[the loop's fill (None: none), its least cosine to a corner's normal, its
            widest triangle or empty circle (None: not yet found)]."""
            G = fill_loop(X, normals, loop, inner, Ek)
            return [G, None if G is None else _least_cosine(X, normals, G), None]

        for v in tried.tolist():
            cs = corner[cstart[v]:cstart[v + 1]]
            label = _fans_at(cs, twin, m)
            labels, sizes = np.unique(label, return_counts=True)
            if len(labels) < 2:
                continue
            for lab in labels[np.argsort(-sizes, kind="stable")][1:].tolist():
                T_off = cs[label == lab] % m
                got = attempt(v, T_off)
                if got is None:
                    continue
                patch, G, keys = got
                busy[patch] = True
                gone.append(T_off)
                fills.append(G)
                taken.update(keys.tolist())
                mended += 1
                break
        if not fills:
            break
        drop = np.zeros(m, dtype=bool)
        drop[np.concatenate(gone)] = True
        # The next round tries the points a mend of this round kept from their try, and the
        # pinched points within two rings of a change (their loops may have changed).
        near = np.zeros(n, dtype=bool)
        near[np.concatenate([faces[drop].ravel(), *[G.ravel() for G in fills]])] = True
        for _ in range(2):
            near[faces[near[faces].any(axis=1)].ravel()] = True
        again = deferred | near
        faces = np.concatenate([faces[~drop], *fills])
    return faces, mended




def _fans_at(corners: np.ndarray, twin: np.ndarray, m: int) -> np.ndarray:
    """(k,) the fan of each of one vertex's corners ``corners`` (``slot * m + tri``), as
    labels: corners joined across the edges at the vertex (``twin``: the half-edges' twins;
    corner ``c`` leaves its vertex by half-edge ``c``, the next corner round the vertex is
    the one that half-edge's twin enters)."""
    k = len(corners)
    where = {c: i for i, c in enumerate(corners.tolist())}
    parent = list(range(k))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, c in enumerate(corners.tolist()):
        t = int(twin[c])
        if t < 0:
            continue
        j = where.get(((t // m + 1) % 3) * m + t % m)
        if j is not None:
            parent[root(i)] = root(j)
    return np.array([root(i) for i in range(k)], dtype=np.int64)
