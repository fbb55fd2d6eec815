"""Layers that only point down, read from the source: every import, at module level or inside a
function (a lazy import is an arrow too), except ``if TYPE_CHECKING:`` blocks.

- nothing under ``robot/``, ``perception/``, ``osila/``, ``language/`` (nor anything else below a
  world: only ``commands/``, ``studio/`` (a front end, beside the commands) and ``worlds/`` themselves) imports from ``worlds/``;
- the robot knows no game: nothing under ``robot/`` or ``sim/`` names a grid, a cell or the
  tic-tac-toe world (a calibration chessboard is no game board);
- no import cycle between modules of the package.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "hila_lang"


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


MODULES = {_module_name(p): p for p in PACKAGE.rglob("*.py")}


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _imports(name: str) -> set[str]:
    """Modules of the package that module ``name`` imports (resolved to existing modules)."""
    path = MODULES[name]
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    tree = ast.parse(path.read_text(), str(path))
    out: set[str] = set()

    def visit(node):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child):
                for sub in child.orelse:
                    visit(sub)
                continue
            if isinstance(child, ast.Import):
                out.update(a.name for a in child.names)
            elif isinstance(child, ast.ImportFrom):
                if child.level:
                    base = package.split(".")
                    base = base[: len(base) - (child.level - 1)]
                    target = ".".join(base + ([child.module] if child.module else []))
                else:
                    target = child.module or ""
                for a in child.names:  # "from X import Y": Y may be a module of X
                    out.add(f"{target}.{a.name}" if f"{target}.{a.name}" in MODULES else target)
            visit(child)

    visit(tree)
    return {m for m in out if m in MODULES and m != name}


GRAPH = {name: _imports(name) for name in MODULES}


def _under(name: str, *packages: str) -> bool:
    return any(name == f"hila_lang.{p}" or name.startswith(f"hila_lang.{p}.") for p in packages)


def test_the_import_reader_sees_lazy_and_relative_imports():
    assert "hila_lang.hierarchy.step" in GRAPH["hila_lang.language.interpreter"]  # lazy, relative
    assert "hila_lang.worlds.tictactoe.vision" in GRAPH["hila_lang.commands.learn"]
    assert "hila_lang.sim.camera" not in GRAPH["hila_lang.plugins.protocols"]  # TYPE_CHECKING only


def test_nothing_below_a_world_imports_a_world():
    wrong = {name: sorted(t for t in targets if _under(t, "worlds"))
             for name, targets in GRAPH.items() if not _under(name, "worlds", "commands", "studio")}
    wrong = {k: v for k, v in wrong.items() if v}
    assert wrong == {}
    for layer in ("robot", "perception", "osila", "language"):
        assert any(_under(n, layer) for n in GRAPH), layer  # the layers exist and were read


def test_the_robot_and_the_simulator_know_no_game():
    words = ("tictactoe", "grid", "cell", "board")
    for name, path in MODULES.items():
        if _under(name, "robot", "sim"):
            tree = ast.parse(path.read_text())
            identifiers = {n.id.lower() for n in ast.walk(tree) if isinstance(n, ast.Name)} | \
                {n.attr.lower() for n in ast.walk(tree) if isinstance(n, ast.Attribute)} | \
                {n.name.lower() for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
            hits = sorted(i for i in identifiers if any(w in i.replace("chessboard", "") for w in words))
            assert hits == [], f"{name} uses {hits}"


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan, iterative)."""
    index, low, on, stack, out = {}, {}, set(), [], []
    counter = 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on.add(root)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                    break
                if child in on:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    comp = []
                    while True:
                        m = stack.pop()
                        on.discard(m)
                        comp.append(m)
                        if m == node:
                            break
                    if len(comp) > 1:
                        out.append(sorted(comp))
    return out


def test_the_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycle_in_the_package():
    assert _cycles(GRAPH) == []
