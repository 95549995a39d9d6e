"""Bridges between sheets that nearly touch: triangles of the local mesh that join opposite
sides of a thin gap (not in the paper).

Where two sheets of a surface come within a spacing of each other (lips, nostrils, the walls
of a fold), the local mesh (:mod:`pcgeom.maps.localmesh`) can join them with triangles: each
such bridge adds a handle that the surface does not have, and LSCM over a mesh with a handle
spreads its error over the whole map. The oriented normals say which side each point is on.

**The rule.** A triangle is a bridge candidate when two of its corners' normals point opposite
ways (``n_a . n_b < 0``): a triangle of one sheet, at the spacing the mesh is built at, turns
by less than a right angle between its corners (or one of its corners' estimated normals is
turned over). The candidates are cut only when the repaired local mesh
(:func:`pcgeom.maps.topology.repair`) has handles (genus > 0) and the mesh repaired without
them has fewer: a handle the cloud's boundary does not explain is a bridge.

**Off in runs** (``local_mesh(..., bridges=True)`` asks for it): measured side by side
(``fast``, angle and flips on the true triangles, 2026-12-05; the tables:
benchmarks/bench_bridges.py in BENCHMARKS.md), it does not mend the lips sheet and is not
safe everywhere:

- In every build (bare clouds too, the normal rounds' meshes included): lips_sheet(11000,
  gap=0.75) with its normals 0.0869 rad, 4.55% flipped -> 0.0741, 4.32% (93 triangles cut,
  genus 2 -> 0), bare 0.148, 10.9% -> 0.127, 11.9%; face_human_choi bare 0.0333, 2.49% ->
  0.0324, 2.36% (genus 8 -> 2); but the pleats (bare; their repaired meshes in the normal
  rounds have genus 3, 2, 4, 0) 0.026, 0.34% -> 0.068, 0.73%: their half-circle folds, 0.75
  spacings in radius, turn by more than a right angle within a triangle, and the round whose
  cut mesh turns over fewest of its own triangles is kept.
- With given normals only: the lips sheet at eight samplings (3k-11k points) better at four,
  worse at three (8000 points, seed 1: 0.099 rad, 4.0% -> 0.122, 8.8%).

What limits the lips sheet is not bridges alone: its edges are right-angle creases, across
which true normals have ``n_i . n_j = 0`` and the fans (same-sheet neighbours: ``> 0``) join
neither side, so its folds hang from the flat only where they taper off, while the flats
either side of the slit (same normals, 0.75 spacings apart) are bridged; bare, the two walls'
PCA normals are oriented the same way and the fans mix them. Cutting every true bridge (the
truth known) took the sheet with normals from 0.087 to 0.201 rad at 11k points and from
0.129 to 0.299 at 5k (the folds come off: 852 -> 1951 points unmeshed), bare from 0.148 to
0.194 at 11k; the rule's cut unmeshes points too (3k with normals: 99 -> 578).

Rules measured and not kept (one run each, every build): a threshold of 0.3 instead of 0
(face_human_choi bare 0.033 -> 0.037 rad); cutting triangles whose edges leave the tangent
plane (component along the normals over 0.7 or 0.8: pleats 0.026 -> 0.038, lips with
normals 0.087 -> 0.131); triangles over a cloud point close under them (lips bare 0.148 ->
0.135 rad but 10.9 -> 11.3% flipped, pleats 0.026 -> 0.046); edges with opposite normals
whose ends are more than 2-3 times further apart on the mesh without them (few cut, no
change); fans that drop neighbours whose offset is steep to the normal (lips with normals
0.087 -> 0.131 at slope 1); fans that take neighbours up to ``n_i . n_j > -0.1`` (to cross the
creases: lips with normals 0.087 -> 0.195, pleats 0.026 -> 0.079); orienting bare normals
by patches of parallel tangent neighbours and votes between patches (lips 10.9 -> 7.1%
flipped but 0.148 -> 0.162 rad, pleats 0.026 -> 0.034). The nearest to a lead: fans that
also take neighbours across a crease (``n_i . n_j > -0.2`` and height off the tangent plane
under half the tangential distance, triangles whose other two corners face away dropped)
with triangles cut whose edge passes next to a point whose normal differs from both ends'
(``dot < 0.5``, within half the edge's length of its midpoint): lips 11k with normals 0.087
rad, 4.55% -> 0.099, 2.83% (unmeshed 687 -> 100, genus 2 -> 6), bare 0.148, 10.8% -> 0.120,
11.6%. What is left then with normals: 625 of its 772 bridging edges join the flats where
the folds taper off (their walls 0.1-0.5 spacings apart, the fold narrower than the
sampling): no rule on normals or distances at the spacing sees that fold.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .topology import Topology

__all__ = ["bridge_candidates", "cut_bridges", "OPPOSITE"]

OPPOSITE = 0.0
"""Two corners of a triangle whose normals' dot product is below this lie on opposite sheets.
Measured with the cut gated on the unrepaired mesh's genus: at 0.3 it took 768 of
face_human_choi's bare triangles and its free map went from 0.033 to 0.037 rad; at -0.5 it
cut none of them, and 24 of the lips sheet's (11k, with its normals: 0.0838 rad, 4.51%
flipped, against 0.0741 and 4.32% at 0)."""


def bridge_candidates(normals: np.ndarray, faces: np.ndarray,
                      opposite: float = OPPOSITE) -> np.ndarray:
    """Which triangles join points on opposite sheets: two of their corners' normals have a
    dot product below ``opposite``.

    Parameters
    ----------
    normals : (N, 3) float64
        Unit normals, consistently oriented.
    faces : (M, 3) int64
    opposite : float

    Returns
    -------
    (M,) bool
    """
    normals = np.asarray(normals, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    dots = [np.einsum("md,md->m", normals[F[:, a]], normals[F[:, b]])
            for a, b in ((0, 1), (1, 2), (2, 0))]
    return np.min(dots, axis=0, initial=np.inf) < opposite if len(F) else np.zeros(0, bool)


def cut_bridges(X: np.ndarray, normals: np.ndarray, faces: np.ndarray, repair, *,
                opposite: float = OPPOSITE, **where) -> tuple[np.ndarray, Topology]:
    """The local mesh repaired (``repair``, :func:`pcgeom.maps.topology.repair`), less its
    bridges between sheets when cutting them lowers the repaired mesh's genus (the module's
    rule).

    Parameters
    ----------
    X : (N, 3) float64
        The points.
    normals : (N, 3) float64
        Unit normals, consistently oriented (the ones the mesh was built from).
    faces : (M, 3) int64
        The local mesh: edge-manifold, consistently oriented.
    repair : callable
        ``repair(X, normals, faces, **where) -> (faces, Topology)``.
    opposite : float
        :data:`OPPOSITE`.
    **where
        Passed on to ``repair`` (``exclude``, ``spacing``).

    Returns
    -------
    faces : (M', 3) int64
        The repaired mesh, bridges cut or not.
    Topology
        Its topology; ``bridges_cut``: the triangles cut (0: none).
    """
    import dataclasses

    from .topology import measure

    faces = np.asarray(faces, dtype=np.int64)
    repaired, topology = repair(X, normals, faces, **where)
    if topology.genus <= 0:
        return repaired, topology
    bridge = bridge_candidates(normals, faces, opposite)
    # The cheap test first: the cut must lower the genus before the repair too.
    if not bridge.any() or measure(faces[~bridge])["genus"] >= measure(faces)["genus"]:
        return repaired, topology
    cut, cut_topology = repair(X, normals, faces[~bridge], **where)
    if cut_topology.genus >= topology.genus:
        return repaired, topology
    return cut, dataclasses.replace(cut_topology, bridges_cut=int(bridge.sum()))
