"""Many scans on a Dask cluster: one map per scan, resumable, one summary row per scan.

:func:`run_batch` maps every input onto the same domain with the same config and seed, one
Dask task per scan, on a ``LocalCluster`` it starts or on an existing scheduler. The
client sends each task a plain dict of paths and settings (:func:`map_scan` reads the
cloud on the worker), never arrays, so the client and the workers must see the same paths.

What one scan ``NAME`` (the input's file stem) leaves in the output directory ``DIR``:

=========================  ===================================================================
file                       content
=========================  ===================================================================
``NAME_uv.npz``            the map, :class:`pcgeom.io.ParamResult` (``ParamResult.load``)
``NAME_loops.json``        boundary loops (``boundary=True``), as ``pcgeom boundary`` writes
``NAME_mesh.ply``          reconstructed mesh (``reconstruct=True``), as ``pcgeom reconstruct``
``.checkpoints/NAME.ckpt`` stage checkpoint while the scan trains; removed after success
``summary.csv``            one row per scan, :data:`SUMMARY_COLUMNS`
=========================  ===================================================================

Every file is written atomically (:mod:`pcgeom.io.atomic`).

Resume rules
------------
A scan is *up to date*, and skipped, when ``NAME_uv.npz`` exists, loads, and records the
same input fingerprint (:func:`pcgeom.cloud.fingerprint` of the coordinates, so a renamed
or touched file with the same points still counts), config, domain and seed, and every
optional output asked for exists. A map that is up to date but lacks an optional output
is reused, not retrained. A scan that trains resumes from its stage checkpoint when one of
the same identity is there (a stale one is discarded). The client checks all this before
it starts a cluster: a rerun of a finished batch starts none.

Failures
--------
A scan whose input cannot be read or whose training rejects it (``ValueError``, e.g.
:class:`pcgeom.errors.InputError`) gets its one-line error in its row at once; such errors
are not retried. Any other exception is retried ``retries`` times by Dask (``submit(...,
retries=)``). A worker that dies (killed, out of memory) is replaced and its scan
rescheduled by the scheduler, up to ``allowed_failures`` times (``retries`` on a local
cluster); the rerun resumes from the scan's last stage checkpoint. A map is written only
by an attempt that finished training, and an attempt that finds it written reuses it, so
each map is written once.
"""

from __future__ import annotations

import csv
import glob
import io
import os
import sys
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..cloud import fingerprint
from ..config import ParamConfig, get_preset
from ..domains import Domain, get_domain
from ..errors import InputError, _one_line
from ..io import SUPPORTED_EXTENSIONS, ParamResult, read_points, write_atomic, write_ply_atomic
from ..progress import Progress

__all__ = ["SUMMARY_COLUMNS", "SUMMARY_NAME", "BatchReport", "collect_inputs", "scan_paths",
           "map_scan", "write_summary", "run_batch"]

SUMMARY_NAME = "summary.csv"
"""Name of the summary file in the output directory."""

SUMMARY_COLUMNS = ("name", "input", "status", "error", "points", "seconds", "worker",
                   "resumed", "loss", "angle_distortion_rad", "flipped")
"""Columns of ``summary.csv``. ``status``: ``ok`` (made in this run), ``skipped`` (up to date
from an earlier run) or ``error`` (``error`` holds the one-line message). ``seconds``: training
time of the map (kept in the map file, so skipped rows have it too). ``worker``: the Dask
worker's address. ``resumed``: ``yes`` when training continued from a stage checkpoint.
``loss``: the final total loss (empty for a map made without one). ``angle_distortion_rad``
(mean absolute angle distortion) and ``flipped`` (flipped triangles): only when the input
has faces; empty otherwise."""

STATUSES = ("ok", "skipped", "error")


@dataclass
class BatchReport:
    """What :func:`run_batch` did: one row per scan, in input order."""

    rows: list[dict]
    """One dict per scan with the keys of :data:`SUMMARY_COLUMNS`."""
    summary: Path
    """The ``summary.csv`` written."""
    dashboard: str | None = None
    """URL of the Dask dashboard of the cluster used (None when no cluster was needed)."""
    counts: dict = field(default_factory=dict)
    """Rows per status (``ok``, ``skipped``, ``error``)."""

    @property
    def failed(self) -> bool:
        """Whether any scan ended with an error."""
        return self.counts.get("error", 0) > 0


# --------------------------------------------------------------------------- inputs


def _read_list(spec: str) -> list[str]:
    """Paths listed in ``@FILE``: one per line, ``#`` comments; relative to the list's folder."""
    list_path = Path(spec[1:])
    try:
        text = list_path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{spec[1:]}: cannot read the list of inputs ({_one_line(exc)})") from None
    entries = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            entries.append(os.fspath(list_path.parent / line) if not os.path.isabs(line) else line)
    if not entries:
        raise InputError(f"{spec[1:]}: the list of inputs names no file")
    return entries


def collect_inputs(specs: Sequence[str]) -> list[Path]:
    """The input files named by ``specs``: paths, glob patterns and ``@LIST`` files.

    ``@LIST`` is a text file with one path (or pattern) per line, ``#`` comments allowed,
    relative paths taken from the list's folder. The same file named twice is kept once, in
    first-seen order.

    Raises
    ------
    InputError
        No specs, a pattern that matches nothing, a missing path, a folder, a file whose
        extension is not a point cloud's, or two inputs with the same stem (their outputs
        would collide).
    """
    if not specs:
        raise InputError("no inputs given")
    paths: list[Path] = []
    for spec in specs:
        entries = _read_list(spec) if spec.startswith("@") else [spec]
        for entry in entries:
            if glob.has_magic(entry):
                matched = sorted(glob.glob(entry, recursive=True))
                if not matched:
                    raise InputError(f"{entry}: no input matched this pattern")
                paths.extend(Path(m) for m in matched if not Path(m).is_dir())
            else:
                path = Path(entry)
                if not path.exists():
                    raise InputError(f"{entry}: no such file")
                if path.is_dir():
                    raise InputError(f"{entry}: is a directory; give a pattern such as "
                                     f"'{os.path.join(entry, '*.ply')}'")
                paths.append(path)
    unique: dict[Path, Path] = {}
    for path in paths:
        unique.setdefault(path.resolve(), path)
    paths = list(unique.values())
    if not paths:
        raise InputError("no inputs matched")
    names: dict[str, Path] = {}
    for path in paths:
        if path.suffix.lower() not in SUPPORTED_EXTENSIONS:
            raise InputError(f"{os.fspath(path)}: unknown extension {path.suffix or '(none)'!r}; "
                             f"supported: {', '.join(SUPPORTED_EXTENSIONS)}")
        if path.stem in names:
            raise InputError(f"{os.fspath(names[path.stem])} and {os.fspath(path)} have the same "
                             f"name {path.stem!r}; their outputs would collide")
        names[path.stem] = path
    return paths


def scan_paths(out_dir, name: str) -> dict[str, Path]:
    """Where the outputs of scan ``name`` go in ``out_dir`` (keys ``map``, ``loops``, ``mesh``,
    ``checkpoint``)."""
    out_dir = Path(out_dir)
    return {"map": out_dir / f"{name}_uv.npz", "loops": out_dir / f"{name}_loops.json",
            "mesh": out_dir / f"{name}_mesh.ply",
            "checkpoint": out_dir / ".checkpoints" / f"{name}.ckpt"}


# --------------------------------------------------------------------------- one scan


def _row(job: dict, status: str, **values) -> dict:
    row = dict.fromkeys(SUMMARY_COLUMNS)
    row.update(name=job["name"], input=job["input"], status=status, error="", resumed="no")
    row.update(values)
    return row


def _current_map(paths: dict[str, Path], fp: str, config: ParamConfig, domain: Domain,
                 seed: int, n_points: int) -> ParamResult | None:
    """The existing map of a scan when it was made from these points, config, domain and seed."""
    if not paths["map"].is_file():
        return None
    try:
        result = ParamResult.load(paths["map"], n_points=n_points)
    except InputError:  # unreadable or another cloud's: it is remade
        return None
    same = (result.fingerprint == fp and result.config == config and result.seed == seed
            and result.domain is not None and result.domain.to_dict() == domain.to_dict())
    return result if same else None


def _wanted(job: dict) -> list[str]:
    """The optional outputs the job asks for (keys of :func:`scan_paths`)."""
    return [key for key, flag in (("loops", "boundary"), ("mesh", "reconstruct")) if job[flag]]


def _measures(result: ParamResult, points: np.ndarray, faces) -> dict:
    """The row's numbers from a map: points, seconds, final loss, angle distortion and flips."""
    from .evaluate import map_report

    final = result.history[-1] if result.history else {}
    values = {"points": len(points), "seconds": round(float(result.seconds), 3),
              "loss": float(final["total"]) if "total" in final else None}
    if faces is not None:
        report = map_report(result.uv, None, points, faces)
        values.update(angle_distortion_rad=report["mean_abs_angle_rad"],
                      flipped=report["flipped"])
    return values


def _worker_name() -> str:
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):  # called outside a Dask worker
        import socket

        return f"{socket.gethostname()}:{os.getpid()}"


def _train(job: dict, cloud, config, domain, paths) -> tuple[ParamResult, bool]:
    """Train the scan's map, resuming from its checkpoint; returns (result, resumed).

    The file's normals, when it has them, are used as ``pcgeom param`` uses them."""
    from ..maps import parametrize

    ckpt = paths["checkpoint"]
    ckpt.parent.mkdir(exist_ok=True)
    resumed = ckpt.is_file()
    # The cloud as read (checked once, by read_points), with its normals.
    settings = dict(config=config, seed=job["seed"], device=job["device"], checkpoint=ckpt,
                    progress=False)
    try:
        result = parametrize(cloud, domain, resume=resumed, **settings)
    except InputError:
        if not resumed:
            raise
        # A checkpoint of another config or input (or a damaged one): start over. An error
        # that is not the checkpoint's comes back from the second call.
        ckpt.unlink(missing_ok=True)
        resumed = False
        result = parametrize(cloud, domain, resume=False, **settings)
    return result, resumed


def map_scan(job: dict) -> dict:
    """Map one scan, as a Dask task: read, train (or reuse), write its outputs, return its row.

    Parameters
    ----------
    job : dict
        Plain data only: ``name``, ``input`` (path), ``out_dir``, ``config``
        (``ParamConfig.to_dict()``), ``domain`` (``Domain.to_dict()``), ``seed``,
        ``device``, ``boundary``, ``reconstruct``, ``target_vertices``, ``threads`` (torch
        threads of this task).

    Returns
    -------
    dict
        The scan's summary row (:data:`SUMMARY_COLUMNS`), plus ``warnings``: the one-line
        messages of the warnings the scan raised (in order, each once). Bad input
        (``ValueError``) gives an ``error`` row; any other exception propagates, for Dask to
        retry.
    """
    import torch

    torch.set_num_threads(job["threads"])  # N workers x T threads must not oversubscribe
    # The scan's warnings (a map that turns triangles over, columns that are not normals, ...)
    # go back to the client in the row, which issues them as its own: a worker's stderr would
    # show raw UserWarning lines with their source, --quiet or not.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        row = _map_scan(job)
    row["warnings"] = list(dict.fromkeys(_one_line(w.message) for w in caught))
    return row


def _map_scan(job: dict) -> dict:
    """:func:`map_scan`'s work, its warnings left to the caller."""
    worker = _worker_name()
    try:
        config = ParamConfig.from_dict(job["config"])
        domain = get_domain(job["domain"])
        cloud = read_points(job["input"])
        points, faces = cloud.points, cloud.faces
        paths = scan_paths(job["out_dir"], job["name"])
        result = _current_map(paths, fingerprint(points), config, domain, job["seed"],
                              len(points))
        resumed = False
        wrote = False
        if result is None:
            result, resumed = _train(job, cloud, config, domain, paths)
            result.faces = faces
            # Outputs of an older map must not outlive it, even if this attempt dies.
            for key in ("loops", "mesh"):
                paths[key].unlink(missing_ok=True)
            result.save(paths["map"])
            wrote = True
        todo = [key for key in _wanted(job) if not paths[key].is_file()]
        if todo:
            _write_extras(job, points, result, paths, todo)
            wrote = True
        paths["checkpoint"].unlink(missing_ok=True)
    except ValueError as exc:  # InputError and the like: the same on every attempt
        return _row(job, "error", error=_one_line(exc), worker=worker)
    return _row(job, "ok" if wrote else "skipped", worker=worker,
                resumed="yes" if resumed else "no", **_measures(result, points, faces))


def _write_extras(job: dict, points, result: ParamResult, paths: dict, todo: list[str]) -> None:
    """Boundary loops (``NAME_loops.json``) and the reconstructed mesh (``NAME_mesh.ply``)."""
    import json

    from .boundary import detect_boundary

    # As pcgeom boundary and pcgeom reconstruct do: the loops judged on the points the map was
    # made of, and the mesh lifted over the inliers only (strays never lifted), a denoised
    # map's rims smoothed along their loops first.
    surface = result.fitted if result.fitted is not None else points
    if "loops" in todo:
        found = detect_boundary(result.uv, points=surface)
        document = {**found.to_dict(), "input": job["input"], "n_points": len(points)}
        write_atomic(paths["loops"], lambda f: f.write(json.dumps(document).encode("utf-8")))
    if "mesh" in todo:
        from .reconstruct import inlier_rows, reconstruct_surface

        rows = inlier_rows(surface, result.mesh_faces)
        lam = result.lambda_inv[rows] if result.lambda_inv is not None else None
        V, F, _ = reconstruct_surface(surface[rows], result.uv[rows],
                                      detect_boundary(result.uv[rows], points=surface[rows]),
                                      target_vertices=job["target_vertices"], lambda_inv=lam,
                                      smooth_rim=result.fitted is not None)
        write_ply_atomic(paths["mesh"], V, F)


# --------------------------------------------------------------------------- the batch


def _check_request(out_dir, domain: Domain, *, boundary: bool, reconstruct: bool,
                   target_vertices: int, scheduler, workers, threads_per_worker: int,
                   retries: int) -> Path:
    """Every check on the request that needs no input file; returns ``out_dir`` as a Path."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError(f"{os.fspath(out_dir)}: is a file; the output must be a directory")
    parent = out if out.exists() else next((p for p in out.absolute().parents if p.exists()), None)
    if parent is None or not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{os.fspath(out_dir)}: output directory is not writable")
    if (boundary or reconstruct) and domain.bounded:
        raise InputError(f"boundary loops and reconstruction need a free-boundary map; drop "
                         f"--domain {domain.label}")
    for label, value, minimum in (("target_vertices", target_vertices, 3),
                                  ("threads_per_worker", threads_per_worker, 1),
                                  ("retries", retries, 0)):
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise InputError(f"{label}: expected an integer >= {minimum}, got {value!r}")
    if scheduler is not None and workers is not None:
        raise InputError("workers: the cluster at the scheduler address has its own workers; "
                         "give workers only without a scheduler")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or workers < 1):
        raise InputError(f"workers: expected an integer >= 1, got {workers!r}")
    if reconstruct:
        from .reconstruct import require_gmsh

        require_gmsh()  # a missing gmsh fails here, before any work
    return out


def _plan(paths: list[Path], job_base: dict, config: ParamConfig, domain: Domain,
          seed: int) -> tuple[list[dict | None], list[dict]]:
    """Rows known without a cluster (unreadable input, up to date) and the jobs to run."""
    rows: list[dict | None] = []
    jobs: list[dict] = []
    for path in paths:
        job = {**job_base, "name": path.stem, "input": os.fspath(path)}
        try:
            cloud = read_points(path, normals=False)  # the worker reads (and checks) normals
        except InputError as exc:
            rows.append(_row(job, "error", error=_one_line(exc)))
            continue
        outs = scan_paths(job["out_dir"], job["name"])
        result = _current_map(outs, fingerprint(cloud.points), config, domain, seed,
                              len(cloud.points))
        if result is not None and all(outs[key].is_file() for key in _wanted(job)):
            rows.append(_row(job, "skipped", **_measures(result, cloud.points, cloud.faces)))
        else:
            rows.append(None)
            jobs.append(job)
    return rows, jobs


def write_summary(path: Path, rows: list[dict]) -> None:
    """``summary.csv``: a header of :data:`SUMMARY_COLUMNS`, then one line per row, atomically."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=SUMMARY_COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: "" if row[k] is None else row[k] for k in SUMMARY_COLUMNS})
    text = buffer.getvalue()
    write_atomic(path, lambda f: f.write(text.encode("utf-8")))


def _failure_row(job: dict, exc: BaseException, allowed_failures: int | None) -> dict:
    name = type(exc).__name__
    if name == "KilledWorker":
        times = "" if allowed_failures is None else f" {allowed_failures + 1} times"
        message = f"KilledWorker: its worker died{times} while mapping it (out of memory?)"
    else:
        message = f"{name}: {_one_line(exc)}"
    return _row(job, "error", error=message)


CONNECT_TIMEOUT = "10s"
"""How long the client tries to reach a ``scheduler`` address before giving up."""


def _connect(scheduler: str | None, workers: int, retries: int):
    """(client, cluster or None, allowed_failures) for a new LocalCluster or an address."""
    from distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError) as exc:
            raise InputError(f"cannot connect to the Dask scheduler at {scheduler} "
                             f"({_one_line(exc)}); is it running, and is the address right?"
                             ) from None
        return client, None, None
    # One scan at a time per worker process; torch gets the worker's threads (map_scan).
    # A port of 0 lets two batches on one machine each get a dashboard.
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                           dashboard_address=":0",
                           scheduler_kwargs={"allowed_failures": retries})
    return Client(cluster), cluster, retries


def _default_workers(threads_per_worker: int) -> int:
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return max(1, (cores or 1) // threads_per_worker)


def run_batch(inputs: Sequence[str], out_dir, *, domain: Domain | str | dict = "free",
              config: ParamConfig | str = "fast", seed: int = 0, boundary: bool = False,
              reconstruct: bool = False, target_vertices: int = 5000,
              scheduler: str | None = None, workers: int | None = None,
              threads_per_worker: int = 1, retries: int = 2, device: str = "auto",
              progress: bool = True) -> BatchReport:
    """Map many scans on a Dask cluster, one task per scan; skip the ones already done.

    Parameters
    ----------
    inputs : sequence of str
        Paths, glob patterns and ``@LIST`` files (:func:`collect_inputs`).
    out_dir : path
        Output directory (created if missing); see the module docstring for its files.
    domain, config, seed
        As :func:`pcgeom.parametrize`; ``config`` may be a preset name.
    boundary : bool
        Also write each scan's boundary loops, ``NAME_loops.json``.
    reconstruct : bool
        Also write a remeshed surface, ``NAME_mesh.ply`` of about ``target_vertices``
        vertices (needs gmsh on the workers).
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``). Default: start a
        ``LocalCluster`` of ``workers`` processes, closed at the end.
    workers : int, optional
        Worker processes of the local cluster (default: usable cores // threads_per_worker).
    threads_per_worker : int
        Torch threads per task (``torch.set_num_threads`` on the worker).
    retries : int
        How many more times a scan is tried after an exception that is not bad input; on a
        local cluster also how many times it may lose its worker (``allowed_failures``).
    device : str
        Training device on the workers (``"auto"``: CUDA where a worker has it).
    progress : bool
        One tqdm bar over scans and the dashboard URL, on stderr.

    Returns
    -------
    BatchReport
        Rows in input order; ``summary.csv`` is written after every finished scan.

    Raises
    ------
    InputError
        Bad request, before any work: no input matched, a missing or unsupported input,
        two inputs with one name, ``out_dir`` a file or not writable, loops or a mesh asked
        of a bounded domain, a count out of range, ``workers`` with ``scheduler``.
        The scheduler cannot be reached (before the output folder is made).

    Warns
    -----
    UserWarning
        Each scan's warnings, as ``"NAME: message"``, when its task returns.
    """
    domain = get_domain(domain)
    config = get_preset(config) if isinstance(config, str) else config
    if not isinstance(config, ParamConfig):
        raise TypeError(f"config: expected a ParamConfig or a preset name, "
                        f"got {type(config).__name__}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"seed: expected an integer >= 0, got {seed!r}")
    out = _check_request(out_dir, domain, boundary=boundary, reconstruct=reconstruct,
                         target_vertices=target_vertices, scheduler=scheduler, workers=workers,
                         threads_per_worker=threads_per_worker, retries=retries)
    paths = collect_inputs(inputs)
    summary = out / SUMMARY_NAME
    job_base = {"out_dir": os.fspath(out.absolute()), "config": config.to_dict(),
                "domain": domain.to_dict(), "seed": seed, "device": device,
                "boundary": boundary, "reconstruct": reconstruct,
                "target_vertices": target_vertices, "threads": threads_per_worker}
    rows, jobs = _plan(paths, job_base, config, domain, seed)
    dashboard = None
    # The cluster before the output folder: an unreachable scheduler leaves nothing behind.
    connection = (_connect(scheduler, workers or _default_workers(threads_per_worker), retries)
                  if jobs else None)
    try:
        out.mkdir(parents=True, exist_ok=True)
        write_summary(summary, [r for r in rows if r is not None])
        if jobs:
            dashboard = _run_jobs(rows, jobs, summary, connection, retries=retries,
                                  progress=progress)
    finally:
        if connection is not None:
            client, cluster, _ = connection
            client.close()
            if cluster is not None:
                cluster.close()
    try:
        (out / ".checkpoints").rmdir()  # only when empty: no scan left a stage behind
    except OSError:
        pass
    counts = {status: sum(r["status"] == status for r in rows) for status in STATUSES}
    return BatchReport(rows=rows, summary=summary, dashboard=dashboard, counts=counts)


def _run_jobs(rows: list[dict | None], jobs: list[dict], summary: Path, connection, *,
              retries: int, progress: bool) -> str:
    """Submit ``jobs`` on ``connection`` (:func:`_connect`'s), fill their rows as they
    finish, issue each scan's warnings as ``"NAME: message"``; returns the dashboard URL."""
    from distributed import as_completed

    # Rows still None are the jobs', in the same order.
    index = dict(zip((job["name"] for job in jobs), (i for i, r in enumerate(rows) if r is None)))
    client, _, allowed = connection
    dashboard = client.dashboard_link
    bar = Progress(len(rows), "batch: scans", enabled=progress, unit="scan",
                   initial=len(rows) - len(jobs), milestones=True)
    futures = []
    try:
        if progress:
            print(f"pcgeom batch: Dask dashboard at {dashboard}", file=sys.stderr, flush=True)
        # pure=False: a resubmitted scan is new work even with the same arguments.
        futures = [client.submit(map_scan, job, retries=retries, pure=False) for job in jobs]
        job_of = {future.key: job for future, job in zip(futures, jobs)}
        for future in as_completed(futures):
            job = job_of[future.key]
            if future.status == "finished":
                row = future.result()
                for message in row.pop("warnings", ()):
                    warnings.warn(f"{job['name']}: {message}", UserWarning, stacklevel=2)
            elif future.cancelled():  # e.g. the scheduler went away
                row = _row(job, "error", error="cancelled: the Dask scheduler dropped the task")
            else:
                row = _failure_row(job, future.exception(), allowed)
            rows[index[job["name"]]] = row
            write_summary(summary, [r for r in rows if r is not None])
            bar.update(1)
            if row["status"] == "error":
                bar.write(f"pcgeom batch: {row['name']}: {row['error']}")
    finally:
        bar.close()
        for future in futures:
            if not future.done():  # interrupted: nothing may keep running for this batch
                future.cancel()
    return dashboard
