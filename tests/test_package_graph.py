"""The package graph stays acyclic: no moonbot package (a folder under moonbot/, or a module
beside them) imports, directly or through others, a package that imports it back; nor does any
module inside a package. Every import counts, a function's deferred one too: deferring an import
hides a cycle from Python, not from the design. Read from the source with `ast`, nothing
imported."""

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


def dependency_graph(paths, unit_of_path, dependencies) -> dict[str, dict[str, str]]:
    """unit → {unit it depends on: one place that does, "file:line"} over the source files
    `paths`: each belongs to unit_of_path(path) and depends on the (unit, line) pairs
    dependencies(path) names; a unit's dependency on itself is left out."""
    graph: dict[str, dict[str, str]] = {}
    for path in sorted(paths):
        unit = unit_of_path(path)
        graph.setdefault(unit, {})
        for target, line in dependencies(path):
            if target != unit:
                graph[unit].setdefault(target, f"{path.relative_to(ROOT.parent)}:{line}")
    return graph


def package_graph() -> dict[str, dict[str, str]]:
    """unit → {unit it imports: one place that does, "file:line"}."""
    return dependency_graph(ROOT.rglob("*.py"), unit_of, imports)


def find_cycle(graph: dict[str, dict[str, str]]) -> list[str] | None:
    """One cycle of units (first repeated at the end), or None."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(unit: str) -> list[str] | None:
        state[unit] = 1
        path.append(unit)
        for target in sorted(graph.get(unit, {})):
            if state.get(target) == 1:
                return path[path.index(target) :] + [target]
            if target not in state and (cycle := visit(target)):
                return cycle
        path.pop()
        state[unit] = 2
        return None

    for unit in sorted(graph):
        if unit not in state and (cycle := visit(unit)):
            return cycle
    return None


def assert_no_cycle(graph: dict[str, dict[str, str]], what: str) -> None:
    """Fails with `what`, one cycle of `graph` and where each of its edges is, if it has one."""
    cycle = find_cycle(graph)
    where = [f"{a} -> {b} ({graph[a][b]})" for a, b in zip(cycle, cycle[1:])] if cycle else []
    assert cycle is None, f"{what}: " + "; ".join(where)


def module_name(path: Path) -> str:
    """moonbot.a.b for moonbot/a/b.py, moonbot.a for moonbot/a/__init__.py."""
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def module_graph() -> dict[str, dict[str, str]]:
    """module → {module it imports: "file:line"}. `from moonbot.a import b` names the module
    moonbot.a.b where there is one, else moonbot.a (its __init__)."""
    paths = {module_name(p): p for p in sorted(ROOT.rglob("*.py"))}
    graph: dict[str, dict[str, str]] = {}
    for module, path in paths.items():
        edges = graph.setdefault(module, {})
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names if a.name in paths]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module in paths:
                targets = [
                    f"{node.module}.{a.name}" if f"{node.module}.{a.name}" in paths else node.module for a in node.names
                ]
            for target in targets:
                if target != module:
                    edges.setdefault(target, f"{path.relative_to(ROOT.parent)}:{node.lineno}")
    return graph


def test_the_package_graph_has_no_cycle():
    graph = package_graph()
    assert_no_cycle(graph, "import cycle between packages")


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


def test_no_module_imports_itself_back():
    """Inside a package too: a module that imports another that imports it back is one concept
    in two files (or two concepts that want a third home)."""
    graph = module_graph()
    assert_no_cycle(graph, "import cycle between modules")
    assert "moonbot.eval.matching" in graph["moonbot.eval.report"]  # the graph sees what it should


# --- the C++ core ------------------------------------------------------------------------------
# The same rule for cpp/: a module is a public header under cpp/include/moonbot/, a header internal
# to the core under cpp/src/, and the source under cpp/src/, all of one name (any may be alone).
# It depends on every module whose header one of its files includes ("moonbot/<name>.h", or
# "<name>.h" for an internal one). Read from the source text, nothing compiled.

CPP = ROOT.parent / "cpp"


def cpp_includes(path: Path) -> list[tuple[str, int]]:
    """(module included, line) for every #include of a core header in the file."""
    found = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        text = line.strip()
        if not text.startswith('#include "'):
            continue
        header = text.split('"')[1]  # a comment may follow the closing quote
        if not header.endswith(".h"):
            continue
        if header.startswith("moonbot/"):
            found.append((header[len("moonbot/") : -len(".h")], number))
        elif (CPP / "src" / header).is_file():
            found.append((header[: -len(".h")], number))
    return found


def cpp_module_graph() -> dict[str, dict[str, str]]:
    """C++ module → {module whose header it includes: one place that does, "file:line"}."""
    paths = [*(CPP / "include" / "moonbot").glob("*.h"), *(CPP / "src").glob("*.[ch]*")]
    return dependency_graph(paths, lambda path: path.stem, cpp_includes)


def test_the_cpp_core_has_no_include_cycle():
    graph = cpp_module_graph()
    assert_no_cycle(graph, "include cycle between C++ modules")


def test_the_cpp_graph_sees_the_core():
    """The C++ graph holds the modules and edges it should, internal headers included; the DEM
    modules reach their I/O error through io_error.h, not through the image module."""
    graph = cpp_module_graph()
    assert {"render", "scene", "accel", "rays", "image", "io_error", "tiff_reader", "dem_raster"} <= set(graph)
    assert "tiff_reader" in graph["dem_raster"] and "io_error" in graph["image"] and "accel" in graph["rays"]
    dem_modules = ["tiff_reader", "geotiff", "dem_georef", "dem_raster", "void_fill", "dem_import"]
    assert all("image" not in graph[m] for m in dem_modules)
