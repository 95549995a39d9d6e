"""``pcgeom param``: map a 3D point cloud onto a 2D domain.

Every input is checked before any training starts (file readable and valid, output paths
writable with the right extension, domain/preset/device known). A bad input prints one line,
``pcgeom: error: <message>``, on stderr and exits with status 2, leaving no output file.
"""

from __future__ import annotations

import argparse
import json
import os
import warnings
from pathlib import Path

import numpy as np
import torch

from ..apps.evaluate import map_report
from ..apps.reconstruct import check_mesh_path, texture_paths, write_mesh
from ..apps.texture import map_mesh, uv_scaling
from ..config import PRESETS, get_preset, with_denoise, with_landmark_weight
from ..domains import DOMAINS, PolygonDomain, get_domain
from ..errors import InputError
from ..examples import EXAMPLES, load_example
from ..io import PointCloud, check_writable, read_landmarks, read_points, write_ply_atomic
from ..maps import choose_map, parametrize
from ..maps.atlas import CUTS, MAX_STRETCH, check_cut
from ..train import LOSS_TERMS, resolve_device
from ._common import (EXIT_OK, add_denoise_option, add_output_options, add_texture_option,
                      distinct_paths,
                      flip_places, int_at_least, print_angles, print_domain_fit, print_noise,
                      run_command, seed, standalone_parser, texture_line)

__all__ = ["configure", "run", "main"]

NORMALS_CHOICES = ("auto", "ignore")
NO_NORMALS_NOTE = "a cloud without normals may fold where two sheets of its surface touch"

NAME = "param"
INTERRUPTED_HINT = " (rerun with --resume to continue from the last finished stage)"
HELP = "map a 3D point cloud onto a 2D domain"
DESCRIPTION = "Map a 3D point cloud sampled from an open surface onto a 2D domain."
EPILOG = """\
examples:
  pcgeom param --example peaks3 --out peaks3_uv.npz --plot peaks3_uv.png
      built-in three-peaks surface; also reports angle distortion against its mesh
  pcgeom param scan.ply --domain disk --out scan_uv.npz --out-ply scan_uv.ply
      map onto the unit disk; the PLY holds the mapped points (z = 0) and the input faces
  pcgeom param mesh.obj --out-mesh mesh_uv.obj --texture checker:12
      the input mesh with the map as its texture coordinates, and a 12 x 12 checkerboard
      material (mesh_uv.mtl, mesh_uv_checker.png) to see the map's distortion in MeshLab
      or Blender; a bare cloud gets its local mesh (the one the map was built on)
  pcgeom param face.ply --domain smile --plot face_uv.png
      onto the smiling face (unit disk minus two eyes and a mouth); see 'pcgeom domains'
  pcgeom param scan.xyz --preset paper --device auto --seed 3 --quiet --json
      the paper's full schedule (on a GPU when there is one: hours on a CPU); one JSON
      object on stdout for scripts
  pcgeom param scan.ply --domain disk --landmarks marks.json
      map onto the disk with landmark pairs (see README, "Landmark files")
  pcgeom param scan.las --normals ignore --json
      a LAS scan; ignore the file's normals (they are used when present: they keep the
      two sheets apart where the surface doubles back)
  pcgeom param noisy_scan.ply --denoise 4 --json
      fit the surface with a wider kernel than auto's before the map (the summary's
      "denoise" holds the estimated noise; the map file keeps the fitted points)
  pcgeom param scan.xyz --resume
      continue an interrupted run from scan_uv.ckpt (same input, preset and seed)
  pcgeom param statue.ply --domain sphere --out-ply statue_sphere.ply --plot statue_sphere.png
      a closed genus-0 cloud onto the unit sphere: the map file holds unit vectors (N, 3),
      the PLY the sphere points (with the input's faces, if any)

The map file loads with pcgeom.ParamResult.load(path); it records the domain, preset, seed
and pcgeom version. Faces in the input (PLY/OBJ/OFF/NPZ) are never used for training, only
to report the angle distortion of the result. The checkpoint <out stem>.ckpt is written
after each stage and removed after success.
"""


def configure(p: argparse.ArgumentParser) -> None:
    """Add ``param``'s arguments to ``p``."""
    p.add_argument("input", nargs="?", metavar="INPUT",
                   help="point cloud: .ply .obj .off .xyz .txt .csv .npz .las .laz "
                        "(omit with --example)")
    p.add_argument("--example", metavar="NAME",
                   help=f"use a built-in surface instead of INPUT: {', '.join(EXAMPLES)}")
    p.add_argument("--domain", default="free", metavar="SPEC",
                   help=f"parameter domain: {', '.join(n for n in DOMAINS if n != 'polygon')}, "
                        "NAME:VALUES such as disk:0.5, rect:2 or annulus:0.4, PATH.json "
                        "(a polygon with holes, GeoJSON-style) or PATH.png (a binary mask: "
                        "its white pixels); 'pcgeom domains' lists them "
                        "(default: free boundary)")
    p.add_argument("--cut", choices=CUTS, default="none",
                   help="auto: seams that open the cloud into a disk (closed clouds of any "
                        "genus; open ones cut from their holes to their rim), mapped without "
                        "a fold and packed into [0, 1]^2 with a gutter; the map file gets "
                        "'chart' and per-corner 'corner_uv'; needs --domain free "
                        "(default: none)")
    p.add_argument("--max-stretch", default=MAX_STRETCH, metavar="S",
                   help="with --cut auto: the bound (a number above 1) on a chart's "
                        "scale-factor spread (95th over 5th percentile): a chart over it "
                        "gets seams from its rim to its most shrunk point, then is split "
                        f"into charts packed by xatlas (default: {MAX_STRETCH:g})")
    p.add_argument("--landmarks", metavar="FILE.json",
                   help="landmark pairs: points of the input (indices or 3D points) and their "
                        "targets in the domain (points or polylines); onto the free boundary "
                        "(--preset fast) the landmark points are pinned on their targets")
    p.add_argument("--landmark-weight", metavar="W", type=float, default=None,
                   help="on the free boundary: pull the landmark points toward their targets "
                        "with this weight instead of pinning them (0: pinned, the default)")
    p.add_argument("--normals", choices=NORMALS_CHOICES, default="auto",
                   help="auto: use the file's oriented normals (PLY nx ny nz, NPZ 'normals', "
                        "six-column XYZ, LAS) when it has them; ignore: do not read them "
                        "(default: auto)")
    p.add_argument("--preset", default="fast", metavar="NAME",
                   help=f"training preset: {', '.join(PRESETS)} (default: fast)")
    add_denoise_option(p)
    p.add_argument("--device", default="auto", metavar="DEV",
                   help="auto, cpu or cuda (default: auto, CUDA when available)")
    p.add_argument("--seed", type=seed, default=0, help="random seed (default: 0)")
    p.add_argument("--threads", type=int_at_least(1), metavar="T",
                   help="torch threads on the CPU (default: torch's, one per core); on a "
                        "machine busy with other work, 1 can be several times faster")
    add_output_options(p, "OUT.npz", "output map (default: <input stem>_uv.npz next to the "
                                     "input; <example>_uv.npz in the current directory for "
                                     "--example)")
    p.add_argument("--out-ply", metavar="MAPPED.ply",
                   help="also write the mapped points (z = 0, input faces if any) as PLY; "
                        "on the sphere, the unit vectors")
    p.add_argument("--out-mesh", metavar="MESH.obj|MESH.ply",
                   help="also write the input's mesh with the map as its texture coordinates "
                        "(OBJ vt, PLY texture_u texture_v); a bare cloud gets its local mesh, "
                        "the one the map was built on")
    add_texture_option(p, "--out-mesh")
    p.add_argument("--plot", metavar="MAP.png",
                   help="also draw the map coloured by lambda_inv")
    p.add_argument("--resume", action="store_true",
                   help="continue from the checkpoint <out stem>.ckpt if it exists")
    p.set_defaults(run=run)


def _load_input(args) -> tuple[PointCloud, Path]:
    """The cloud (points, faces, normals, checked once, here) and the default output path,
    from INPUT or --example."""
    if (args.input is None) == (args.example is None):
        raise InputError("give exactly one of INPUT or --example NAME")
    if args.example is not None:
        V, F = load_example(args.example)  # ValueError for an unknown name
        return PointCloud(V, F, args.example), Path(f"{args.example}_uv.npz")
    src = Path(args.input)
    return (read_points(args.input, normals=args.normals == "auto"),
            src.with_name(f"{src.stem}_uv.npz"))


def _map_record(history: list[dict]) -> dict:
    """The map's first record (after the denoising's, when the run had one)."""
    return next((r for r in history if r.get("stage") != "denoise"), {})


def _normals_used(history: list[dict], given: bool) -> str:
    """``"input"``, ``"estimated"`` (the local-mesh map estimated them) or ``"none"``."""
    if _map_record(history).get("kind") == "localmesh":
        return _map_record(history)["normals"]
    return "input" if given else "none"


def _check_outputs(args, default_out: Path, domain) -> dict[str, Path | None]:
    """All output paths, checked writable, distinct, and none of them the input."""
    if args.out_mesh is not None and domain.closed:
        raise InputError("--out-mesh writes planar texture coordinates; a map onto the sphere "
                         "has none: use --out-ply for the sphere points")
    if args.texture is not None and args.out_mesh is None:
        raise InputError("--texture needs --out-mesh MESH.obj (the mesh it textures)")
    outs = {
        "out": check_writable(args.out if args.out is not None else default_out, "npz"),
        "out_ply": check_writable(args.out_ply, "ply") if args.out_ply else None,
        "out_mesh": check_mesh_path(args.out_mesh, args.texture) if args.out_mesh else None,
        "plot": check_writable(args.plot, "png") if args.plot else None,
    }
    outs["checkpoint"] = check_writable(outs["out"].with_suffix(".ckpt"), "ckpt")
    extra = texture_paths(outs["out_mesh"], args.texture) if args.texture is not None else {}
    distinct_paths({"INPUT": args.input, "--landmarks": args.landmarks},
                   {**outs, **{f"texture {k}": v for k, v in extra.items()}})
    return outs


def _write_mesh(args, outs, cloud: PointCloud, result) -> dict | None:
    """``--out-mesh``: the input's mesh (or a bare cloud's local mesh, the one the map kept)
    with the map as its texture coordinates; the summary's ``mesh`` object (None without
    ``--out-mesh``)."""
    if outs["out_mesh"] is None:
        return None
    # A denoised map was made of the fitted points: its mesh is theirs.
    fitted = result.fitted if result.fitted is not None else cloud
    if result.corner_uv is not None:  # an atlas: the cut local mesh, uv per corner
        mesh = map_mesh(fitted, result.uv, None, mesh_faces=result.mesh_faces)
        write_mesh(outs["out_mesh"], mesh.vertices, mesh.faces, texture=args.texture,
                   corner_uv=result.corner_uv)
        files = None
        if args.texture is not None:
            files = {k: os.fspath(v)
                     for k, v in texture_paths(outs["out_mesh"], args.texture).items()}
        return {"source": "atlas", "n_vertices": len(mesh.vertices),
                "n_faces": len(mesh.faces), "unused_points": mesh.unused,
                "uv_offset": [0.0, 0.0], "uv_scale": 1.0,
                "texture": args.texture.spec if args.texture is not None else None,
                "texture_files": files}
    mesh = map_mesh(fitted, result.uv, cloud.faces, mesh_faces=result.mesh_faces,
                    config=result.config, normals=cloud.normals, progress=not args.quiet)
    scaling = uv_scaling(mesh.uv)
    write_mesh(outs["out_mesh"], mesh.vertices, mesh.faces, uv=scaling.apply(mesh.uv),
               texture=args.texture)
    files = None
    if args.texture is not None:
        files = {k: os.fspath(v) for k, v in texture_paths(outs["out_mesh"], args.texture).items()}
    return {"source": mesh.source, "n_vertices": len(mesh.vertices), "n_faces": len(mesh.faces),
            "unused_points": mesh.unused, **scaling.to_dict(),
            "texture": args.texture.spec if args.texture is not None else None,
            "texture_files": files}


def run(args) -> int:
    """Run ``pcgeom param`` on parsed arguments; returns the exit status."""
    # Everything that can be wrong with the request is checked here, before training.
    domain = get_domain(args.domain)
    config = with_landmark_weight(with_denoise(get_preset(args.preset), args.denoise),
                                  args.landmark_weight)
    choose_map(domain, config, args.landmarks is not None)  # a request no map is built for
    max_stretch = check_cut(args.cut, args.max_stretch, domain.name)
    if args.cut == "auto" and args.landmarks is not None:
        raise InputError("--cut auto does not take landmarks")
    if args.cut == "auto" and args.out_mesh is not None \
            and not str(args.out_mesh).lower().endswith(".obj"):
        raise InputError("--out-mesh with --cut auto writes per-corner texture coordinates: "
                         "give an .obj path")
    device = resolve_device(args.device)
    cloud, default_out = _load_input(args)
    points, faces, normals, name = cloud.points, cloud.faces, cloud.normals, cloud.source
    landmarks = []
    if args.landmarks is not None:
        landmarks = [(points[pair.indices], pair.targets)
                     for pair in read_landmarks(args.landmarks, points)]
    outs = _check_outputs(args, default_out, domain)

    if args.threads is not None:
        torch.set_num_threads(args.threads)
    result = parametrize(cloud, domain, config=config, landmarks=landmarks, device=device,
                         seed=args.seed, checkpoint=outs["checkpoint"], resume=args.resume,
                         progress=not args.quiet, cut=args.cut, max_stretch=max_stretch)
    result.faces = faces
    domain = result.domain  # what the cloud decided filled in (annulus:auto's radius)
    result.save(outs["out"])
    if outs["out_ply"] is not None:
        mapped = (result.uv if domain.closed  # the sphere's unit vectors
                  else np.column_stack([result.uv, np.zeros(len(result.uv))]))  # z = 0
        write_ply_atomic(outs["out_ply"], mapped, faces)
    mesh = _write_mesh(args, outs, cloud, result)
    if outs["plot"] is not None and result.corner_uv is not None:  # an atlas
        from ..apps.plot_atlas import plot_atlas

        plot_atlas(cloud.points, result.mesh_faces, result.corner_uv, outs["plot"],
                   title=f"{name}: --cut auto, {args.preset}")
    elif outs["plot"] is not None:
        from ..apps.plot import plot_map, plot_sphere

        title = f"{name}: {domain.label}, {args.preset} (colour: lambda_inv)"
        if domain.closed:
            plot_sphere(result.uv, outs["plot"], values=result.lambda_inv, title=title,
                        value_label="lambda_inv")
        else:
            plot_map(result.uv, outs["plot"], values=result.lambda_inv, domain=domain,
                     title=title)
    report = map_report(result.uv, domain, points, faces if result.corner_uv is None else None)
    if faces is not None and result.corner_uv is not None:  # a cut map: inside charts
        from ..maps.atlas_eval import cut_map_report

        report.update(cut_map_report(points, faces, result, overlap=False))
    outs["checkpoint"].unlink(missing_ok=True)

    final = result.history[-1] if result.history else {}
    evaluation = None
    if faces is not None:
        evaluation = {k: report[k] for k in ("mean_abs_angle_rad", "flipped", "n_faces",
                                             "flipped_where")}
        if report["flipped"]:
            warnings.warn(f"the map turns over {report['flipped']} of the input's "
                          f"{report['n_faces']} triangles ({report['flipped_percent']:.2f}%)"
                          + flip_places(report["flipped_where"]))
    summary = {
        "command": "param",
        "input": name,
        "out": os.fspath(outs["out"]),
        "out_ply": os.fspath(outs["out_ply"]) if outs["out_ply"] else None,
        "out_mesh": os.fspath(outs["out_mesh"]) if outs["out_mesh"] else None,
        "mesh": mesh,
        "plot": os.fspath(outs["plot"]) if outs["plot"] else None,
        "n_points": report["n_points"],
        # A polygon's spec holds all its coordinates: scripts get the file they named.
        "domain": args.domain if isinstance(domain, PolygonDomain) else domain.spec,
        "preset": args.preset,
        "device": str(device),
        "seed": args.seed,
        "version": result.version,
        "seconds": float(result.seconds),
        "method": "localmesh" if _map_record(result.history).get("kind") == "localmesh"
                  else "networks",
        "normals": _normals_used(result.history, normals is not None),
        # The local mesh's topology (its repaired largest part): None without a local mesh.
        "genus": _map_record(result.history).get("genus"),
        "boundary_loops": _map_record(result.history).get("boundary_loops"),
        "denoise": result.denoise,
        "loss": {k: float(final[k]) for k in LOSS_TERMS if k in final},
        "landmark_hausdorff": final.get("landmark_hausdorff"),
        "evaluation": evaluation,
        "domain_hausdorff": report["domain_hausdorff"],
        "surface_hausdorff": report["surface_hausdorff"],
    }
    if args.json:
        print(json.dumps(summary))
        return EXIT_OK
    written = [summary["out"]] + [summary[k] for k in ("out_ply", "out_mesh", "plot")
                                  if summary[k]]
    print(f"{name}: {summary['n_points']} points -> {', '.join(written)}")
    print(f"preset {args.preset}, domain {domain.label}, device {summary['device']}, "
          f"seed {args.seed}: {summary['seconds']:.1f} s")
    note = "" if summary["normals"] == "input" else f" ({NO_NORMALS_NOTE})"
    print(f"method {summary['method']}, normals {summary['normals']}{note}")
    print_noise(result.denoise)
    if summary["loss"]:
        print("final loss: " + ", ".join(f"{k} {v:.4g}" for k, v in summary["loss"].items()))
    print_domain_fit(summary, domain.label)
    if summary["landmark_hausdorff"] is not None:
        print("Hausdorff distance of each landmark set to its targets: "
              + ", ".join(f"{d:.4f}" for d in summary["landmark_hausdorff"]))
    if evaluation is not None:
        print_angles(report)
    if mesh is not None:
        print(_mesh_line(mesh, summary["out_mesh"], len(points)))
        print(texture_line(mesh))
    return EXIT_OK


def _mesh_line(mesh: dict, path: str, n_points: int) -> str:
    """The human line for ``--out-mesh``: whose triangles it holds."""
    if mesh["source"] == "atlas":
        return (f"{path}: the cut local mesh, {mesh['n_faces']} triangles over "
                f"{mesh['n_vertices']} points, with the atlas as per-corner texture coordinates")
    if mesh["source"] == "input":
        return (f"{path}: the input's {mesh['n_faces']} triangles with the map as texture "
                "coordinates")
    return (f"{path}: the input has no faces, so this is its local mesh (the one the map was "
            f"built on): {mesh['n_faces']} triangles over {mesh['n_vertices']} of the "
            f"{n_points} points")


def main(argv: list[str] | None = None) -> int:
    """``pcgeom param`` on its own: ``main(["--example", "peaks3"])``."""
    import sys

    return run_command(standalone_parser(sys.modules[__name__]), argv)
