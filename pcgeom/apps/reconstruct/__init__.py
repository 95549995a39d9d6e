"""Surface reconstruction from a map (the paper's section 8, remeshing): a free-boundary
map, meshed inside its detected loops (:func:`reconstruct_surface`), a map onto a bounded
domain, meshed on the domain itself (:func:`reconstruct_on_domain`), or a map onto the sphere,
the sphere meshed and lifted into a closed genus-0 mesh (:func:`reconstruct_on_sphere`,
:mod:`.sphere`).

1. Mesh the region of the map inside the detected loops (the outer loop minus the holes)
   with gmsh, every loop point a mesh vertex, so the mesh's boundary is the detected one
   (:mod:`.polygons`: the region as simple polygons, where loops touch or cross).
2. Size: uniform, or adaptive to ``lambda_inv``, corrected to a target vertex count
   (:mod:`.gmsh_mesh`).
3. Lift each new 2D vertex to 3D by barycentric interpolation over the triangles that
   boundary detection kept (:mod:`.lifting`, with the rule for vertices outside them).
4. Measure the mesh (:mod:`.report`) and write it as PLY or OBJ (:mod:`.export`);
   :mod:`.surface` chains the steps.

A cut map (``--cut auto``) is not remeshed: its own mesh is written with the atlas per corner
(:func:`atlas_mesh`).

Measured on face_3holes_small_choi (5053 points), its ``fast`` map, 5000 target vertices:
5060 vertices (uniform; 5128 adaptive), 4 boundary loops, edge-manifold, oriented; distance
of the vertices to the true mesh at most 0.46% of the bounding-box diagonal; minimum angle
22 degrees (24 adaptive); about a second.

Orientation: every triangle is counter-clockwise in the map, so the 3D mesh is consistently
oriented wherever the map is one-to-one (its normal is the one the map's orientation gives).
"""

from __future__ import annotations

from .atlas import atlas_mesh
from .export import MESH_FORMATS, check_mesh_path, texture_paths, write_mesh
from .gmsh_mesh import mesh_domain, mesh_region, require_gmsh
from .lifting import inlier_rows, lift, map_delaunay
from .report import mesh_report
from .sphere import (INTERPOLATIONS, closed_checks, lift_sphere, mesh_sphere,
                     reconstruct_on_sphere, sphere_compression, sphere_triangulation)
from .surface import SIZES, reconstruct_on_domain, reconstruct_surface

__all__ = ["atlas_mesh", "reconstruct_surface", "reconstruct_on_domain", "reconstruct_on_sphere",
           "lift",
           "inlier_rows",
           "lift_sphere", "mesh_region", "mesh_domain", "mesh_sphere", "map_delaunay",
           "sphere_triangulation", "sphere_compression", "closed_checks", "mesh_report", "SIZES",
           "INTERPOLATIONS",
           "require_gmsh", "MESH_FORMATS", "check_mesh_path", "texture_paths", "write_mesh"]
