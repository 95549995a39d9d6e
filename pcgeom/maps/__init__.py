"""The mapping methods, one module for each map they make, and :func:`parametrize`, which
chooses among them (:func:`pcgeom.maps.run.choose_map`).

=====================  ==============================================================
module                 what it makes
=====================  ==============================================================
:mod:`.localmesh`      the local mesh of a cloud (same-sheet tangent fans, merged into
                       a manifold); :func:`mesh_cloud`: outliers, surface test,
                       normals, mesh
:mod:`.uvmesh`         the local mesh built again from its free map (a Delaunay
                       triangulation in the map's plane, kept where it is the surface's)
:mod:`.normals`        normals of a bare cloud (PCA, oriented by propagation)
:mod:`.free`           the free-boundary conformal map (LSCM of the local mesh), the
                       conformal factor; :func:`free_map`
:mod:`.disk`           the conformal disk map (free map, then the Riemann map of its
                       planar region); :func:`disk_map`
:mod:`.riemann`        the conformal map onto a domain without holes: the disk map
                       composed with the domain's inverse Riemann map
                       (:func:`riemann_onto`)
:mod:`.domain`         the map onto any other bounded domain: :func:`domain_map` (the
                       Riemann composition; onto a domain with holes or with
                       landmarks the barrier map, :func:`injective_onto`,
                       :func:`landmarks_onto`, the disk included; with
                       ``domain_method="harmonic"`` a disk with landmarks turned by
                       :func:`align_onto` and refined; :func:`harmonic_onto`, the
                       layout with holes on holes)
:mod:`.injective`      the barrier map: a bijection of the local mesh onto a domain
                       that never turns a triangle over (:func:`injective_map`)
:mod:`.networks`       the paper's two sine networks trained stage by stage
                       (Algorithm 1)
:mod:`.sphere`         the map of a closed genus-0 cloud onto the sphere (the closed
                       local mesh's spherical conformal map); :func:`sphere_map`
:mod:`.refine`         the per-point refinement (LEG on local pairs, HAND, landmarks)
:mod:`.run`            :func:`parametrize`, :func:`choose_map`, :data:`MAPS`
=====================  ==============================================================
"""

from .disk import conformal_disk, disk_map
from .domain import align_onto, domain_map, harmonic_onto
from .free import conformal_factor, free_map, lscm_free
from .localmesh import LocalMesh, local_mesh, mesh_cloud
from .normals import estimate_normals, orient_normals
from .riemann import riemann_onto
from .run import MAPS, choose_map, parametrize
from .sphere import sphere_map, spherical_conformal

__all__ = [
    "parametrize", "choose_map", "MAPS",
    "LocalMesh", "local_mesh", "mesh_cloud", "estimate_normals", "orient_normals",
    "lscm_free", "conformal_factor", "free_map",
    "conformal_disk", "disk_map",
    "harmonic_onto", "align_onto", "domain_map", "riemann_onto",
    "spherical_conformal", "sphere_map",
]
