"""House rules that the code itself can be held to (pcgeom/): no file over 800 lines, no
function with more than 6 positional parameters, the barrier map's modules importing one way."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "pcgeom"
MAX_LINES = 800
MAX_POSITIONAL = 6


def _sources():
    return sorted(PACKAGE.rglob("*.py"))


def _positional(tree: ast.AST) -> list[tuple[int, str, int]]:
    """(line, name, count) of every function with more than MAX_POSITIONAL positional
    parameters (a method's ``self`` or ``cls`` not counted)."""
    methods = {id(f) for node in ast.walk(tree) if isinstance(node, ast.ClassDef)
               for f in node.body if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef))}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            names = [a.arg for a in node.args.posonlyargs + node.args.args]
            if id(node) in methods and names[:1] in (["self"], ["cls"]):
                names = names[1:]
            if len(names) > MAX_POSITIONAL:
                found.append((node.lineno, getattr(node, "name", "lambda"), len(names)))
    return found


def test_the_checks_can_fail():
    bad = ast.parse("def f(a, b, c, d, e, f, g):\n    pass\n"
                    "class C:\n    def m(self, a, b, c, d, e, f, *, g):\n        pass\n")
    assert _positional(bad) == [(1, "f", 7)]
    assert _positional(ast.parse("lambda a, b, c, d, e, f, g: a")) == [(1, "lambda", 7)]


def test_no_function_takes_more_than_six_positional_parameters():
    offenders = [f"{path.relative_to(PACKAGE.parent)}:{line} {name} ({count})"
                 for path in _sources()
                 for line, name, count in _positional(ast.parse(path.read_text()))]
    assert not offenders, "more than 6 positional parameters (make the rest keyword-only): " \
        + ", ".join(offenders)


def test_no_file_is_over_800_lines():
    long = [f"{path.relative_to(PACKAGE.parent)} ({n})" for path in _sources()
            if (n := len(path.read_text().splitlines())) > MAX_LINES]
    assert not long, "files over 800 lines: " + ", ".join(long)


INJECTIVE = ["jacobians", "energies", "rings", "newton", "linesearch", "barrier", "untangle",
             "tutte", "clean", "loops", "landmarks", "map"]
"""The barrier map's modules, each importing only the ones before it."""


def test_the_barrier_map_imports_one_way():
    folder = PACKAGE / "maps" / "injective"
    assert sorted(p.stem for p in folder.glob("*.py")) == sorted(INJECTIVE + ["__init__"])
    for k, name in enumerate(INJECTIVE):
        tree = ast.parse((folder / f"{name}.py").read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.level == 1:
                assert node.module in INJECTIVE[:k], f"{name} imports .{node.module}"
            if isinstance(node, ast.ImportFrom) and node.level >= 2:
                # Nothing above the maps but the core (never pcgeom.maps' other modules' runs,
                # apps or cli).
                assert not (node.module or "").startswith(("apps", "cli", "run", "domain")), \
                    f"{name} imports {'.' * node.level}{node.module}"


def test_every_benchmarks_section_is_known_to_the_harness():
    """benchmarks/harness.py keeps the marked sections of BENCHMARKS.md it knows when
    bench_param.py rewrites the top; a section missing from its SECTIONS would be dropped."""
    import re

    root = PACKAGE.parent
    tree = ast.parse((root / "benchmarks" / "harness.py").read_text(encoding="utf-8"))
    sections = next(ast.literal_eval(node.value) for node in tree.body
                    if isinstance(node, ast.Assign)
                    and any(getattr(t, "id", None) == "SECTIONS" for t in node.targets))
    marked = re.findall(r"<!-- (\S+): begin -->",
                        (root / "BENCHMARKS.md").read_text(encoding="utf-8"))
    assert marked and not set(marked) - set(sections), set(marked) - set(sections)
    assert [s for s in sections if s in marked] == marked  # in file order


MAX_COLUMNS = 100


def test_no_line_of_the_package_is_over_100_columns():
    long = [f"{path.relative_to(PACKAGE.parent)}:{k}" for path in _sources()
            for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
            if len(line) > MAX_COLUMNS]
    assert not long, long
