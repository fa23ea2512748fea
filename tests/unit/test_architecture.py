"""One way down (issue 18): the import graph of ``src/granflow``, read with :mod:`ast`.

* No cycle among the modules at module level. An import inside a function (or under
  ``if TYPE_CHECKING:``) is deferred: it runs after every module is loaded, so it cannot make
  an import cycle, and it is allowed -- but it is still a dependency, so the layering rule below
  counts it too.
* No upward import: the numerical core (grid, operators, solvers, physics, rheology, model, state,
  step, simulation, schedules) imports none of cases, casekit, cli, plotting, sweep -- at module level or in a function.
* ``granflow.config`` depends on nothing above it (not on cases, cli, plotting, sweep), nor does
  ``granflow.output`` (the writers and recorders a Simulation runs without the case runner).
* Sizes (issue 18): no function of ``src/granflow`` over :data:`MAX_FUNCTION_LINES` lines, no
  module over :data:`MAX_MODULE_LINES`.

The cycle detector and the layering check are tested on synthetic graphs, so they can fail.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest
from _scripts import ROOT  # the repository (tests/ holds tiers)

SRC = ROOT / "src" / "granflow"
CORE = ("grid", "operators", "strain_rate", "_strain_numba", "topography", "axisymmetric", "solvers", "physics", "rheology", "model", "model_geometry",
        "state", "step", "step_energy", "step_retry", "simulation", "active_set", "predictor",
        "schedules")
TOP = ("cases", "casekit", "cli", "plotting", "closure_figures", "case_figures", "sweep", "sweep_spec", "sweep_files")
MAX_FUNCTION_LINES = 80
"""Longest function or method [lines, from ``def`` to its last line; decorators not counted]."""
MAX_MODULE_LINES = 500
"""Longest module [lines]."""


def module_name(path: Path, root: Path = SRC) -> str:
    """``src/granflow/cases/runner.py`` -> ``granflow.cases.runner`` (a package is its __init__)."""
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def imports_of(tree: ast.Module, name: str, is_package: bool) -> tuple[set[str], set[str]]:
    """(module-level imports, deferred imports) of the ``granflow`` modules named in ``tree``.

    ``from a.b import c`` counts as an import of ``a.b`` and of ``a.b.c`` (``c`` may be a
    submodule; a name that is not a module is dropped later against the list of modules).
    """
    top: set[str] = set()
    deferred: set[str] = set()
    package = name if is_package else name.rpartition(".")[0]

    def targets(node) -> list[str]:
        if isinstance(node, ast.Import):
            return [a.name for a in node.names]
        base = node.module or ""
        if node.level:
            anchor = package.split(".")
            anchor = anchor[:len(anchor) - (node.level - 1)]
            base = ".".join(anchor + ([base] if base else []))
        return [base] + [f"{base}.{a.name}" for a in node.names]

    def visit(node, in_function: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.Import, ast.ImportFrom)):
                (deferred if in_function else top).update(
                    t for t in targets(child) if t.split(".")[0] == "granflow")
            elif isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                visit(child, True)
            elif isinstance(child, ast.If) and _is_type_checking(child):
                visit(child, True)
            else:
                visit(child, in_function)

    visit(tree, False)
    return top, deferred


def import_graph(root: Path = SRC) -> tuple[dict[str, set[str]], dict[str, set[str]]]:
    """(module-level graph, deferred graph): module -> the granflow modules it imports.

    Importing ``a.b.c`` also runs ``a/__init__`` and ``a/b/__init__``: those parents are edges too.
    """
    files = {module_name(p, root): p for p in sorted(root.rglob("*.py"))}
    top: dict[str, set[str]] = {}
    deferred: dict[str, set[str]] = {}
    for name, path in files.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        t, d = imports_of(tree, name, path.name == "__init__.py")
        for graph, found in ((top, t), (deferred, d)):
            edges = set()
            for target in found:
                parts = target.split(".")
                edges.update(".".join(parts[:i]) for i in range(1, len(parts) + 1))
            # a module's own package(s) are loaded before it: not an edge of the module
            graph[name] = {e for e in edges if e in files and not name.startswith(e + ".") and e != name}
    return top, deferred


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle ``[a, b, ..., a]`` of ``graph``, or None (iterative depth-first search)."""
    WHITE, GREY, BLACK = 0, 1, 2
    colour = dict.fromkeys(graph, WHITE)
    for start in sorted(graph):
        if colour[start] != WHITE:
            continue
        stack = [(start, iter(sorted(graph[start])))]
        path = [start]
        colour[start] = GREY
        while stack:
            node, children = stack[-1]
            for child in children:
                if colour.get(child, BLACK) == GREY:
                    return path[path.index(child):] + [child]
                if colour.get(child) == WHITE:
                    colour[child] = GREY
                    path.append(child)
                    stack.append((child, iter(sorted(graph.get(child, ())))))
                    break
            else:
                colour[node] = BLACK
                path.pop()
                stack.pop()
    return None


def _in(module: str, names: tuple[str, ...]) -> bool:
    return any(module == f"granflow.{n}" or module.startswith(f"granflow.{n}.") for n in names)


def upward_imports(graph: dict[str, set[str]], lower: tuple[str, ...], upper: tuple[str, ...]) -> list[str]:
    """``"a -> b"`` for every edge from a module of ``lower`` to a module of ``upper``."""
    return sorted(f"{a} -> {b}" for a, targets in graph.items() if _in(a, lower)
                  for b in targets if _in(b, upper))


def oversized(root: Path = SRC, max_function: int = MAX_FUNCTION_LINES, max_module: int = MAX_MODULE_LINES,
              allow: tuple[str, ...] = ()) -> list[str]:
    """``"module: N lines"`` and ``"module.function: N lines"`` over the limits, outside ``allow``."""
    found = []
    for path in sorted(root.rglob("*.py")):
        name = module_name(path, root)
        if name in allow:
            continue
        text = path.read_text(encoding="utf-8")
        if len(text.splitlines()) > max_module:
            found.append(f"{name}: {len(text.splitlines())} lines")
        for node in ast.walk(ast.parse(text, str(path))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = node.end_lineno - node.lineno + 1
                if length > max_function:
                    found.append(f"{name}.{node.name}: {length} lines")
    return found


# --- the detectors, on synthetic input --------------------------------------------------------
def test_find_cycle_finds_a_cycle_and_only_a_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"a"}}) == ["a", "a"]
    assert find_cycle({"a": {"b", "c"}, "b": {"c"}, "c": set(), "d": {"a", "zz"}}) is None


def test_upward_imports_flags_an_edge_from_the_core_to_the_top():
    graph = {"granflow.step": {"granflow.cases.runner", "granflow.grid"},
             "granflow.cases.runner": {"granflow.step"}, "granflow.stepper": {"granflow.cli"}}
    assert upward_imports(graph, CORE, TOP) == ["granflow.step -> granflow.cases.runner"]


def test_imports_of_separates_deferred_imports_and_resolves_relative_ones(tmp_path):
    code = ("from __future__ import annotations\nimport granflow.grid\nfrom . import step\n"
            "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from granflow.cli import x\n"
            "def f():\n    from granflow.cases import CASES\n")
    top, deferred = imports_of(ast.parse(code), "granflow.model", is_package=False)
    assert top == {"granflow.grid", "granflow", "granflow.step"}
    assert deferred == {"granflow.cli", "granflow.cli.x", "granflow.cases", "granflow.cases.CASES"}
    root = tmp_path / "granflow"
    (root / "sub").mkdir(parents=True)
    (root / "__init__.py").write_text("")
    (root / "sub" / "__init__.py").write_text("from granflow.sub import a\n")
    (root / "sub" / "a.py").write_text("from granflow.sub.b import g\n")
    (root / "sub" / "b.py").write_text("import granflow.sub.a\n")
    graph, _ = import_graph(root)
    assert find_cycle(graph) == ["granflow.sub.a", "granflow.sub.b", "granflow.sub.a"]


def test_oversized_flags_long_functions_and_modules_outside_the_allow_list(tmp_path):
    root = tmp_path / "granflow"
    root.mkdir()
    (root / "__init__.py").write_text("")
    body = "".join(f"    x{i} = {i}\n" for i in range(5))
    (root / "long.py").write_text("def f():\n" + body + "\n\ndef g():\n    pass\n")
    (root / "big.py").write_text("y = 0\n" * 12)
    (root / "exempt.py").write_text("def h():\n" + body + "y = 0\n" * 12)
    found = oversized(root, max_function=5, max_module=10, allow=("granflow.exempt",))
    assert found == ["granflow.big: 12 lines", "granflow.long.f: 6 lines"]
    assert oversized(root, max_function=6, max_module=18, allow=()) == []  # at the limits: not over


# --- the package ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def graphs():
    return import_graph()


def test_the_scan_sees_the_package(graphs):
    top, deferred = graphs
    assert len(top) > 50
    assert "granflow.grid" in top["granflow.model"]
    assert "granflow.casekit.runner" in top["granflow.cli.run"] | deferred["granflow.cli.run"]


def test_no_import_cycle_at_module_level(graphs):
    top, _ = graphs
    assert find_cycle(top) is None


@pytest.mark.parametrize("lower, upper", [(CORE, TOP), (("config",), TOP), (("output",), TOP)],
                         ids=["core", "config", "output"])
def test_no_upward_import(graphs, lower, upper):
    top, deferred = graphs
    merged = {m: top[m] | deferred[m] for m in top}
    assert upward_imports(merged, lower, upper) == []


def test_no_function_or_module_over_the_size_limits():
    assert oversized() == []
