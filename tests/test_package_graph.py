"""The package graph stays acyclic: no moonbot package (a folder under moonbot/, or a module
beside them) imports, directly or through others, a package that imports it back. Every import
counts, a function's deferred one too: deferring an import hides a cycle from Python, not from
the design. Read from the source with `ast`, nothing imported."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

pytestmark = pytest.mark.unit

ROOT = Path(__file__).resolve().parent.parent / "moonbot"
# The units an import can name: moonbot's folders and the modules beside them.
UNITS = {p.name if p.is_dir() else p.stem for p in ROOT.iterdir() if p.is_dir() or p.suffix == ".py"}


def unit_of(path: Path) -> str:
    """The package a source file belongs to: its folder under moonbot/, or its own module name."""
    parts = path.relative_to(ROOT).parts
    return parts[0] if len(parts) > 1 else path.stem


def imports(path: Path) -> list[tuple[str, int]]:
    """(moonbot unit imported, line) for every import in the file."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module] if node.module != "moonbot" else [f"moonbot.{a.name}" for a in node.names]
        for name in names:
            parts = name.split(".")
            if parts[0] == "moonbot" and len(parts) > 1 and parts[1] in UNITS:
                found.append((parts[1], node.lineno))
    return found


def package_graph() -> dict[str, dict[str, str]]:
    """unit → {unit it imports: one place that does, "file:line"}."""
    graph: dict[str, dict[str, str]] = {}
    for path in sorted(ROOT.rglob("*.py")):
        unit = unit_of(path)
        graph.setdefault(unit, {})
        for target, line in imports(path):
            if target != unit:
                graph[unit].setdefault(target, f"{path.relative_to(ROOT.parent)}:{line}")
    return graph


def find_cycle(graph: dict[str, dict[str, str]]) -> list[str] | None:
    """One cycle of units (first repeated at the end), or None."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(unit: str) -> list[str] | None:
        state[unit] = 1
        path.append(unit)
        for target in sorted(graph.get(unit, {})):
            if state.get(target) == 1:
                return path[path.index(target):] + [target]
            if target not in state and (cycle := visit(target)):
                return cycle
        path.pop()
        state[unit] = 2
        return None

    for unit in sorted(graph):
        if unit not in state and (cycle := visit(unit)):
            return cycle
    return None


def test_the_package_graph_has_no_cycle():
    graph = package_graph()
    cycle = find_cycle(graph)
    where = [f"{a} -> {b} ({graph[a][b]})" for a, b in zip(cycle, cycle[1:])] if cycle else []
    assert cycle is None, "import cycle between packages: " + "; ".join(where)


def test_a_cycle_is_found_and_named():
    """The check itself: a graph with a cycle through three units is caught, one without is not."""
    graph = {"a": {"b": "a.py:1"}, "b": {"c": "b.py:2"}, "c": {"a": "c.py:3"}, "d": {"a": "d.py:4"}}
    assert find_cycle(graph) == ["a", "b", "c", "a"]
    del graph["c"]["a"]
    assert find_cycle(graph) is None
    # The real graph has the packages it should and sees a deferred import.
    real = package_graph()
    assert {"bop", "export", "render", "scene", "pipeline", "sweep", "benchmark", "writer"} <= set(real)
    assert "bop" in real["export"]
