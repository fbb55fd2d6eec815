"""The engine (issue 21): one executor object per state class, found through the state's class,
not a string; the evaluator works on a scene, not on the step loop."""

import dataclasses
from pathlib import Path

import pytest

from hila_lang.engine import executors as X
from hila_lang.engine.interpreter import Interpreter
from hila_lang.engine.run import RunExecutor
from hila_lang.engine.scene import Evaluator, Scene
from hila_lang.language import fsm
from hila_lang.language.transformer import parse_expr

ENGINE = Path(__file__).resolve().parents[1] / "hila_lang" / "engine"


def _example(cls):
    fields = {f.name: None for f in dataclasses.fields(cls) if f.default is dataclasses.MISSING
              and f.default_factory is dataclasses.MISSING}
    return cls(**fields)


def test_every_state_class_has_its_own_executor_class():
    seen = set()
    for kind, cls in fsm.STATE_KINDS.items():
        ex = X.executor(_example(cls))
        assert ex is X.EXECUTORS[cls] and issubclass(ex, X.Executor), kind
        seen.add(ex)
    assert len(seen) == len(fsm.STATE_KINDS)  # one each, none shared through a kind test
    assert X.executor(_example(fsm.RunState)) is RunExecutor
    assert issubclass(X.CallExecutor, X.SetExecutor)  # a call sets its parameters as a let does


def test_a_subclass_without_an_executor_runs_its_bases_and_a_stranger_is_a_clear_error():
    @dataclasses.dataclass
    class Louder(fsm.WaitState):
        kind = ""  # no kind of its own: not registered in place of 'wait'

    assert X.executor(_example(Louder)) is X.WaitExecutor

    class Stranger:
        pass

    with pytest.raises(TypeError, match="no executor for the state class Stranger"):
        X.executor(Stranger())


def test_no_dispatch_through_a_string_and_the_loop_holds_no_executor():
    loop = (ENGINE / "interpreter.py").read_text()
    assert 'getattr(self, "exec_"' not in loop
    assert "def exec_" not in loop and "visit_" not in loop  # executors and the evaluator live elsewhere
    assert len(loop.splitlines()) < 320


class _World:
    scene = None

    def __init__(self):
        self.asked = []

    def points(self):
        return {"cup": (0.3, 0.1, 0.7), "board.cell1": (0.2, 0.0, 0.6), "board.cell2": (0.25, 0.0, 0.6)}

    def query(self, name, *args):
        self.asked.append((name, args))
        return 7


class _Backend:
    def hand_position(self):
        return (0.1, 0.2, 0.3)


def test_the_evaluator_needs_only_a_scene():
    world = _World()
    scene = Scene(world, _Backend(), {"home": parse_expr("(1, 2, 3)")})
    assert isinstance(scene.evaluator, Evaluator)
    assert list(scene.eval(parse_expr("home + (1, 1, 1)"))) == [2, 3, 4]
    assert scene.eval(parse_expr("hand.z")) == pytest.approx(0.3)
    assert scene.eval(parse_expr("ask best_move + 1")) == 8 and world.asked == [("best_move", ())]
    assert scene.lookup("board") == "board"  # a group prefix
    assert [m for m, _ in scene.points_of(parse_expr("board"))] == ["board.cell1", "board.cell2"]
    from hila_lang.core.errors import HilaRuntimeError

    with pytest.raises(HilaRuntimeError, match="did you mean 'cup'"):
        scene.lookup("cupp")


def test_one_executor_object_per_class_in_a_run(tmp_path):
    from hila_lang.language import load_program
    from hila_lang.robot.dry import DryBackend
    from hila_lang.worlds.scripted.world import ScriptedWorld

    p = tmp_path / "x.hila"
    p.write_text("main {\n let a = 1\n let b = a + 1\n repeat 2 { let a = a + b }\n}\n")
    checked, machine = load_program(p)
    it = Interpreter(checked, machine, ScriptedWorld(), DryBackend((0.2, -0.25, 0.75)))
    made = []
    it.observers.append(lambda e: made.append(it.executor_for(it.fsm.states[e.state])))
    it.run()
    assert it.env["main:a"] == 5 and it.env["main:b"] == 2
    assert {type(x) for x in made} == {X.SetExecutor, X.BranchExecutor, X.EndExecutor}
    assert len({id(x) for x in made if type(x) is X.SetExecutor}) == 1  # the same object for every let
    assert set(it._executors) == {X.SetExecutor, X.BranchExecutor, X.EndExecutor}


def test_a_statement_class_needs_no_transformer_or_checker_code_of_its_own(tmp_path, monkeypatch):
    """A statement registered with ast.statement is built from its rule's children and checked
    generically (its expressions' names, its blocks), so a new keyword is grammar + ast + compiler."""
    from hila_lang.core.errors import CheckError
    from hila_lang.language import ast as A
    from hila_lang.language import transformer as T
    from hila_lang.language.checker import check
    from hila_lang.language.environment import Environment

    assert set(A.RULES) <= {n for n in dir(T.ToAst) if not n.startswith("_")}  # every rule has a builder
    assert A.STATEMENTS == tuple(A.RULES.values())

    @dataclasses.dataclass(frozen=True)
    class ShoutStmt:  # not registered: nothing global changes
        value: object
        body: tuple
        pos: A.Pos = A.NOPOS

    from lark import Token

    build = T._generic(ShoutStmt)
    node = build(None, type("M", (), {"empty": True})(), [Token("NAME", "x"), ()])
    assert node == ShoutStmt("x", ())  # a token becomes its text, fields in order

    env = Environment.default()
    program = env.parse("main {\n let a = 1\n}\n", str(tmp_path / "p.hila"))
    main = program.items[-1]
    stranger = ShoutStmt(A.Name(("nope",), A.Pos(2, 8)), (), A.Pos(2, 2))
    monkeypatch.setattr(A, "STATEMENTS", A.STATEMENTS + (ShoutStmt,))
    bad = A.Program(program.items[:-1] + (A.MainDef(main.body + (stranger,), main.pos),), program.file,
                    program.source)
    with pytest.raises(CheckError, match="'nope'"):
        check(bad)
