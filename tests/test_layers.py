"""Layers that only point down, read from the source: every import, at module level or inside a
function (a lazy import is an arrow too), except ``if TYPE_CHECKING:`` blocks.

- nothing under ``robot/``, ``perception/``, ``osila/``, ``language/`` (nor anything else below a
  world: only ``commands/``, ``studio/`` (a front end, beside the commands) and ``worlds/`` themselves) imports from ``worlds/``;
- the robot knows no game: nothing under ``robot/`` or ``sim/`` names a grid, a cell or the
  tic-tac-toe world (a calibration chessboard is no game board);
- no import cycle between modules of the package;
- no module imports a ``_private`` name from another package (a package's face is its public names);
- at most five loose modules at the top of ``hila_lang/`` besides ``__init__``, ``__main__`` and
  ``cli``: the folders are the floors.

Imports made through ``importlib`` count too: a string constant naming a module of the package
(``"hila_lang.worlds.scripted.world:make_world"``, a plug-in's factory) is an arrow from the module
that holds it (unless it names one of the holder's own modules); ``cli``'s ``COMMANDS`` table is an arrow from ``cli`` to each command module; the
entry points of ``pyproject.toml`` (worlds, back ends) are arrows from ``cli``, the top, for whom
the registry loads them -- so a world that imported ``cli`` would close a loop.
"""

from __future__ import annotations

import ast
import re
import tomllib
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
    out |= _dynamic(name, tree)
    return {m for m in out if m in MODULES and m != name}


_NAMED = re.compile(r"^(hila_lang(?:\.\w+)+)(?::[\w.]+)?$")


def _dynamic(name: str, tree: ast.AST) -> set[str]:
    """What module ``name`` imports through importlib: strings that name a module of the package
    (``"pkg.mod"`` or ``"pkg.mod:attr"``), ``cli``'s COMMANDS table and pyproject's entry points."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            match = _NAMED.match(node.value.strip())
            # a package naming one of its own modules to load later (a plug-in's factory) stays on
            # its floor: Python imports the package before the module anyway
            if match and not match.group(1).startswith(name + "."):
                out.add(match.group(1))
    if name == "hila_lang.cli":
        for node in ast.walk(tree):
            if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "COMMANDS" for t in node.targets):
                out.update(f"hila_lang.commands.{v.value}" for v in node.value.values)
        project = tomllib.loads((PACKAGE.parent / "pyproject.toml").read_text())["project"]
        for group in project.get("entry-points", {}).values():
            out.update(target.partition(":")[0] for target in group.values())
    return out


GRAPH = {name: _imports(name) for name in MODULES}


def _under(name: str, *packages: str) -> bool:
    return any(name == f"hila_lang.{p}" or name.startswith(f"hila_lang.{p}.") for p in packages)


def test_the_import_reader_sees_lazy_and_relative_imports():
    assert "hila_lang.hierarchy.step" in GRAPH["hila_lang.engine.run"]  # lazy, relative
    assert "hila_lang.worlds.tictactoe.marks" in GRAPH["hila_lang.commands.snapshot"]  # lazy, two dots up
    assert "hila_lang.sim.camera" not in GRAPH["hila_lang.plugins.protocols"]  # TYPE_CHECKING only


def test_the_import_reader_sees_imports_made_through_importlib():
    cli = GRAPH["hila_lang.cli"]
    assert {"hila_lang.commands.exec_", "hila_lang.commands.lsp"} <= cli  # the COMMANDS table
    assert {"hila_lang.worlds.tictactoe", "hila_lang.robot"} <= cli  # pyproject's entry points
    factory = ast.parse('WORLD = make("hila_lang.robot.dry:DRY", "hila_lang.lsp.server")')
    assert _dynamic("hila_lang.worlds.x", factory) == {"hila_lang.robot.dry", "hila_lang.lsp.server"}
    assert _dynamic("hila_lang.robot", factory) == {"hila_lang.lsp.server"}  # its own module: its floor
    # a world that imported cli would close a loop the static imports alone do not show
    graph = {k: set(v) for k, v in GRAPH.items()}
    graph["hila_lang.worlds.tictactoe"].add("hila_lang.cli")
    assert _cycles(graph) != []


#: the modules that may sit loose at the top of hila_lang/ without counting
TOP_ALWAYS = {"__init__", "__main__", "cli"}


def test_the_top_of_the_package_has_at_most_five_loose_modules():
    loose = sorted(p.stem for p in PACKAGE.glob("*.py") if p.stem not in TOP_ALWAYS)
    assert len(loose) <= 5, f"loose modules at the top of hila_lang/: {loose}; give them a floor"
    assert "metrics" in loose  # docs/design.md §3's contract hila_lang.metrics stays where it is


def _package(name: str) -> str:
    return name if MODULES[name].name == "__init__.py" else name.rpartition(".")[0]


def _private_imports(name: str) -> list[str]:
    """``target.name`` for each ``_private`` name module ``name`` imports from another package."""
    path = MODULES[name]
    package = _package(name)
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if not isinstance(node, ast.ImportFrom):
            continue
        if node.level:
            base = package.split(".")
            target = ".".join(base[: len(base) - (node.level - 1)] + ([node.module] if node.module else []))
        else:
            target = node.module or ""
        if target not in MODULES:
            continue
        for a in node.names:
            private = a.name.startswith("_") and not a.name.startswith("__")
            if private and _package(target) != package:
                out.append(f"{target}.{a.name}")
    return out


def test_the_private_import_reader_sees_one(tmp_path, monkeypatch):
    monkeypatch.setitem(MODULES, "hila_lang.hierarchy.fake", tmp_path / "fake.py")
    (tmp_path / "fake.py").write_text("from ..osila import _pin, OPTIONS\nfrom .step import _fmt\n")
    assert _private_imports("hila_lang.hierarchy.fake") == ["hila_lang.osila._pin"]  # not its own package's _fmt


def test_no_module_imports_a_private_name_from_another_package():
    wrong = {name: found for name in MODULES if (found := _private_imports(name))}
    assert wrong == {}


def _floors() -> list[set[str]]:
    """The floors the package docstring lists, top first: sets of top-level names."""
    import hila_lang

    floors = []
    for line in hila_lang.__doc__.splitlines():
        names = re.findall(r"``(\w+)/?``", line.split("  ")[0]) if line.startswith("- ``") else []
        if names:
            floors.append(set(names))
    return floors


def test_the_package_docstring_lists_the_floors_and_no_import_runs_up_one():
    floors = _floors()
    top = {p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__"} | \
        {d.name for d in PACKAGE.iterdir() if (d / "__init__.py").is_file()}
    assert set().union(*floors) == top  # every module and folder at the top is on one floor
    rank = {name: i for i, floor in enumerate(floors) for name in floor}

    def floor(module):
        parts = module.split(".")
        return rank[parts[1]] if len(parts) > 1 else None

    up = sorted((a, b) for a, targets in GRAPH.items() for b in targets
                if floor(a) is not None and floor(b) is not None and floor(b) < floor(a))
    assert up == []


def test_every_package_docstring_names_its_modules():
    missing = {}
    for init in sorted(PACKAGE.rglob("__init__.py")):
        doc = ast.get_docstring(ast.parse(init.read_text())) or ""
        names = sorted({p.stem for p in init.parent.glob("*.py") if p.stem != "__init__"} |
                       {d.name for d in init.parent.iterdir() if (d / "__init__.py").is_file()})
        lost = [n for n in names if not re.search(rf"(?<![\w]){re.escape(n)}(?![\w])", doc)]
        if lost:
            missing[_module_name(init)] = lost
    assert missing == {}


def test_nothing_below_a_world_imports_a_world():
    wrong = {name: sorted(t for t in targets if _under(t, "worlds"))
             for name, targets in GRAPH.items()
             if not _under(name, "worlds", "commands", "studio", "cli")}
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


def test_no_front_end_or_world_imports_a_command():
    """Learning is a library function (``hierarchy/learn.py``): the studio and the worlds call it,
    not ``commands/``, whose modules only the CLI loads."""
    wrong = sorted((a, b) for a, targets in GRAPH.items() for b in targets
                   if _under(a, "studio", "worlds") and _under(b, "commands"))
    assert wrong == []
    assert any(_under(b, "hierarchy") for b in GRAPH["hila_lang.studio.save"])  # the reader saw its arrows (the save learns)


def test_every_import_inside_a_function_says_why_it_is_lazy():
    """Imports at the top (issue 31): one made inside a function stays there only with its reason, a
    ``# lazy: ...`` comment above its group (a package ``import M`` would otherwise load, an optional
    extra, a branch that alone needs it)."""
    missing = []
    for name, path in MODULES.items():
        text = path.read_text()
        lines = text.splitlines()
        tree = ast.parse(text)
        parent = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
        for node in ast.walk(tree):
            if not isinstance(node, (ast.Import, ast.ImportFrom)):
                continue
            up = parent.get(node)
            while up is not None and not isinstance(up, (ast.FunctionDef, ast.AsyncFunctionDef)):
                up = parent.get(up)
            if up is None or "# lazy" in lines[node.lineno - 1]:
                continue
            above = node.lineno - 2
            while above >= 0 and (not lines[above].strip() or _an_import_line(tree, above + 1)):
                above -= 1
            if not lines[above].strip().startswith("# lazy:"):
                missing.append(f"{name}:{node.lineno}")
    assert missing == [], "function-level imports without a '# lazy:' reason: " + ", ".join(missing)


def _an_import_line(tree: ast.Module, lineno: int) -> bool:
    return any(isinstance(n, (ast.Import, ast.ImportFrom)) and n.lineno <= lineno <= n.end_lineno
               for n in ast.walk(tree))
