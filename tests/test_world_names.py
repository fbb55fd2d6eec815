"""A world's names are declared once (issue 23 item 1, issue 21 item 4's world part): one table of
points, questions and events (name, arguments, doc, answering method) that the world answers
through, ``hila check`` checks by, ``hila show world`` prints and the language server reads."""

from __future__ import annotations

import inspect

import pytest

from hila_lang import cli
from hila_lang.core.errors import InputError, UnknownNameError
from hila_lang.plugins import registry
from hila_lang.plugins.names import Name, Names


@pytest.mark.parametrize("world, module", [("tictactoe", "hila_lang.worlds.tictactoe.world:TicTacToeWorld"),
                                           ("letters", "hila_lang.worlds.letters.world:LettersWorld")])
def test_every_declared_question_and_event_is_answered_by_a_method_with_its_arguments(world, module):
    import importlib

    mod, _, cls = module.partition(":")
    klass = getattr(importlib.import_module(mod), cls)
    info = registry.world(world)
    answered = list(info.questions.entries) + list(info.events.entries)
    assert answered and all(e.answer for e in answered)
    for e in answered:
        params = [p for p in inspect.signature(getattr(klass, e.answer)).parameters.values() if p.name != "self"]
        assert len(params) == len(e.args), e
    assert len(info.points) >= 2 and all(doc for doc in info.points.values())


class _Toy:
    def ask_twice(self, n):
        return 2 * n


def test_the_table_dispatches_checks_arguments_and_says_did_you_mean():
    table = Names("question", [Name("twice", "two times N", args=("N",), answer="ask_twice"),
                               Name("doc_only", "declared, answered elsewhere")])
    assert table.answer(_Toy(), "twice", (4,), "the toy") == 8
    assert dict(table) == {"twice": "two times N", "doc_only": "declared, answered elsewhere"}
    with pytest.raises(InputError, match=r"question 'twice' takes one argument \(twice\(N\)\), got 2"):
        table.answer(_Toy(), "twice", (1, 2), "the toy")
    with pytest.raises(UnknownNameError, match="the toy has no question 'twise'") as info:
        table.answer(_Toy(), "twise", (), "the toy")
    assert info.value.hint == "did you mean 'twice'?"
    assert table.arities() == {("question", "twice"): 1}  # a name with only a doc says nothing of arguments


def test_a_plug_in_declaring_a_plain_dict_still_works():
    info = registry.WorldInfo(name="toy", factory="x:y", doc="d", questions={"ready": "the world is ready"})
    assert isinstance(info.questions, Names) and info.questions["ready"] == "the world is ready"
    assert info.declared({}).arities == {}


def test_the_tictactoe_world_answers_through_its_table():
    from hila_lang.plugins.options import RunOptions
    from hila_lang.robot.dry import DryBackend

    world = registry.world("tictactoe").build(RunOptions(seed=0, settings={}), {"report": False})
    world.attach(DryBackend())
    assert world.query("free", 5) is True and world.query("marks") == 0
    with pytest.raises(InputError, match=r"question 'free' takes one argument \(free\(N\)\), got 0"):
        world.query("free")
    with pytest.raises(InputError, match=r"event 'opponent_moved' takes no arguments"):
        world.wait("opponent_moved", 3)


def test_check_refuses_a_call_with_the_wrong_number_of_arguments(tmp_path, capsys):
    prog = tmp_path / "p.hila"
    prog.write_text("world tictactoe\nmain {\n    if ask free(1, 2) { wait opponent_moved }\n}\n")
    assert cli.main(["check", str(prog)]) == 2
    err = capsys.readouterr().err.replace(str(prog), "p.hila").splitlines()
    assert err[0] == "p.hila:3:8: error: question 'free' of the tictactoe world takes 1 argument(s), got 2"
    assert err[-1] == "hint: write it ask free(N)"
    prog.write_text("world tictactoe\nmain {\n    if ask free(1) { wait opponent_moved }\n}\n")
    assert cli.main(["check", str(prog)]) == 0
