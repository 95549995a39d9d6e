"""The mesh of a cut map (``--cut auto``) with its atlas: ``pcgeom reconstruct`` on a map
whose points' uv jump across seams.

A cut map is not remeshed: its uv are one-to-one only chart by chart, so a mesh of the unit
square lifted through them would stitch charts that are far apart on the surface. Its mesh is
the map's own (the cloud's repaired local mesh, over the fitted points of a denoised map),
each triangle's corners carrying their atlas position (``corner_uv``): a seam vertex is one
vertex in 3D with one texture coordinate per chart it touches, written as OBJ ``vt``
(:func:`pcgeom.apps.reconstruct.export.write_mesh`).
"""

from __future__ import annotations

import numpy as np

from .export import write_mesh

__all__ = ["atlas_mesh"]


def atlas_mesh(result, points: np.ndarray, out, *, texture=None
               ) -> tuple[np.ndarray, np.ndarray, dict]:
    """Write the mesh of the cut map ``result`` (a ``ParamResult`` with ``corner_uv``) over
    ``points`` (the cloud; the map's fitted points when it has them) to the ``.obj`` path
    ``out``, with ``texture`` when given.

    Returns
    -------
    V : (K, 3) float64
    F : (M, 3) int64
    report : dict
        ``n_vertices``, ``n_faces``, ``charts``, ``n_uv`` (distinct texture coordinates:
        more than ``n_vertices`` where seams split them), ``uv_inside`` (every one in
        ``[0, 1]^2``), ``unused_points`` (points on no triangle), ``source`` (``"atlas"``).
    """
    from ..texture import map_mesh

    fitted = result.fitted if result.fitted is not None else points
    mesh = map_mesh(fitted, result.uv, None, mesh_faces=result.mesh_faces)
    corner_uv = np.asarray(result.corner_uv, dtype=np.float64)
    write_mesh(out, mesh.vertices, mesh.faces, texture=texture, corner_uv=corner_uv)
    pairs = np.column_stack([np.asarray(mesh.faces).reshape(-1, 1), corner_uv.reshape(-1, 2)])
    report = {"source": "atlas", "n_vertices": int(len(mesh.vertices)),
              "n_faces": int(len(mesh.faces)),
              "charts": int(len(np.unique(result.chart))) if result.chart is not None else 1,
              "n_uv": int(len(np.unique(pairs, axis=0))),
              "uv_inside": bool(((corner_uv >= 0) & (corner_uv <= 1)).all()),
              "unused_points": mesh.unused}
    return mesh.vertices, mesh.faces, report
