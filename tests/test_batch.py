"""``pcgeom batch`` (pcgeom.apps.batch): many scans on a Dask cluster, resumable.

The cluster tests run real Dask clusters of two worker processes on clouds of a few hundred
points with a tiny training budget (``tests.helpers.tiny_preset`` with two short stages):
they check the scheduling, the files and the resume rules, not the quality of the maps.
Where a test needs stage checkpoints it maps onto the disk, since a bounded domain always
trains the networks stage by stage. The faults
are deterministic: a worker plugin makes the first stage checkpoint written anywhere kill
its own process (once, claimed through a marker file), makes one scan's reads fail with an
``OSError`` on every attempt, and records every map saved.
"""

from __future__ import annotations

import dataclasses

import csv
import json
import os
import signal
import socket
from pathlib import Path

import numpy as np
import pytest
from distributed.diagnostics.plugin import WorkerPlugin

import pcgeom.apps.batch as batch_app
import pcgeom.cli.batch as batch_command
from pcgeom import ParamResult, cli, parametrize
from pcgeom.apps.batch import (SUMMARY_COLUMNS, collect_inputs, map_scan, run_batch,
                               scan_paths)
from pcgeom.cloud import fingerprint
from pcgeom.domains import get_domain
from pcgeom.errors import InputError
from pcgeom.examples import peaks_surface
from pcgeom.io import read_points, write_ply_atomic

from tests.helpers import assert_cli_fails, tiny_preset


def _tiny(name: str = "fast"):
    """The preset shrunk to seconds, with two short network stages so that a map trained in
    stages has a checkpoint mid-scan (the disk by the networks too: ``fast`` maps it by the
    local mesh, in one step); unknown names still raise the real error."""
    return dataclasses.replace(tiny_preset(name, max_stages=2), disk_map="networks",
                               domain_map="networks")


def _write_scans(folder: Path, n: int = 4, broken: bool = True) -> list[Path]:
    """``n`` small curved patches (peaks3, 18 x 18 = 324 points, with faces), each shifted a
    little so their fingerprints differ, and one broken file (3 points)."""
    folder.mkdir(parents=True, exist_ok=True)
    V, F = peaks_surface("peaks3", n_side=18)
    paths = []
    for k in range(n):
        path = folder / f"scan{k}.ply"
        write_ply_atomic(path, V * (1.0 + 0.05 * k), F)
        paths.append(path)
    if broken:
        bad = folder / "broken.xyz"
        bad.write_text("0 0 0\n1 0 0\n0 1 0\n")
        paths.append(bad)
    return paths


def _summary(out: Path) -> list[dict]:
    with open(out / "summary.csv", newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        assert tuple(reader.fieldnames) == SUMMARY_COLUMNS
        return list(reader)


def _mtimes(out: Path) -> dict[str, int]:
    return {p.name: p.stat().st_mtime_ns for p in out.iterdir() if p.name != "summary.csv"}


@pytest.fixture
def tiny(monkeypatch):
    monkeypatch.setattr(batch_command, "get_preset", _tiny)


@pytest.fixture
def no_cluster(monkeypatch):
    """Fail the test if the batch starts or reaches a cluster."""

    def forbidden(*args, **kwargs):
        raise AssertionError("a cluster was started although no scan needed one")

    monkeypatch.setattr(batch_app, "_connect", forbidden)


# --------------------------------------------------------------------------- errors


def test_bad_requests_fail_in_one_line_before_any_work(tmp_path, capsys, monkeypatch,
                                                       no_cluster):
    monkeypatch.chdir(tmp_path)
    _write_scans(tmp_path / "scans", n=1, broken=False)
    Path("afile").write_text("x")
    Path("notes.md").write_text("x")
    (tmp_path / "other").mkdir()
    write_ply_atomic(tmp_path / "other" / "scan0.ply", *peaks_surface("peaks3", n_side=6))
    Path("empty.txt").write_text("# nothing\n")
    ok = ["scans/*.ply", "--out", "maps"]
    cases = [
        (["nothing/*.ply", "--out", "maps"], "nothing/*.ply: no input matched this pattern"),
        (["missing.ply", "--out", "maps"], "missing.ply: no such file"),
        (["scans", "--out", "maps"], "scans: is a directory"),
        (["notes.md", "--out", "maps"], "notes.md: unknown extension '.md'"),
        (["scans/scan0.ply", "other/scan0.ply", "--out", "maps"],
         "have the same name 'scan0'; their outputs would collide"),
        (["@nolist.txt", "--out", "maps"], "nolist.txt: cannot read the list of inputs"),
        (["@empty.txt", "--out", "maps"], "empty.txt: the list of inputs names no file"),
        (["scans/*.ply", "--out", "afile"], "afile: is a file; the output must be a directory"),
        ([*ok, "--workers", "0"], "argument --workers: expected a positive integer, got 0"),
        ([*ok, "--threads-per-worker", "0"],
         "argument --threads-per-worker: expected a positive integer, got 0"),
        ([*ok, "--retries", "-1"], "argument --retries: expected a non-negative integer"),
        ([*ok, "--target-vertices", "100"], "--target-vertices needs --reconstruct"),
        ([*ok, "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"],
         "--workers applies to the local cluster"),
        ([*ok, "--boundary", "--domain", "disk"],
         "boundary loops and reconstruction need a free-boundary map; drop --domain disk"),
        ([*ok, "--preset", "nope"], "unknown preset 'nope'"),
        ([*ok, "--domain", "nope"], "nope"),
    ]
    for argv, message in cases:
        assert_cli_fails(capsys, ["batch", *argv], message)
    assert not Path("maps").exists()


def test_library_checks_counts_and_workers_with_scheduler(tmp_path):
    scans = _write_scans(tmp_path / "scans", n=1, broken=False)
    with pytest.raises(InputError, match=r"workers: expected an integer >= 1, got 0"):
        run_batch([str(scans[0])], tmp_path / "out", workers=0)
    with pytest.raises(InputError, match=r"threads_per_worker: expected an integer >= 1"):
        run_batch([str(scans[0])], tmp_path / "out", threads_per_worker=0)
    with pytest.raises(InputError, match=r"workers: the cluster at the scheduler address"):
        run_batch([str(scans[0])], tmp_path / "out", workers=2, scheduler="tcp://h:8786")
    with pytest.raises(InputError, match=r"seed: expected an integer >= 0, got -1"):
        run_batch([str(scans[0])], tmp_path / "out", seed=-1)
    with pytest.raises(InputError, match=r"no inputs given"):
        collect_inputs([])
    assert not (tmp_path / "out").exists()


def test_collect_inputs_reads_lists_and_drops_repeats(tmp_path):
    scans = _write_scans(tmp_path / "scans", n=3, broken=False)
    listing = tmp_path / "todo.txt"
    listing.write_text("# today\nscans/scan1.ply\n\nscans/scan0.ply  # again below\n")
    got = collect_inputs([f"@{listing}", str(tmp_path / "scans" / "*.ply")])
    assert [p.name for p in got] == ["scan1.ply", "scan0.ply", "scan2.ply"]
    assert {p.resolve() for p in got} == {p.resolve() for p in scans}


# --------------------------------------------------------------------------- one scan


def _job(scan: Path, out: Path, **changes) -> dict:
    job = {"name": scan.stem, "input": os.fspath(scan), "out_dir": os.fspath(out),
           "config": _tiny().to_dict(), "domain": get_domain("free").to_dict(), "seed": 0,
           "device": "cpu", "boundary": False, "reconstruct": False, "target_vertices": 100,
           "threads": 1}
    job.update(changes)
    return job


def test_map_scan_discards_a_stale_checkpoint(tmp_path):
    (scan,) = _write_scans(tmp_path / "scans", n=1, broken=False)
    out = tmp_path / "out"
    out.mkdir()
    paths = scan_paths(out, "scan0")
    # A checkpoint of another seed (stopped after its first stage) is discarded, not an
    # error. The disk: a bounded domain always trains the networks in stages.
    cloud = read_points(scan)
    paths["checkpoint"].parent.mkdir()

    def stop(record, uv):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        parametrize(cloud.points, "disk", config=_tiny(), seed=5,
                    checkpoint=paths["checkpoint"], progress=False, on_stage=stop)
    assert paths["checkpoint"].is_file()

    disk = get_domain("disk").to_dict()
    row = map_scan(_job(scan, out, domain=disk))
    assert row["status"] == "ok" and row["error"] == "" and row["resumed"] == "no"
    assert row["points"] == len(cloud.points) and row["flipped"] is not None
    assert not paths["checkpoint"].exists()
    result = ParamResult.load(paths["map"])
    assert (result.seed, result.fingerprint) == (0, fingerprint(cloud.points))
    assert result.domain.to_dict() == disk
    assert map_scan(_job(scan, out, domain=disk))["status"] == "skipped"


def test_map_scan_reuses_an_up_to_date_map_for_a_missing_output(tmp_path):
    (scan,) = _write_scans(tmp_path / "scans", n=1, broken=False)
    paths = scan_paths(tmp_path, "scan0")
    assert map_scan(_job(scan, tmp_path, boundary=True))["status"] == "ok"
    assert paths["loops"].is_file()
    before = paths["map"].stat().st_mtime_ns
    assert map_scan(_job(scan, tmp_path, boundary=True))["status"] == "skipped"
    paths["loops"].unlink()
    row = map_scan(_job(scan, tmp_path, boundary=True))
    assert row["status"] == "ok" and paths["loops"].is_file()
    assert paths["map"].stat().st_mtime_ns == before  # not retrained
    # Another seed is another map: remade.
    assert map_scan(_job(scan, tmp_path, seed=1))["status"] == "ok"
    assert ParamResult.load(paths["map"]).seed == 1


def test_map_scan_reports_bad_input_in_its_row(tmp_path):
    bad = tmp_path / "bad.xyz"
    bad.write_text("1 2 3\n")
    row = map_scan(_job(bad, tmp_path))
    assert row["status"] == "error"
    assert row["error"] == f"{bad}: 1 points, need at least 10"
    assert set(row) == {*SUMMARY_COLUMNS, "warnings"} and row["warnings"] == []


def test_map_scan_returns_its_warnings_in_one_line_each(tmp_path):
    """A worker's warnings go back in the row (issue 39: raw UserWarning lines on the
    workers' stderr), once each."""
    V, _ = peaks_surface("peaks3", n_side=12)
    scan = tmp_path / "rgb.xyz"
    np.savetxt(scan, np.column_stack([V, np.tile([10.0, 200.0, 30.0], (len(V), 1))]))
    row = map_scan(_job(scan, tmp_path))
    assert row["status"] == "ok"
    assert [w for w in row["warnings"] if "columns 4-6" in w] == [
        f"{scan}: columns 4-6 are not unit vectors (lengths 202 to 202), so not read as "
        "normals; name them in a header row (x y z nx ny nz) to use them"]


def test_unreachable_scheduler_exits_2_and_leaves_no_folder(tmp_path, capsys, monkeypatch):
    """Issue 39: exit 1 and a folder holding a header-only summary.csv before."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(batch_app, "CONNECT_TIMEOUT", "1s")
    _write_scans(tmp_path / "scans", n=1, broken=False)
    with socket.socket() as sock:  # a port nobody listens on
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    assert_cli_fails(capsys, ["batch", "scans/*", "--out", "maps", "--scheduler",
                              f"tcp://127.0.0.1:{port}"],
                     f"cannot connect to the Dask scheduler at tcp://127.0.0.1:{port} (")
    assert not Path("maps").exists()
    with pytest.raises(InputError, match=r"cannot connect to the Dask scheduler at "
                                         r"tcp://127\.0\.0\.1:\d+ \(.*\); is it running, and "
                                         r"is the address right\?"):
        run_batch(["scans/*"], "maps", scheduler=f"tcp://127.0.0.1:{port}")
    assert not Path("maps").exists()


# --------------------------------------------------------------------------- clusters


@pytest.mark.slow
def test_batch_on_two_workers_then_a_rerun_does_no_work(tmp_path, capsys, monkeypatch, tiny):
    monkeypatch.chdir(tmp_path)
    _write_scans(tmp_path / "scans")
    argv = ["batch", "scans/*", "--out", "maps", "--workers", "2", "--boundary"]
    assert cli.main(argv) == 1
    out, err = capsys.readouterr()
    assert "4 mapped, 0 up to date, 1 failed" in out
    assert err.count("Dask dashboard at http") == 1

    maps = Path("maps")
    rows = {row["name"]: row for row in _summary(maps)}
    assert sorted(rows) == ["broken", "scan0", "scan1", "scan2", "scan3"]
    assert rows["broken"]["status"] == "error"
    assert rows["broken"]["error"] == "scans/broken.xyz: 3 points, need at least 10"
    workers = set()
    for k in range(4):
        row = rows[f"scan{k}"]
        assert row["status"] == "ok" and row["points"] == "324" and row["error"] == ""
        assert float(row["angle_distortion_rad"]) >= 0 and int(row["flipped"]) >= 0
        result = ParamResult.load(maps / f"scan{k}_uv.npz", n_points=324)
        assert result.config == _tiny() and result.seed == 0
        assert (maps / f"scan{k}_loops.json").is_file()
        workers.add(row["worker"])
    assert len(workers) == 2  # both workers mapped scans
    assert not (maps / ".checkpoints").exists()

    # The rerun starts no cluster, rewrites no map, and still reports the broken scan.
    def forbidden(*args, **kwargs):
        raise AssertionError("the rerun started a cluster")

    monkeypatch.setattr(batch_app, "_connect", forbidden)
    before = _mtimes(maps)
    assert cli.main([*argv, "--json"]) == 1
    out, err = capsys.readouterr()
    report = json.loads(out)
    assert (report["n_ok"], report["n_skipped"], report["n_error"]) == (0, 4, 1)
    assert report["dashboard"] is None
    assert _mtimes(maps) == before
    assert [r["status"] for r in _summary(maps)].count("skipped") == 4


class FaultyWorkers(WorkerPlugin):
    """Worker plugin injecting two faults, in every worker process (restarted ones too):

    - the first stage checkpoint written on any worker kills that worker's process (claimed
      once through the file ``marker``, which records the scan);
    - reading the scan ``flaky`` raises ``OSError`` on every attempt (one line per attempt
      in ``attempts``).

    Every map saved is appended to ``log``.
    """

    name = "pcgeom-faulty-workers"

    def __init__(self, marker: str, attempts: str, log: str):
        self.marker, self.attempts, self.log = marker, attempts, log

    def setup(self, worker):
        import pcgeom.apps.batch as batch
        import pcgeom.maps.run as run
        from pcgeom.io import ParamResult as Result

        marker, attempts, log = self.marker, self.attempts, self.log
        save_checkpoint, save, read = run.save_checkpoint, Result.save, batch.read_points

        def save_then_die(path, state):
            save_checkpoint(path, state)
            try:
                fd = os.open(marker, os.O_WRONLY | os.O_CREAT | os.O_EXCL)
            except FileExistsError:
                return
            os.write(fd, Path(path).stem.encode())
            os.close(fd)
            os.kill(os.getpid(), signal.SIGKILL)

        def save_and_log(result, path):
            written = save(result, path)
            with open(log, "a", encoding="utf-8") as f:
                f.write(Path(path).name + "\n")
            return written

        def read_or_fail(path, *args, **kwargs):
            if Path(path).stem == "flaky":
                with open(attempts, "a", encoding="utf-8") as f:
                    f.write("attempt\n")
                raise OSError("the disk went away")
            return read(path, *args, **kwargs)

        run.save_checkpoint = save_then_die
        Result.save = save_and_log
        batch.read_points = read_or_fail


@pytest.mark.slow
def test_killed_worker_resumes_and_every_map_is_written_once(tmp_path):
    from distributed import Client, LocalCluster

    scans = _write_scans(tmp_path / "scans", n=3, broken=False)
    _write_scans(tmp_path / "more", n=1, broken=False)[0].rename(tmp_path / "scans" / "flaky.ply")
    marker, attempts, log = tmp_path / "killed", tmp_path / "attempts", tmp_path / "saved.log"
    out = tmp_path / "maps"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        client.register_plugin(FaultyWorkers(*map(os.fspath, (marker, attempts, log))))
        # The disk: a bounded domain always trains the networks in stages, with checkpoints.
        report = run_batch([os.fspath(tmp_path / "scans" / "*.ply")], out, domain="disk",
                           config=_tiny(), scheduler=cluster.scheduler_address, retries=2,
                           progress=False)
    killed = marker.read_text()
    assert killed in {p.stem for p in scans}
    assert report.counts == {"ok": 3, "skipped": 0, "error": 1}
    rows = {row["name"]: row for row in report.rows}
    assert rows[killed]["resumed"] == "yes"  # it went on from its first stage's checkpoint
    assert sorted(log.read_text().split()) == sorted(f"{p.stem}_uv.npz" for p in scans)
    for scan in scans:
        ParamResult.load(out / f"{scan.stem}_uv.npz", n_points=324)
    # Not bad input: Dask tried it 1 + retries times, and the row holds the last error.
    assert rows["flaky"]["error"] == "OSError: the disk went away"
    assert attempts.read_text().count("attempt") == 3
    assert not (out / "flaky_uv.npz").exists()
    assert sorted(r["name"] for r in _summary(out)) == sorted([*(p.stem for p in scans), "flaky"])


def test_batch_reconstructs_in_worker_threads(tmp_path, capfd, monkeypatch, tiny):
    """gmsh meshes inside a Dask worker's thread (issue 39: it installed a SIGINT handler
    there, "signal only works in main thread"); one worker process with two threads meshes
    two scans at once, serialised by the mesher's lock. The scans' warnings come back as one
    'pcgeom: warning: NAME: ...' line each, none with --quiet, never raw UserWarning lines."""
    monkeypatch.chdir(tmp_path)
    _write_scans(tmp_path / "scans", n=1, broken=False)
    V = read_points(tmp_path / "scans" / "scan0.ply").points * 1.05
    np.savetxt(tmp_path / "scans" / "rgb.xyz",  # colours, not normals: one warning
               np.column_stack([V, np.tile([10.0, 200.0, 30.0], (len(V), 1))]))
    argv = ["batch", "scans/*", "--out", "maps", "--workers", "1", "--threads-per-worker", "2",
            "--reconstruct", "--target-vertices", "150"]
    assert cli.main([*argv, "--quiet", "--json"]) == 0
    out, err = capfd.readouterr()  # the worker processes' stderr too
    report = json.loads(out)
    assert (report["n_ok"], report["n_error"]) == (2, 0)
    for name in ("scan0", "rgb"):
        mesh = read_points(Path("maps") / f"{name}_mesh.ply")
        assert 75 <= len(mesh.points) <= 300
    assert "UserWarning" not in err and "pcgeom: warning" not in err

    Path("maps/rgb_mesh.ply").unlink()  # the rerun meshes rgb again, not quiet
    assert cli.main(argv) == 0
    err = capfd.readouterr().err
    assert "UserWarning" not in err
    assert [ln for ln in err.splitlines() if "columns 4-6" in ln] == [
        "pcgeom: warning: rgb: scans/rgb.xyz: columns 4-6 are not unit vectors (lengths 202 to "
        "202), so not read as normals; name them in a header row (x y z nx ny nz) to use them"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def dask_processes(tmp_path):
    """A ``dask scheduler`` and two ``dask worker`` processes, started as a user starts them
    (the CLI, each its own process); the scheduler's address. Stopped after the test."""
    import subprocess
    import sys
    import time

    from distributed import Client

    address = f"tcp://127.0.0.1:{_free_port()}"
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    common = ["--no-dashboard"]
    procs = [subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1",
                               "--port", address.rsplit(":", 1)[1], *common],
                              cwd=tmp_path, env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)]
    try:
        for k in range(2):
            procs.append(subprocess.Popen(
                [sys.executable, "-m", "dask", "worker", address, "--nthreads", "1",
                 "--name", f"w{k}", "--local-directory", str(tmp_path / f"w{k}"), *common],
                cwd=tmp_path, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        deadline = time.monotonic() + 60
        with Client(address, timeout=60) as client:
            while len(client.scheduler_info()["workers"]) < 2:
                assert time.monotonic() < deadline, "the dask workers did not start"
                time.sleep(0.2)
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()


def test_batch_boundary_and_reconstruct_on_a_dask_scheduler_with_two_worker_processes(
        tmp_path, capsys, monkeypatch, tiny, dask_processes):
    """Issue 39: on a cluster started as ``dask scheduler`` plus ``dask worker`` processes,
    ``--boundary --reconstruct`` wrote the maps and loops but gmsh failed in the workers'
    threads ("signal only works in main thread"); every scan's map, loops and mesh are
    written and the batch exits 0."""
    monkeypatch.chdir(tmp_path)
    _write_scans(tmp_path / "scans", n=2, broken=False)
    argv = ["batch", "scans/*", "--out", "maps", "--scheduler", dask_processes, "--boundary",
            "--reconstruct", "--target-vertices", "150", "--json", "--quiet"]
    assert cli.main(argv) == 0
    report = json.loads(capsys.readouterr().out)
    assert (report["n_ok"], report["n_error"]) == (2, 0)
    rows = _summary(Path("maps"))
    assert sorted(r["name"] for r in rows) == ["scan0", "scan1"]
    assert all(r["status"] == "ok" and r["error"] == "" for r in rows)
    for k in range(2):
        assert ParamResult.load(Path("maps") / f"scan{k}_uv.npz", n_points=324).seed == 0
        loops = json.loads((Path("maps") / f"scan{k}_loops.json").read_text())
        assert loops  # the loops file holds the report
        mesh = read_points(Path("maps") / f"scan{k}_mesh.ply")
        assert 75 <= len(mesh.points) <= 300 and mesh.faces is not None and len(mesh.faces)
