"""The FSM is data that round-trips, and every AST pass walks the tree through one visitor.

- ``FSM.from_dict(fsm.to_dict()) == fsm`` for every program in ``programs/`` and
  ``tests/programs/``, through JSON text too, and the reloaded machine renders and runs the same;
- expression text (``expr_text``) parses back to the same expression (``parse_expr``) for
  hypothesis-generated expressions, slots and strings with braces included;
- one state class per kind, and a changed field makes the machines differ.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hila_lang.language import ast as A
from hila_lang.language import load_program
from hila_lang.language.fsm import FSM, STATE_KINDS, BranchState, RunState, State
from hila_lang.engine.interpreter import Interpreter
from hila_lang.language.transformer import parse_expr, parse_program

ROOT = Path(__file__).resolve().parent.parent
PROGRAMS = sorted((ROOT / "programs").glob("*.hila")) + sorted((ROOT / "tests" / "programs").glob("*.hila"))


@pytest.fixture(autouse=True)
def _in_root(monkeypatch):
    monkeypatch.chdir(ROOT)


@pytest.mark.parametrize("program", PROGRAMS, ids=lambda p: p.stem)
def test_fsm_round_trips_through_json(program):
    _, fsm = load_program(program.relative_to(ROOT).as_posix())
    again = FSM.from_dict(json.loads(fsm.to_json()))
    assert again == fsm
    assert [type(s) for s in again.states.values()] == [type(s) for s in fsm.states.values()]
    assert again.to_json() == fsm.to_json()
    assert again.to_text() == fsm.to_text()
    assert again.to_dot() == fsm.to_dot()


def test_a_changed_field_makes_machines_differ():
    _, fsm = load_program("programs/game.hila")
    d = fsm.to_dict()
    run = next(s for s in d["states"] if s["kind"] == "run")
    run["bindings"]["hand"] = "arm.park"
    assert FSM.from_dict(d) != fsm
    d = fsm.to_dict()
    next(s for s in d["states"] if s["kind"] == "branch")["column"] += 1
    assert FSM.from_dict(d) != fsm


def test_reloaded_machine_runs_the_same_trace():
    from hila_lang.robot.dry import DryBackend
    from hila_lang.worlds.scripted.world import ScriptedWorld

    checked, fsm = load_program("programs/abc.hila")
    again = FSM.from_dict(fsm.to_dict())
    traces = []
    for machine in (fsm, again):
        world = ScriptedWorld()
        interp = Interpreter(checked, machine, world, DryBackend((0.2, -0.28, 0.72)))
        traces.append([str(t) for t in interp.run()])
    assert traces[0] == traces[1] and len(traces[0]) > 5


def test_one_class_per_kind():
    assert set(STATE_KINDS) == {"run", "call", "set", "wait", "branch", "end"}
    for kind, cls in STATE_KINDS.items():
        assert cls.kind == kind and issubclass(cls, State)
    with pytest.raises(ValueError, match="hila_fsm: 1"):
        FSM.from_dict({"hila_fsm": 2})


def test_states_round_trip_one_by_one():
    run = RunState("main/a", 3, 5, "end", template="t", tag="a",
                   bindings=(("*", A.Name(("c",))), ("hand", A.NoneLit())), pen_down=True)
    assert State.from_dict(run.to_dict()) == run
    branch = BranchState("main/if#1", 2, 1, None, guard=A.Binary("and", A.Bool(True), A.Var("main:x", ("z",))),
                         then="a", orelse="b")
    assert State.from_dict(branch.to_dict()) == branch
    assert branch.successors() == ["a", "b"]


# --------------------------------------------------------------------------- expressions

NAMES = st.sampled_from(["c", "cell", "board", "tl", "x", "hand", "p_1"])
SLOTS = st.text(alphabet="abc/:#_0123456789.", min_size=1, max_size=12)
LEAVES = st.one_of(
    st.floats(allow_nan=False, allow_infinity=False, width=64).map(A.Number),
    st.text(alphabet="ab {}:/#.", max_size=6).map(A.String),
    st.booleans().map(A.Bool),
    st.just(A.NoneLit()),
    st.lists(NAMES, min_size=1, max_size=3).map(lambda p: A.Name(tuple(p))),
    st.tuples(SLOTS, st.lists(NAMES, max_size=2)).map(lambda t: A.Var(t[0], tuple(t[1]))),
)


def _extend(children):
    return st.one_of(
        st.tuples(st.sampled_from(["-", "not"]), children)
        .filter(lambda t: not (t[0] == "-" and isinstance(t[1], A.Number)))  # the parser folds -2 into a number
        .map(lambda t: A.Unary(*t)),
        st.tuples(st.sampled_from(sorted(A._BINARY_PREC)), children, children).map(lambda t: A.Binary(*t)),
        st.tuples(NAMES, st.lists(children, max_size=2)).map(lambda t: A.Ask(t[0], tuple(t[1]))),
        st.lists(children, min_size=2, max_size=3).map(lambda items: A.Vector(tuple(items))),
    )


EXPRS = st.recursive(LEAVES, _extend, max_leaves=12)


@pytest.mark.filterwarnings("ignore::hypothesis.errors.HypothesisWarning")
@settings(max_examples=300, deadline=None)
@given(EXPRS)
def test_expression_text_parses_back(e):
    assert parse_expr(A.expr_text(e)) == e


def test_comparisons_on_the_left_are_parenthesised():
    e = A.Binary("==", A.Binary("<", A.Name(("a",)), A.Number(1.0)), A.Bool(True))
    assert A.expr_text(e) == "(a < 1) == true"
    assert parse_expr("(a < 1) == true") == e


# --------------------------------------------------------------------------- the visitor

SOURCE = """
point home = (0.1, 0.2, 0.3)
task t(c) { let x = ask q(c) if x { wait e } else { repeat 2 { let y = 1 } } }
main { until ask done { t(home) } while false { } }
"""


def test_walk_visits_every_statement_in_source_order():
    program = parse_program(SOURCE, "<test>")
    task = program.of(A.TaskDef)[0]
    assert [type(s).__name__ for s in A.walk(task.body)] == ["LetStmt", "IfStmt", "WaitStmt", "RepeatStmt", "LetStmt"]


def test_visitor_dispatches_by_class_and_walks_children():
    program = parse_program(SOURCE, "<test>")

    class Asks(A.Visitor):
        def __init__(self):
            self.names = []

        def visit_Ask(self, e):
            self.names.append(e.name)
            self.generic_visit(e)

    v = Asks()
    v.visit(program)
    assert v.names == ["q", "done"]
    assert A.children(A.Binary("+", A.Number(1.0), A.Name(("a",)))) == [A.Number(1.0), A.Name(("a",))]
