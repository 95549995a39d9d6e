"""``pcgeom reconstruct``: a triangle mesh of a point cloud, remeshed in its free-boundary map."""

from __future__ import annotations

import json
import os
import sys
import warnings

from ..apps.boundary import detect_boundary, unkept_holes
from ..apps.reconstruct import (INTERPOLATIONS, SIZES, check_mesh_path, inlier_rows,
                                 reconstruct_on_domain,
                                 reconstruct_on_sphere, reconstruct_surface, require_gmsh,
                                 texture_paths, write_mesh)
from ..apps.texture import uv_scaling
from ..config import get_preset, with_denoise
from ..domains import get_domain
from ..errors import InputError
from ..maps import parametrize
from .boundary import add_hole_options, add_normals_option, read_cloud
from ._common import (EXIT_OK, add_cloud_and_map, add_denoise_option, add_output_options,
                      add_texture_option, distinct_paths, int_at_least, load_free_map,
                      print_noise, run_command, standalone_parser, texture_line)

__all__ = ["configure", "run", "main"]

NAME = "reconstruct"
HELP = "triangle mesh of a point cloud, remeshed in its map (free boundary or a domain)"
DESCRIPTION = ("Reconstruct a surface mesh from a point cloud: detect the boundary loops on its "
               "free-boundary map, mesh the region inside them with gmsh, and lift the new "
               "vertices to 3D by barycentric interpolation over the map's Delaunay triangles. "
               "With --domain, mesh that domain instead (the map must be onto it).")
EPILOG = """\
examples:
  pcgeom reconstruct scan.ply --target-vertices 5000 --out scan_mesh.ply
      maps the cloud first (free boundary, preset fast), then remeshes it
  pcgeom reconstruct scan.ply --map scan_uv.npz --target-vertices 5000 --out mesh.ply --json
      reuses a map written by 'pcgeom param scan.ply' (no --domain)
  pcgeom reconstruct scan.ply --map scan_uv.npz --size adaptive --out mesh.obj
      element size from the map's lambda (its file's lambda_inv); written as OBJ
  pcgeom reconstruct scan.ply --map scan_uv.npz --texture checker:12 --out mesh.obj
      also writes mesh.mtl and mesh_checker.png (12 x 12 squares over the map): open
      mesh.obj in MeshLab or Blender to see the map's distortion on the surface
  pcgeom reconstruct scan.ply --domain disk --target-vertices 2000 --out disk_mesh.ply
      maps the cloud onto the disk first (preset fast), then meshes the disk itself and lifts
      it (one boundary loop, the circle's); with --map, a map that 'pcgeom param scan.ply
      --domain disk' wrote
  pcgeom reconstruct statue.ply --domain sphere --target-vertices 3000 --out statue_mesh.ply
      a closed genus-0 cloud: maps it onto the sphere (preset fast), meshes the sphere and
      lifts it; the mesh is closed (watertight, consistently oriented, genus 0)
  pcgeom reconstruct statue.ply --map statue_uv.npz --size adaptive --out statue_mesh.ply
      reuses a map that 'pcgeom param statue.ply --domain sphere' wrote (the file says it is
      onto the sphere; --domain sphere may be given too)
  pcgeom reconstruct mug.ply --map mug_uv.npz --texture checker:12 --out mug.obj
      a cut map ('pcgeom param mug.ply --cut auto'): its own mesh with the atlas per corner
      (seam vertices split in uv, not in 3D), not remeshed; .obj only
  pcgeom reconstruct noisy_scan.ply --denoise auto --out mesh.ply
      fits the surface first when the scan is noisy (as by default): the mesh is lifted over
      the fitted points, not the noisy ones

With a map made of denoised points (pcgeom param --denoise, or auto on a noisy scan), the
mesh is lifted over the fitted points the map file keeps (the loops' points smoothed along
their loops: a rim point's fit is one-sided), and the distances below are to them.
Strays (points the map's local mesh leaves out, or that the outlier test flags for a map
without one) are never lifted: the mesh is made over the inliers only (--json: n_strays, and
max_offset_spacings, the farthest vertex from them in their median point spacing).
The mesh is edge-manifold, counter-clockwise in the map (so consistently oriented), with one
boundary loop per detected loop (per domain loop with --domain); every loop point of INPUT is
a mesh vertex (without --domain). With --domain and no --map, INPUT is mapped onto the
domain first (preset fast). The summary gives
the distances from the mesh vertices to INPUT (vertex-to-point) over its bounding-box
diagonal, the triangles' minimum angle and aspect ratio. Faces in INPUT are never used.
The format follows the extension of --out: .ply (binary) or .obj (text, trimesh's exporter).
Either carries the map as texture coordinates, one pair per vertex (OBJ vt, PLY texture_u
texture_v): the vertex's position in the map, uv = (p - uv_offset) / uv_scale, which fills
[0, 1] along the map's longer side and keeps its aspect (--json gives uv_offset and uv_scale).
On the sphere (--domain sphere, or a map file onto it) the sphere is meshed, each vertex is
located in the spherical triangulation of the map (the map's own mesh when the file has it and
it covers the sphere, else the convex hull of the unit vectors; one that overlaps is refused)
and lifted from the cloud by Phong tessellation of that triangle (--interpolation linear: the
flat triangle); the mesh is checked to be watertight, consistently oriented and of Euler
characteristic 2, and refused otherwise. It has no texture coordinates (the sphere has no
seamless planar ones): --texture is refused.
Needs gmsh (pip install 'gmsh>=4.11').
"""


def configure(p) -> None:
    """Add ``reconstruct``'s arguments to ``p``."""
    add_cloud_and_map(p)
    p.add_argument("--domain", metavar="SPEC",
                   help="mesh this bounded domain or the sphere (as in 'pcgeom param "
                        "--domain'; the map must be onto it) instead of the region inside the "
                        "detected loops; a map onto the sphere needs no --domain")
    add_hole_options(p)
    add_normals_option(p)
    p.add_argument("--size", choices=SIZES, default="uniform",
                   help="mesh size rule: uniform (default), or adaptive: size proportional to "
                        "lambda_inv^-1/2 of the map (finer where the map compresses the "
                        "surface)")
    p.add_argument("--interpolation", choices=INTERPOLATIONS, default="phong",
                   help="on the sphere: how a vertex is lifted inside the cloud's triangle, "
                        "curved by Phong tessellation (default) or flat (linear)")
    add_denoise_option(p)
    p.add_argument("--target-vertices", type=int_at_least(3), default=None, metavar="N",
                   help="about how many vertices the mesh gets (default: 5000; --domain "
                        "sphere: 3 per point of the cloud, at most 200000)")
    add_output_options(p, "MESH.ply|MESH.obj", "the mesh, as PLY or OBJ (by extension), with "
                       "the map as its texture coordinates", required=True)
    add_texture_option(p, "--out")
    p.set_defaults(run=run)


def run(args) -> int:
    """Run ``pcgeom reconstruct`` on parsed arguments; returns the exit status."""
    # Everything that can be wrong with the request is checked before any training.
    cloud = read_cloud(args)  # with its normals when mapped here, as 'pcgeom param' maps it
    points = cloud.points
    if args.denoise is not None and args.map is not None:
        raise InputError("--denoise: the map is read from --map; denoise when making it "
                         "(pcgeom param --denoise), or drop --map")
    config = with_denoise(get_preset("fast"), args.denoise)
    out = check_mesh_path(args.out, args.texture)
    extra = texture_paths(out, args.texture) if args.texture is not None else {}
    distinct_paths({"INPUT": args.input, "--map": args.map},
                   {"out": out, **{f"texture {k}": v for k, v in extra.items()}})
    domain = get_domain(args.domain) if args.domain is not None else None
    if domain is not None and not domain.bounded:
        domain = None  # --domain free: the free-boundary path
    if domain is not None and domain.closed and args.texture is not None:
        raise InputError(_NO_TEXTURE)
    require_gmsh()  # a missing gmsh fails here, before any training
    if args.map is not None:
        result = load_free_map(args, points, "surface reconstruction", domain=domain,
                               hint=" or --domain with the map's domain", closed_ok=True,
                               cut_ok=True)
        if result.corner_uv is not None:
            return _on_atlas(args, points, result, out)
        if result.domain is not None and result.domain.closed:
            domain = result.domain  # a map onto the sphere says so itself
            if args.texture is not None:
                raise InputError(_NO_TEXTURE)
    else:
        result = parametrize(cloud, domain if domain is not None else "free",
                             config=config, progress=not args.quiet)
    # A denoised map was made of the fitted points: the mesh is lifted over them.
    lifted = result.fitted if result.fitted is not None else points
    if domain is not None and domain.closed:
        return _on_sphere(args, lifted, result, out)
    # Strays are never lifted: the mesh is made over the inliers only (apps.reconstruct.lifting).
    rows = inlier_rows(lifted, result.mesh_faces)
    lifted, uv = lifted[rows], result.uv[rows]
    lambda_inv = result.lambda_inv[rows] if result.lambda_inv is not None else None
    if domain is not None:
        return _on_domain(args, (lifted, uv, lambda_inv), result, domain, out)
    loops = detect_boundary(uv, points=lifted, min_width=args.min_width,
                            cloud_spacing=args.cloud_spacing)
    if not loops.loops:
        raise InputError(f"{args.input}: its map has no boundary loop of {loops.min_loop} points "
                         f"or more ({len(loops.dropped)} smaller ones dropped); the "
                         "reconstruction would be empty")
    V, F, Q, report = reconstruct_surface(lifted, uv, loops, size=args.size,
                                          target_vertices=args.target_vertices or 5000,
                                          lambda_inv=lambda_inv, return_uv=True,
                                          smooth_rim=result.fitted is not None)
    report.update(_write(args, out, V, F, Q), n_strays=len(points) - len(rows))
    summary = _summary(args, points, result, out, report, n_loops_detected=len(loops.loops))
    return _print(args, points, report, summary,
                  _loops_line(report, f"{len(loops.loops)} detected"))


def _write(args, out, V, F, Q) -> dict:
    """Write the mesh with its texture coordinates (the vertices' map positions, scaled into
    the unit square) and the texture asked for; the summary's keys for them."""
    scaling = uv_scaling(Q)
    write_mesh(out, V, F, uv=scaling.apply(Q), texture=args.texture)
    files = None
    if args.texture is not None:
        files = {k: os.fspath(v) for k, v in texture_paths(out, args.texture).items()}
    return {**scaling.to_dict(),
            "texture": args.texture.spec if args.texture is not None else None,
            "texture_files": files}


def _summary(args, points, result, out, report: dict, **extra) -> dict:
    """The ``--json`` object of a reconstruction (``extra`` before the mesh report)."""
    return {
        "command": "reconstruct",
        "input": args.input,
        "map": args.map,
        "out": os.fspath(out),
        "n_points": len(points),
        **extra,
        **report,
        "mapped_seconds": None if args.map is not None else float(result.seconds),
        # the normals the map was made with: "input", "estimated" (a local-mesh map's), or
        # None where its history does not record them
        "normals": next((r for r in result.history if r.get("stage") != "denoise"),
                        {}).get("normals"),
        "denoise": result.denoise,
    }


def _on_domain(args, inliers, result, domain, out) -> int:
    """The mesh of the domain itself, lifted over the map's Delaunay triangles of the inliers
    (``(points, uv, lambda_inv)``); one warning line when the cloud has holes the domain has
    not (the mesh fills them)."""
    points, uv, lambda_inv = inliers
    holes, kept = unkept_holes(uv, domain, points=points, min_width=args.min_width,
                               cloud_spacing=args.cloud_spacing)
    if holes > kept:
        warnings.warn(f"{args.input}: the cloud has {holes} hole(s) and the domain "
                      f"{domain.label} {kept}: the mesh covers the whole domain and fills "
                      f"{holes - kept} of them; to keep them, reconstruct without --domain "
                      "(the free boundary)", UserWarning, stacklevel=2)
    V, F, Q, report = reconstruct_on_domain(points, uv, domain, size=args.size,
                                            target_vertices=args.target_vertices or 5000,
                                            lambda_inv=lambda_inv, return_uv=True)
    report.update(_write(args, out, V, F, Q), n_strays=len(result.uv) - len(points))
    summary = _summary(args, result.uv, result, out, report)
    return _print(args, result.uv, report, summary, _loops_line(
        report, f"{report['n_domain_loops']} in the domain {domain.label}"))


_NO_TEXTURE = ("--texture: a mesh of the sphere has no planar texture coordinates (the sphere "
               "has no seamless ones); drop --texture")


def _on_sphere(args, points, result, out) -> int:
    """The mesh of the sphere, lifted through the map's spherical triangulation; closed."""
    V, F, report = reconstruct_on_sphere(points, result.uv, faces=result.mesh_faces,
                                         size=args.size, target_vertices=args.target_vertices,
                                         lambda_inv=result.lambda_inv,
                                         interpolation=args.interpolation)
    write_mesh(out, V, F)
    summary = _summary(args, points, result, out, report)
    shape = (f"  closed: watertight {report['watertight']}, winding-consistent "
             f"{report['winding_consistent']}, Euler characteristic "
             f"{report['euler_characteristic']} (genus {report['genus']:g}); lifted over the "
             f"{report['triangulation']} of the sphere map, {report['interpolation']}")
    return _print(args, points, report, summary, shape, texture=False)


def _on_atlas(args, points, result, out) -> int:
    """A cut map (``--cut auto``): its own mesh, cut along the seams in uv only, with the
    atlas per corner (:func:`pcgeom.apps.reconstruct.atlas_mesh`); ``.obj`` only, not
    remeshed (no ``--target-vertices``, ``--size adaptive``)."""
    from ..apps.reconstruct import atlas_mesh

    if not str(out).lower().endswith(".obj"):
        raise InputError(f"{args.map}: is a cut map (--cut auto): its mesh carries the atlas "
                         "per corner; give an .obj path to --out")
    if args.target_vertices is not None or args.size != "uniform":
        raise InputError(f"{args.map}: is a cut map (--cut auto): its mesh is the map's own, "
                         "cut along the seams, not remeshed; drop --target-vertices and --size")
    V, F, report = atlas_mesh(result, points, out, texture=args.texture)
    files = None
    if args.texture is not None:
        files = {k: os.fspath(v) for k, v in texture_paths(out, args.texture).items()}
    report.update(texture=args.texture.spec if args.texture is not None else None,
                  texture_files=files)
    summary = _summary(args, points, result, out, report)
    if args.json:
        print(json.dumps(summary))
        return EXIT_OK
    print(f"{args.input}: {len(points)} points -> {report['n_vertices']} vertices, "
          f"{report['n_faces']} triangles -> {summary['out']}")
    print(f"  atlas: {report['charts']} chart(s), {report['n_uv']} texture coordinates "
          f"(seam vertices split in uv), every uv in [0, 1]: {report['uv_inside']}")
    print_noise(summary["denoise"])
    return EXIT_OK


def _loops_line(report: dict, loops: str) -> str:
    return (f"  boundary loops: {report['n_boundary_loops']} ({loops}), edge-manifold: "
            f"{report['edge_manifold']}, oriented: {report['oriented']}")


def _print(args, points, report: dict, summary: dict, shape: str, *,
           texture: bool = True) -> int:
    """The summary: JSON, or lines (``shape``: the mesh's loops or closedness; the texture
    line unless the mesh has none)."""
    if args.json:
        print(json.dumps(summary))
        return EXIT_OK
    print(f"{args.input}: {len(points)} points -> {report['n_vertices']} vertices, "
          f"{report['n_faces']} triangles -> {summary['out']}")
    print(shape)
    print(f"  vertex-to-cloud distance / diagonal: max {report['hausdorff_rel']:.4f}, "
          f"mean {report['mean_distance_rel']:.4f}")
    print(f"  triangles: min angle {report['min_angle_deg']:.1f} deg, "
          f"max aspect ratio {report['max_aspect_ratio']:.2f}")
    if texture:
        print(texture_line(report))
    print_noise(summary["denoise"])
    return EXIT_OK


def main(argv: list[str] | None = None) -> int:
    """``pcgeom reconstruct`` on its own: ``main(["scan.ply", "--out", "mesh.ply"])``."""
    return run_command(standalone_parser(sys.modules[__name__]), argv)
