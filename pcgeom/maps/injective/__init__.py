"""Maps of a triangle mesh onto a planar domain that never fold.

A map ``U`` of a mesh ``(V, F)`` onto a domain is a bijection when every triangle keeps its
orientation (positive signed area: the faces counter-clockwise) and each boundary loop of the
mesh runs once, in order, around the domain ring it is paired with (outer ring
counter-clockwise, holes clockwise): the degree of the map is then 1 inside the domain and 0
outside, so every point of the domain is covered by exactly one triangle.
:func:`injective_map` gets there from a start that may fold, such as
:func:`pcgeom.maps.domain.harmonic_onto`'s harmonic map, whose loops are laid on their rings:

1. **Clean** the mesh of what no flip-free planar map can hold (triangles are dropped, never
   points: a dropped triangle's vertices are mapped all the same): two fans meeting at a vertex
   (:func:`pcgeom.mesh.one_fan`), rim slivers (:func:`pcgeom.mesh.peel_rim`), handles
   (:func:`clean._cut_handles`). The
   local mesh of a bare cloud has all three: face_3holes_small_choi 43 vertices with two
   fans; face_human_choi with a hole, 10 handles where the estimated normals join the
   eyelids' or lips' sheets.
2. **Scaffold.** Each hole of the mesh paired with no ring is filled by a fan to a virtual
   vertex: with it every loop is bounded by triangles or a ring, so a free hole cannot fold
   over the rest of the map either (its fan must stay positive too).
3. **Untangle** (:func:`untangle`; Garanzha, Kaporin, Kudryavtseva, Protais, Ray, Sokolov,
   "Foldover-free maps in 50 lines of code", SIGGRAPH 2021). With the paired loops held on
   their rings, minimize over the other vertices

   ``E_eps(U) = sum_t A_t [(1 - theta) tr(J_t^T J_t) + theta (det(J_t)^2 + 1)] / chi(det J_t, eps)``

   with ``chi(D, eps) = (D + sqrt(eps^2 + D^2)) / 2``, a positive stand-in for ``det J``
   (``-> D`` as ``eps -> 0`` where ``D > 0``, ``eps^2 / (4 |D|)`` where ``D < 0``). ``J_t`` is
   the Jacobian from the triangle's reference shape (its 3D triangle laid flat, scaled so
   that the reference areas sum to the map's area) to its image, ``A_t`` the reference area.
   ``E_eps`` is smooth for ``eps > 0``; projected Newton (or the paper's L-BFGS) minimizes it,
   then ``eps`` decreases by the paper's rule until no triangle has ``det J <= 0``. A loop
   vertex no flip-free map can hold on its ring (a hole's ear: three consecutive vertices on
   a ring that bends away from the triangle) moves freely (:func:`_release`). When that does
   not unfold everything, the start is Tutte's embedding (:func:`tutte_fill`, flip-free by
   Tutte's theorem) with the loops pulled onto their rings under the barrier of step 4.
4. **Barrier.** From the flip-free map, lower the angle distortion with an energy that is
   infinite at zero area, ``sum_t A_t e(J_t)`` with ``s1 >= s2`` the singular values of
   ``J_t`` and ``K = s1/s2 + s2/s1 = tr(J^T J) / det J``:

   - ``"mips"`` (conformal AMIPS/MIPS): ``e = K``; 2 exactly for a similarity, its minimum;
   - ``"root_mips"`` (default): ``e = (K - 2 + delta^2)^p + b (K - 2)``, ``p = 1/2``,
     ``b = 0.1``: about ``|log(s1/s2)|``, the measure of the angles, for moderate
     distortion, still infinite at zero area;
   - ``"symmetric_dirichlet"``: ``e = s1^2 + s2^2 + s1^-2 + s2^-2``; 4 for an isometry.

   The vertices of the paired loops slide along their rings (each by its arc length, on a
   smooth curve through the ring's points, one-sided at its corners; a vertex is pinned on
   each corner: :class:`_Rings`), the others move freely. Projected Newton picks a direction
   (Teran et al. 2005: each triangle's Hessian with its negative eigenvalues cut); the step
   never crosses a zero area: per triangle ``det J(x + a d)`` is a quadratic in ``a``
   (Smith and Schaefer, "Bijective parameterization with free boundaries", SIGGRAPH 2015),
   the step starts below its smallest positive root over all triangles
   (:func:`max_feasible_step`) and backtracks until the energy decreases (Armijo), every
   triangle is positive and every loop is still in order along its ring. A term for the area
   of the domain the loops' polygons leave uncovered keeps the loop vertices from bunching
   (the energy is blind to where they sit on the ring). Every iterate, not only the last, is a
   bijection onto the region bounded by the loops' polygons inscribed in their rings.

Every iterate of step 4 is flip-free; the guarantee covers the cleaned mesh, whose loop
vertices are on their rings except the released ones (kept near the domain by a penalty,
not a barrier).

Measured (2 CPU cores, one thread), judged on the true triangles of the files, the mapped
surface's distance to the domain by :func:`pcgeom.metrics.surface_hausdorff`; the start (the
free map and :func:`pcgeom.maps.domain.harmonic_onto`) takes 2.7 s more:

=============================================  ========  =======  =======  ======
face_3holes_small_choi (5053 points, bare)     angle     flipped  surface  time
onto ``smile``
=============================================  ========  =======  =======  ======
harmonic start                                 0.296     4.35%    0.109
untangled (step 3 only)                        0.323     0.041%   0.018    3.6 s
``"root_mips"`` (default)                      0.054     0.031%   0.025    16 s
``"mips"``                                     0.152     0.010%   0.027    11 s
``"symmetric_dirichlet"``                      0.278     0.041%   0.026    6 s
=============================================  ========  =======  =======  ======

The local mesh itself never folds; the true triangles that do are the other diagonal of a
local-mesh quad the distortion made non-convex (``BarrierConfig.flip_guard`` keeps every
quad convex, at twice the time). face_human_choi with a hole cut around its nose (16k
points) onto ``annulus:0.3``, with the mesh's normals: harmonic 0.255 rad, 8.1%; this map
0.044 rad, 0.125% (flips where cleaning dropped triangles), 0.079 from the domain, 87 s.
The same bare cloud (10 handles in its local mesh) is not mapped: untangling leaves folds,
the pulled Tutte start leaves 129 loop vertices off their rings, 3.9% of the true triangles
fold, 250 s.

The package, one module per thing it makes, each importing only those before it:

==============  ===========================================================================
module          what it makes
==============  ===========================================================================
``jacobians``   reference triangles, Jacobians ``J_t``, folds (:func:`flipped`)
``energies``    the energies per triangle, gradients, projected Hessians; :func:`conformal_energy`
``rings``       the variables: free vertices, loop vertices sliding on their rings
``newton``      sparse Hessian assembly, projected Newton, L-BFGS directions
``linesearch``  :func:`max_feasible_step`; vertices moved where that folds nothing
``barrier``     step 4, the barrier descent
``untangle``    step 3, :func:`untangle`
``tutte``       :func:`tutte_fill`; the ``"pull"`` start
``clean``       handles cut, dropped triangles' vertices placed, the scaffold (steps 1-2)
``loops``       loops rebuilt on their rings, pinned at corners, released
``landmarks``   the landmark term's pairs
``map``         :func:`injective_map`, the steps in order
==============  ===========================================================================

The settings are :class:`pcgeom.config.InjectiveConfig` (with :class:`UntangleConfig`,
:class:`PullConfig`, :class:`BarrierConfig`), re-exported here.
"""

from __future__ import annotations

from ...config import (ENERGIES, STARTS, BarrierConfig, InjectiveConfig, PullConfig,
                       UntangleConfig)
from ...mesh import signed_areas
from .energies import conformal_energy
from .jacobians import flipped, reference_triangles
from .linesearch import max_feasible_step
from .map import injective_map
from .tutte import tutte_fill
from .untangle import untangle

__all__ = ["flipped", "signed_areas", "reference_triangles", "conformal_energy",
           "max_feasible_step", "untangle", "tutte_fill", "injective_map", "InjectiveConfig",
           "UntangleConfig", "PullConfig", "BarrierConfig", "ENERGIES", "STARTS"]
