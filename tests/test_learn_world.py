"""``hila learn`` asks the world plug-in for its demonstration recorder and ICP reader (issue 21):
the command names no world's modules."""

from pathlib import Path

import pytest

from hila_lang.cli import main
from hila_lang.plugins import registry

LEARN = Path(__file__).resolve().parents[1] / "hila_lang" / "commands" / "learn.py"


def test_the_command_imports_no_world():
    assert "worlds" not in LEARN.read_text()


def test_tictactoe_declares_its_recorder_and_icp_reader():
    from hila_lang.worlds.tictactoe.recording import learn_from_sim
    from hila_lang.worlds.tictactoe.vision import demonstration_icps

    info = registry.world("tictactoe")
    assert info.capability("recorder", "x", "--from-sim") is learn_from_sim
    assert info.capability("icp_reader", "x", "--frames") is demonstration_icps


@pytest.mark.parametrize("args, flag", [(["--from-sim"], "--from-sim"), (["--frames", "rec"], "--frames")])
def test_a_world_without_one_is_a_clear_error(args, flag, capsys):
    rc = main(["learn", *args, "--world", "scripted", "-o", "/nonexistent/x.yaml"])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert f"world 'scripted' has no" in err and flag in err and "tictactoe" in err
    assert "Traceback" not in err
