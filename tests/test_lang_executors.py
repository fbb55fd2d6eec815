"""The engine finds a state's executor through the state's class (issue 21), not a string."""

import dataclasses
from pathlib import Path

import pytest

from hila_lang.language import fsm
from hila_lang.language.interpreter import EXECUTORS, Interpreter, executor

INTERPRETER = Path(__file__).resolve().parents[1] / "hila_lang" / "language" / "interpreter.py"


def _example(cls):
    fields = {f.name: None for f in dataclasses.fields(cls) if f.default is dataclasses.MISSING
              and f.default_factory is dataclasses.MISSING}
    return cls(**fields)


def test_every_state_class_has_its_own_executor():
    for kind, cls in fsm.STATE_KINDS.items():
        assert executor(_example(cls)) is EXECUTORS[cls], kind
    assert executor(_example(fsm.CallState)) is Interpreter.exec_call  # not its base's, no kind test
    assert executor(_example(fsm.SetState)) is Interpreter.exec_set


def test_a_subclass_without_an_executor_runs_its_bases_and_a_stranger_is_a_clear_error():
    @dataclasses.dataclass
    class Louder(fsm.WaitState):
        kind = ""  # no kind of its own: not registered in place of 'wait'

    assert executor(_example(Louder)) is Interpreter.exec_wait

    class Stranger:
        pass

    with pytest.raises(TypeError, match="no executor for the state class Stranger"):
        executor(Stranger())


def test_no_dispatch_through_a_string():
    assert 'getattr(self, "exec_"' not in INTERPRETER.read_text()
