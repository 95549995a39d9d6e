"""Progress: a bar on a terminal, a few lines in a log (pcgeom.progress)."""

import io

import pytest

from pcgeom import cli
from pcgeom.progress import Progress, log, on_terminal


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_log_gets_one_line_with_the_figures_when_the_task_ends():
    stream = io.StringIO()
    with Progress(1000, "refine", unit="step", stream=stream) as bar:
        for _ in range(1000):
            bar.update()
        bar.set_postfix({"leg": "0.001"})
        assert stream.getvalue() == ""  # nothing while it runs
    lines = stream.getvalue().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("pcgeom: refine: 1000/1000 step in ")
    assert lines[0].endswith(", leg 0.001")


def test_milestones_write_a_line_at_each_tenth_and_at_the_end():
    stream = io.StringIO()
    bar = Progress(40, "scans", unit="scan", initial=4, milestones=True, stream=stream)
    for _ in range(36):
        bar.update()
    bar.close()
    bar.close()  # a second close writes nothing
    lines = stream.getvalue().splitlines()
    assert [line.split(": ")[2].split(" ")[0] for line in lines] == [
        "8/40", "12/40", "16/40", "20/40", "24/40", "28/40", "32/40", "36/40", "40/40"]


def test_quiet_writes_nothing_and_a_terminal_gets_a_bar():
    stream = io.StringIO()
    with Progress(10, "x", enabled=False, stream=stream) as bar:
        bar.update(10)
        bar.write("hidden")
    log("hidden", enabled=False, stream=stream)
    assert stream.getvalue() == ""

    terminal = _Terminal()
    assert on_terminal(terminal) and not on_terminal(stream)
    bar = Progress(10, "x", stream=terminal)
    assert bar.bar is not None and not bar.logging
    bar.close()
    log("a terminal has the bars", stream=terminal)
    assert "a terminal has the bars" not in terminal.getvalue()


def test_param_into_a_log_leaves_a_few_lines(tmp_path, capsys):
    """`pcgeom param ... 2> log`: the start, each step's end, nothing of the bars' redraws."""
    pytest.importorskip("igl")
    out = tmp_path / "p.npz"
    assert cli.main(["param", "--example", "peaks3", "--domain", "disk", "--out",
                     str(out)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert 1 <= len(err) <= 4, err
    assert err[0] == "pcgeom: 5776 points onto disk: the disk map"
    assert all(line.startswith("pcgeom: ") and "\r" not in line for line in err)


def test_a_map_that_flips_gets_a_warning_line_with_the_count_and_where(tmp_path, capsys,
                                                                        monkeypatch):
    """Both measures: the cloud's local mesh (parametrize warns, any caller sees it) and the
    input's own triangles (pcgeom param, when the input has faces)."""
    pytest.importorskip("igl")
    import pcgeom.apps.evaluate as evaluate
    import pcgeom.cli.param as param_cli
    import pcgeom.maps.free as free

    monkeypatch.setattr(free, "mesh_flips", lambda X, mesh, U: {
        "count": 5, "faces": 100, "rim": 3, "hole": 0, "inside": 2})
    real = evaluate.map_report

    def flipped_report(*args, **kwargs):
        report = real(*args, **kwargs)
        return report | {"flipped": 7, "flipped_percent": 0.06,
                         "flipped_where": {"rim": 1, "hole": 2, "inside": 4}}

    monkeypatch.setattr(param_cli, "map_report", flipped_report)
    assert cli.main(["param", "--example", "peaks3", "--quiet", "--out",
                     str(tmp_path / "p.npz")]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err == [
        "pcgeom: warning: the map turns over 5 of the 100 triangles of the cloud's local mesh "
        "(5.00%: 3 on the rim, 0 near holes, 2 inside)",
        "pcgeom: warning: the map turns over 7 of the input's 11250 triangles (0.06%): 1 on the "
        "rim, 2 near holes, 4 inside"]
