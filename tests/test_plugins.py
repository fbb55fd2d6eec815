"""The plug-in seam: protocols, the entry-point registry, settings, and bugs that look like bugs.

- every registered world and back end implements its protocol (members and signatures), and so
  do the back ends' capabilities; a plug-in that does not is refused as a plug-in bug;
- declarations (settings, questions, events, docs) are readable without building anything and
  import nothing heavy;
- a world from a throwaway distribution (a temporary ``*.dist-info`` with ``entry_points.txt`` on
  ``sys.path``; nothing is downloaded) is found and runs a program, in-process and through the CLI;
- ``--set`` is split among OSILA, the world and the back end and parsed before anything is
  built; the dry back end's ``hand`` setting works;
- a world's unknown name is :class:`UnknownNameError` (exit 1, located); anything else raised
  by a plug-in is an internal error (exit 3) naming where it was raised and whom to tell, with
  the traceback under ``--debug``.
"""

from __future__ import annotations

import io
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from hila_lang import cli
from hila_lang.core.errors import InputError, UnknownNameError, internal_error_message
from hila_lang.session.runner import finish, prepare
from hila_lang.plugins.options import split_settings
from hila_lang.plugins import registry
from hila_lang.plugins.options import RunOptions
from hila_lang.plugins.protocols import CAPABILITIES, WORLD_CAPABILITIES, Backend, World, conformance

ROOT = Path(__file__).resolve().parents[1]


def test_hilas_own_plugins_are_registered_by_entry_points():
    assert {"scripted", "tictactoe", "letters"} <= set(registry.names("world"))
    assert {"dry", "pybullet"} <= set(registry.names("back end"))
    assert registry.world("tictactoe").default_backend == "pybullet"
    with pytest.raises(InputError, match="unknown world 'tictactoo'") as info:
        registry.world("tictactoo")
    assert info.value.hint == "did you mean 'tictactoe'?"


@pytest.mark.parametrize("world_name", registry.names("world"))
@pytest.mark.parametrize("backend_name", registry.names("back end"))
def test_every_registered_plugin_implements_its_protocol(tmp_path, world_name, backend_name):
    winfo, binfo = registry.world(world_name), registry.backend(backend_name)
    if backend_name == "ros":  # it needs an arm on ROS 2 to be built: tests/test_ros.py builds it against robot-sim
        from hila_lang.ros.backend import RosBackend

        assert conformance(RosBackend.__new__(RosBackend), Backend) == []  # members and signatures, not built
        return
    options = RunOptions(out=tmp_path, stdin=io.StringIO(), stdout=io.StringIO())
    world = winfo.build(options, winfo.parse({s.name: "no" for s in winfo.settings if s.name == "report"}))
    assert conformance(world, World) == [] and isinstance(world, World)
    for name, protocol in WORLD_CAPABILITIES.items():  # hila's own worlds can all go back
        part = getattr(world, name, None)
        if name == "tracking":  # a world that declares it can be tracked has the capability, and only then
            assert (part is not None) == winfo.tracking, world_name
            if part is None:
                continue
        assert isinstance(part, protocol) and conformance(part, protocol) == []
    backend = binfo.build(world.scene, options, binfo.parse({}))
    try:
        assert conformance(backend, Backend) == [] and backend.name == backend_name
        for name, protocol in CAPABILITIES.items():
            part = getattr(backend, name)
            if backend_name in ("dry", "pybullet") and name in ("eyes", "ink", "overview"):
                assert (part is None) == (backend_name == "dry"), name  # the dry one has no camera, no ink
            if backend_name in ("dry", "pybullet") and name == "view":
                assert part is None  # no window without --gui
            if part is not None:
                assert isinstance(part, protocol) and conformance(part, protocol) == []
        world.attach(backend)
        assert np.asarray(backend.hand_position()).shape == (3,)
    finally:
        backend.close()


def test_conformance_names_what_is_missing_or_wrongly_shaped():
    class Half:
        name = "half"
        eyes = ink = overview = snapshots = view = None

        def hand_position(self):
            return np.zeros(3)

        def reset_hand(self, where):  # wrong parameter name
            pass

        def move(self, path, pen_down=False):  # no label keyword
            return path

    problems = conformance(Half(), Backend)
    assert "has no 'close'" in problems
    assert any(p.startswith("reset_hand() names its parameter 1 'where'") for p in problems)
    assert "move() takes no keyword 'label'" in problems

    class BadEyes(Half):
        eyes = object()

    assert any(p.startswith("eyes has no 'camera_image'") for p in conformance(BadEyes(), Backend))

    class HalfSnapshots:  # a world's capability is checked as a back end's is
        def save(self):
            return 0

        def restore(self, token):  # wrong parameter name
            pass

    from hila_lang.worlds.scripted.world import ScriptedWorld

    world = ScriptedWorld()
    world.snapshots = HalfSnapshots()
    assert conformance(world, World) == ["snapshots has no 'discard'",
                                         "snapshots restore() names its parameter 1 'token', expected 'saved'"]


def test_declarations_are_documented_and_import_nothing_heavy():
    for info in registry.declarations("world") + registry.declarations("back end"):
        assert info.doc and "\n" not in info.doc
        for s in info.settings:
            assert s.doc and "\n" not in s.doc and s.name in s.help()
        for name, doc in {**getattr(info, "questions", {}), **getattr(info, "events", {})}.items():
            assert doc and "\n" not in doc, name
    ttt = registry.world("tictactoe")
    assert set(ttt.questions) >= {"game_over", "best_move", "free"} and set(ttt.events) == {"opponent_moved"}
    assert ttt.parse({}) == {"opponent": "minimax", "first": "robot", "report": True,
                             "board.bump": 0.0, "light": 1.0, "crosses": "neat", "board.slide": 0.0,
                             "board.turn": 0.0, "board.jump": 0.0}
    assert ttt.parse({"board.bump": "0.03", "crosses": "sloppy"})["board.bump"] == 0.03
    code = ("import sys; from hila_lang.plugins import registry\n"
            "[registry.world(n) for n in registry.names('world')]\n"
            "[registry.backend(n) for n in registry.names('back end')]\n"
            "print([m for m in ('numpy', 'pybullet', 'cv2', 'scipy', 'lark') if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


# --------------------------------------------------------------------------- a third-party world

TOY = '''
"""A world from another distribution: one point, one question, one event, one setting."""
from hila_lang.plugins.registry import WorldInfo
from hila_lang.plugins.settings import Setting, number

BUILT = []

WORLD = WorldInfo(
    name="toy",
    factory="toyworld.world:make_world",
    doc="a world from a throwaway distribution",
    settings=(Setting("height", "how high the target is", number(0.0, 1.0), default=0.6, metavar="METRES"),),
    questions={"target": "the target point", "crash": "raises a plain KeyError (a plug-in bug)"},
    events={"ready": "the world is ready"},
)
'''

TOY_WORLD = '''
import numpy as np
from hila_lang.core.errors import UnknownNameError
from . import BUILT, WORLD


class ToyWorld:
    scene = None
    snapshots = None  # it cannot go back

    def __init__(self, height):
        self.height = height
        self.log = []

    def attach(self, backend):
        backend.reset_hand(np.array([0.2, -0.2, 0.7]))

    def points(self):
        return {"goal.tip": np.array([0.3, -0.1, self.height])}

    def query(self, name, *args):
        if name == "target":
            return "goal"
        if name == "crash":
            return {}["oops"]
        raise UnknownNameError("question", name, WORLD.questions, owner="the toy world")

    def wait(self, event, *args):
        raise UnknownNameError("event", event, WORLD.events, owner="the toy world")

    def notify(self, event, **data):
        self.log.append(event)

    def finish(self, trace, *, fsm=None):
        print(f"toy world: {len(trace)} states, notified {self.log}")
        return {"states": len(trace)}


def make_world(options, settings):
    BUILT.append(settings)
    return ToyWorld(settings["height"])
'''

PROGRAM = """world toy
import reach
main {
    let g = ask target
    run reach.reach(object = g.tip, home = hand)
}
"""


@pytest.fixture
def toy_distribution(tmp_path, monkeypatch):
    """A distribution 'toyworld' installed by putting its files on sys.path; removed afterwards."""
    site = tmp_path / "site"
    pkg = site / "toyworld"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text(textwrap.dedent(TOY))
    (pkg / "world.py").write_text(textwrap.dedent(TOY_WORLD))
    info = site / "toyworld-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: toyworld\nVersion: 0.1\n")
    (info / "top_level.txt").write_text("toyworld\n")
    (info / "entry_points.txt").write_text("[hila.worlds]\ntoy = toyworld:WORLD\n")
    program = tmp_path / "toy.hila"
    program.write_text(PROGRAM)
    (tmp_path / "primitives").mkdir()
    (tmp_path / "primitives" / "reach.yaml").write_text((ROOT / "primitives" / "reach.yaml").read_text())
    monkeypatch.syspath_prepend(str(site))
    registry.refresh()
    yield site, program
    for name in [m for m in sys.modules if m == "toyworld" or m.startswith("toyworld.")]:
        del sys.modules[name]
    monkeypatch.undo()
    registry.refresh()
    assert "toy" not in registry.names("world")


def test_a_world_from_another_distribution_runs_a_program(toy_distribution):
    site, program = toy_distribution
    assert "toy" in registry.names("world")
    options = RunOptions(settings={"height": "0.62"}, stdout=io.StringIO())
    interp = prepare(program, options)
    assert interp.backend.name == "dry"  # the world's default
    trace = interp.run()
    assert finish(interp) == {"states": len(trace)}
    run = trace[-2]
    assert run.kind == "run" and np.allclose(run.icps["object"], [0.3, -0.1, 0.62])
    np.testing.assert_allclose(run.path[0], [0.2, -0.2, 0.7])  # attach parked the hand
    assert interp.world.log[-1] == "program_done"
    import toyworld

    assert toyworld.BUILT == [{"height": 0.62}]
    # through the CLI, in a fresh process that sees the distribution on its path
    done = subprocess.run([sys.executable, "-m", "hila_lang", "exec", str(program), "--set", "height=0.6"],
                          capture_output=True, text=True, timeout=120, cwd=program.parent,
                          env={**__import__("os").environ, "PYTHONPATH": str(site)})
    assert done.returncode == 0, done.stderr
    assert "toy world: 3 states" in done.stdout


def test_a_bad_setting_is_refused_before_the_world_is_built(toy_distribution):
    _, program = toy_distribution
    import toyworld

    with pytest.raises(InputError, match=r"bad value for --set height=2 \(world toy\): expected a number in \[0.0, 1.0\]"):
        prepare(program, RunOptions(settings={"height": "2"}))
    with pytest.raises(InputError, match="unknown setting 'hieght' for world 'toy' and back end 'dry'") as info:
        prepare(program, RunOptions(settings={"hieght": "0.5"}))
    assert info.value.hint == "did you mean 'height'?"
    assert toyworld.BUILT == []


def test_a_plugin_bug_is_an_internal_error_that_names_the_plugin(toy_distribution, capsys):
    site, program = toy_distribution
    program.write_text(PROGRAM.replace("ask target", "ask crash"))
    assert cli.main(["exec", str(program)]) == 3
    err = capsys.readouterr().err
    assert "hila: internal error: KeyError: 'oops'" in err
    assert "in query" in err and "toyworld" in err
    assert "bug in the plug-in module 'toyworld.world' (distribution 'toyworld')" in err
    assert "Traceback" not in err
    assert cli.main(["exec", str(program), "--debug"]) == 3
    err = capsys.readouterr().err
    assert "Traceback (most recent call last)" in err and "internal error" in err


def test_an_unknown_question_is_found_by_check_from_the_declaration(toy_distribution, capsys):
    _, program = toy_distribution
    program.write_text(PROGRAM.replace("ask target", "ask targte"))
    for command in ("check", "exec"):  # the world's declaration is enough: nothing is built
        assert cli.main([command, str(program)]) == 2
        err = capsys.readouterr().err
        assert "toy.hila:4:13: error: the toy world has no question 'targte'" in err
        assert "hint: did you mean 'target'?" in err


# --------------------------------------------------------------------------- settings and errors


def test_settings_go_to_their_owner_and_are_parsed():
    osila, world, backend = split_settings(
        {"osila.threshold": "0.002", "first": "opponent", "hand": "0.1, 0.2, 0.3"},
        registry.world("tictactoe"), registry.backend("dry"))
    assert osila == {"threshold": 0.002}
    assert world == {"opponent": "minimax", "first": "opponent", "report": True, "board.bump": 0.0, "light": 1.0,
                     "crosses": "neat", "board.slide": 0.0, "board.turn": 0.0, "board.jump": 0.0}
    assert backend == {"hand": (0.1, 0.2, 0.3)}
    with pytest.raises(InputError, match=r"unknown setting 'colour' .* known: board.bump, board.jump, board.slide, board.turn, crosses, first, hand, light, opponent, report, osila.OPTION"):
        split_settings({"colour": "red"}, registry.world("tictactoe"), registry.backend("dry"))


def test_the_dry_back_ends_hand_setting_is_accepted_on_the_command_line(tmp_path, capsys):
    program = tmp_path / "p.hila"
    program.write_text("import reach\npoint o = (0.3, -0.1, 0.6)\nmain { run reach.reach(object = o, home = hand) }\n")
    (tmp_path / "primitives").mkdir()
    (tmp_path / "primitives" / "reach.yaml").write_text((ROOT / "primitives" / "reach.yaml").read_text())
    assert cli.main(["exec", str(program), "--set", "hand=0.2,-0.3,0.75"]) == 0
    out = capsys.readouterr().out
    assert "(0.200, -0.300, 0.750) ->" in out  # the first run starts at the hand
    assert cli.main(["exec", str(program), "--set", "hand=0.2"]) == 2
    assert "bad value for --set hand=0.2 (back end dry): expected X,Y,Z" in capsys.readouterr().err


def test_help_documents_exit_3_debug_and_the_opponent_alias(capsys):
    with pytest.raises(SystemExit):
        cli.main(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "3 internal error" in text and "--debug" in text
    with pytest.raises(SystemExit):
        cli.main(["exec", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--opponent OPPONENT same as --set opponent=VALUE (world tictactoe: random|minimax|human)" in text
    assert "{dry,pybullet" in text


def test_the_internal_error_message_blames_hila_for_its_own_frames():
    from hila_lang.sim.canvas import Canvas

    with pytest.raises(AttributeError) as info:
        Canvas(None)  # a misuse inside hila: the innermost frame is hila's own module
    text = internal_error_message(info.value)
    assert text.startswith("internal error: AttributeError: ")
    assert "sim/canvas.py" in text and "in __init__" in text
    assert "This is a bug in hila, not a mistake in your program or data." in text
    assert "hila --debug" in text


def test_unknown_name_error_is_a_run_error_with_a_hint():
    exc = UnknownNameError("event", "opponent_move", ["opponent_moved"], owner="the tictactoe world")
    assert exc.exit_code == 1 and str(exc).startswith("error: the tictactoe world has no event 'opponent_move'")
    assert exc.hint == "did you mean 'opponent_moved'?"


def test_help_lists_an_installed_plugins_settings(toy_distribution, capsys):
    """--help reads the settings from the registry: a world installed by another distribution
    appears with its settings, nothing hard-coded."""
    with pytest.raises(SystemExit):
        cli.main(["exec", "--help"])
    text = capsys.readouterr().out
    assert "world toy: a world from a throwaway distribution" in text
    assert "height=METRES  how high the target is (default: 0.6)" in text
