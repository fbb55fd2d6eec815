"""Golden files per stage: program -> AST dump -> FSM JSON -> dry-run trace.

Every program in ``programs/`` and ``tests/programs/`` is parsed, checked and compiled; the AST
dump and the FSM JSON are compared with ``tests/golden/NAME.ast.txt`` and ``NAME.fsm.json``.
Programs that run on the scripted world (a sibling ``NAME.world.yaml`` script, or none needed)
are also run on the dry back end and their trace compared with ``NAME.trace.txt``.

Regenerate after an intended change:  ``HILA_UPDATE_GOLDEN=1 pytest tests/test_lang_golden.py``
(then review the diff).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from hila_lang.language import load_program
from hila_lang.language.ast import dump
from hila_lang.robot.dry import make_backend
from hila_lang.plugins.options import RunOptions
from hila_lang.engine.interpreter import Interpreter
from hila_lang.language.source import read_source
from hila_lang.worlds.scripted.world import ScriptedWorld, load_script
from hila_lang.language.transformer import parse_program

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = ROOT / "tests" / "golden"
PROGRAMS = sorted((ROOT / "programs").glob("*.hila")) + sorted((ROOT / "tests" / "programs").glob("*.hila"))
UPDATE = os.environ.get("HILA_UPDATE_GOLDEN") == "1"


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def compare(name: str, text: str) -> None:
    target = GOLDEN / name
    if UPDATE:
        GOLDEN.mkdir(parents=True, exist_ok=True)
        target.write_text(text, encoding="utf-8")
        return
    assert target.is_file(), f"missing golden file {target}; run with HILA_UPDATE_GOLDEN=1"
    expected = target.read_text(encoding="utf-8")
    assert text == expected, f"{name} differs from the golden file (HILA_UPDATE_GOLDEN=1 to accept)"


@pytest.fixture(autouse=True)
def _in_root(monkeypatch):
    monkeypatch.chdir(ROOT)  # file names in the goldens are relative to the checkout


@pytest.mark.parametrize("program", PROGRAMS, ids=lambda p: p.stem)
def test_ast_golden(program):
    ast = parse_program(read_source(_rel(program)), _rel(program))
    compare(f"{program.stem}.ast.txt", dump(ast.items) + "\n")


@pytest.mark.parametrize("program", PROGRAMS, ids=lambda p: p.stem)
def test_fsm_golden(program):
    _, fsm = load_program(_rel(program))
    text = fsm.to_json()
    doc = json.loads(text)
    assert doc["start"] in {s["name"] for s in doc["states"]}
    names = {s["name"] for s in doc["states"]}
    for s in doc["states"]:  # every transition lands on a state
        for key in ("next", "then", "orelse"):
            if s.get(key) is not None:
                assert s[key] in names, f"{s['name']}.{key} -> {s[key]} is not a state"
    compare(f"{program.stem}.fsm.json", text)


def _scripted(program: Path):
    script = program.with_name(program.stem + ".world.yaml")
    return load_script(script) if script.is_file() else ScriptedWorld()


RUNNABLE = [p for p in PROGRAMS if load_program(p)[1].world == "scripted"]


@pytest.mark.parametrize("program", RUNNABLE, ids=lambda p: p.stem)
def test_dry_trace_golden(program):
    checked, fsm = load_program(_rel(program))
    world = _scripted(program)
    interp = Interpreter(checked, fsm, world, make_backend(world.scene, RunOptions(), {}))
    trace = interp.run(max_steps=10_000)
    assert interp.done, "the program did not finish in 10000 steps"
    runs = [t for t in trace if t.kind == "run"]
    assert runs, "a dry run should execute at least one run state"
    for t in runs:  # the hand follows each path exactly and each path starts where the hand was
        assert t.executed is not None and (t.executed == t.path).all()
    for before, after in zip(runs, runs[1:]):
        if "start" in after.icps:
            assert abs(after.path[0] - before.path[-1]).max() < 1e-9
    done = [e for e, _ in world.log if e == "state_done"]
    assert len(done) == len(runs)
    compare(f"{program.stem}.trace.txt", "\n".join(str(t) for t in trace) + "\n")
