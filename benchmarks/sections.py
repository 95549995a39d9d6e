"""Marked sections of BENCHMARKS.md that one script writes and the others carry over.

A section runs from ``<!-- NAME: begin -->`` to ``<!-- NAME: end -->``. ``bench_param.py``
rewrites the file and carries every other script's section; ``bench_schedules.py``,
``gpu_section.py``, ``bench_apps.py``, ``bench_batch.py``, ``bench_scans.py`` and
``bench_domains.py`` replace only their own.
"""

from __future__ import annotations

from pathlib import Path

SECTIONS = ("bench_schedules", "gpu", "bench_apps", "bench_batch", "bench_scans",
            "bench_scans_large", "bench_domains")
"""Sections written by scripts other than bench_param.py, in file order."""


def markers(name: str) -> tuple[str, str]:
    return f"<!-- {name}: begin -->", f"<!-- {name}: end -->"


def find_section(text: str, name: str) -> str | None:
    """The section ``name`` of ``text``, markers included; None without them."""
    begin, end = markers(name)
    if begin in text and end in text:
        return text[text.index(begin): text.index(end) + len(end)]
    return None


def put_section(text: str, name: str, body: str) -> str:
    """``text`` with section ``name`` replaced by ``body`` (lines between the markers), or
    appended when absent."""
    begin, end = markers(name)
    section = f"{begin}\n{body.strip()}\n{end}"
    old = find_section(text, name)
    return text.replace(old, section) if old else text.rstrip("\n") + "\n\n" + section + "\n"


def carry_sections(old_text: str, new_text: str) -> str:
    """``new_text`` followed by every section of :data:`SECTIONS` found in ``old_text``."""
    kept = [s for s in (find_section(old_text, name) for name in SECTIONS) if s]
    return "\n\n".join([new_text.rstrip("\n"), *kept]) + "\n"


def write_section(path: Path, name: str, body: str) -> None:
    """Replace (or append) section ``name`` of the file at ``path``, atomically."""
    from pcgeom.io import write_atomic  # the caller has put this checkout on sys.path

    text = path.read_text(encoding="utf-8") if path.exists() else "# Benchmarks\n"
    text = put_section(text, name, body)
    write_atomic(path, lambda f: f.write(text.encode("utf-8")))
