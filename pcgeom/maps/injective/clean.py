"""Step 1 and 2: what no flip-free planar map can hold (handles) cut away, the dropped
triangles' vertices placed, and the free holes filled by fans (the scaffold)."""

from __future__ import annotations

import numpy as np

from ...mesh import boundary_loops, half_edges, main_faces, one_fan, signed_areas, unique_edges
from .tutte import tutte_fill


def _genus(F: np.ndarray) -> int:
    """Handles of the vertex-manifold, connected mesh ``F``: ``(2 - chi - b) / 2`` with
    ``chi = V - E + F`` and ``b`` its boundary loops."""
    edges = unique_edges(F)
    chi = len(np.unique(F)) - len(edges) + len(F)
    return (2 - chi - len(boundary_loops(F))) // 2


def _cut_handles(V: np.ndarray, F: np.ndarray, rounds: int = 30) -> tuple[np.ndarray, int]:
    """Drop triangles until the mesh has no handle: where the local mesh joins two sheets by
    a bridge (closed eyelids or lips without normals: face_human_choi's has 10 handles), no
    flip-free planar map exists. Tutte's embedding of the mesh with its holes filled (on a
    circle) folds where the handles are; those triangles and the ones around them go, and
    the mesh's largest part is kept, until no handle is left. Returns the faces kept and how
    many were dropped."""
    dropped = 0
    for _ in range(rounds):
        if _genus(F) <= 0:
            break
        outer = np.asarray(max(boundary_loops(F), key=lambda loop: np.linalg.norm(
            V[np.roll(loop, -1)] - V[loop], axis=1).sum()))
        step = np.linalg.norm(V[np.roll(outer, -1)] - V[outer], axis=1)
        angle = 2 * np.pi * np.concatenate([[0.0], np.cumsum(step)[:-1]]) / step.sum()
        U = tutte_fill(V, F, outer, np.column_stack([np.cos(angle), np.sin(angle)]))
        # A handle shows as folded triangles, or as a vertex its triangles wind around more
        # than once (angles summing above 2 pi, every triangle positive: on face_human_choi
        # with a hole, at the rim of small holes).
        bad = (signed_areas(U, F) <= 0) | (_angle_sums(U, F)[F] > 2.05 * np.pi).any(axis=1)
        if not bad.any():
            break
        near = np.zeros(int(F.max()) + 1, dtype=bool)
        near[F[bad].ravel()] = True
        drop = near[F].any(axis=1)  # the folded triangles and their neighbours
        before = len(F)
        F, _ = one_fan(main_faces(F[~drop]))
        F = main_faces(F)
        dropped += before - len(F)
    return F, dropped


def _angle_sums(U: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Sum of the unsigned angles of the triangles ``U[F]`` at each vertex, (n,)."""
    sums = np.zeros(len(U))
    for q in range(3):
        a = U[F[:, (q + 1) % 3]] - U[F[:, q]]
        b = U[F[:, (q + 2) % 3]] - U[F[:, q]]
        angle = np.arctan2(np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]), (a * b).sum(axis=1))
        sums += np.bincount(F[:, q], angle, minlength=len(U))
    return sums


def _scaffold(V: np.ndarray, F: np.ndarray, U: np.ndarray, paired: list[np.ndarray]
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fill each boundary loop of ``F`` that is not in ``paired`` with a fan to a new vertex
    at its centroid (in 3D and in the map). Returns the vertices, faces and map with the new
    vertices appended (rows ``len(V):``) and the fans after ``F``."""
    taken = set(np.concatenate(paired).tolist())
    points, faces, maps = [V], [F], [U]
    n = len(V)
    for loop in boundary_loops(F):
        if loop[0] in taken:
            continue
        loop = np.asarray(loop)
        c = n + len(points) - 1
        points.append(V[loop].mean(axis=0, keepdims=True))
        maps.append(U[loop].mean(axis=0, keepdims=True))
        # The loop runs along F's boundary edges (a -> b); the fan holds b -> a.
        faces.append(np.column_stack([np.roll(loop, -1), loop, np.full(len(loop), c)]))
    return np.vstack(points), np.vstack(faces), np.vstack(maps)


def _place_dropped(U: np.ndarray, F: np.ndarray, F_all: np.ndarray) -> np.ndarray:
    """Vertices of ``F_all`` on no triangle of ``F`` (the tips of dropped triangles) at the
    mean of their neighbours in ``F_all`` that are placed, repeated outwards."""
    placed = np.zeros(len(U), dtype=bool)
    placed[F.ravel()] = True
    edges = half_edges(F_all)
    edges = np.concatenate([edges, edges[:, ::-1]])
    U = U.copy()
    for _ in range(100):
        todo = np.flatnonzero(~placed & np.isin(np.arange(len(U)), F_all.ravel()))
        if not len(todo):
            break
        use = edges[np.isin(edges[:, 0], todo) & placed[edges[:, 1]]]
        if not len(use):
            break
        count = np.bincount(use[:, 0], minlength=len(U))
        for c in range(2):
            total = np.bincount(use[:, 0], U[use[:, 1], c], minlength=len(U))
            U[count > 0, c] = total[count > 0] / count[count > 0]
        placed |= count > 0
    return U
