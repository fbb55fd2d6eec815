"""``hila check`` means it (issue 13): what a program asks of its world is checked against what
the world declares, the points' sizes against the templates', the settings before anything is
built; 2-D templates run where the world has a drawing surface; tags are names a program can
write; a binding is never dropped in silence; an obstacle on an ICP says what can help."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

from hila_lang import cli
from hila_lang.core.errors import InputError
from hila_lang.hierarchy.step import hila_step
from hila_lang.plugins import registry
from hila_lang.osila.template import Template, load_template, save_template

ROOT = Path(__file__).resolve().parent.parent


def run_cli(tmp_path, capsys, text: str, *args: str) -> tuple[int, str, str]:
    prog = tmp_path / "p.hila"
    prog.write_text(text)
    code = cli.main([*args[:1], str(prog), *args[1:]])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return code, captured.out, captured.err.replace(str(prog), "p.hila")


# --------------------------------------------------------------------------- names the world declares


def test_an_unknown_question_is_found_by_check_with_did_you_mean(tmp_path, capsys):
    """The issue's input: world tictactoe + ask best_mvoe passed check, then failed the run."""
    text = "world tictactoe\nmain { let m = ask best_mvoe }\n"
    for command in ("check", "exec"):
        code, out, err = run_cli(tmp_path, capsys, text, command, "--backend", "dry")
        assert code == 2 and err.splitlines() == [
            "p.hila:2:16: error: the tictactoe world has no question 'best_mvoe'",
            "    main { let m = ask best_mvoe }", "                   ^", "hint: did you mean 'best_move'?"]
        assert "tic-tac-toe:" not in out  # nothing was built, no game started


def test_events_and_points_come_from_the_scripted_worlds_script(tmp_path, capsys):
    script = tmp_path / "s.yaml"
    script.write_text("points: {shelf.low: [0.3, -0.1, 0.6]}\nanswers: {ready: true}\nevents: {bell: [1]}\n")
    good = "import reach\nmain { if ask ready { wait bell }\n run reach.reach(object = shelf.low, home = hand) }\n"
    code, out, err = run_cli(tmp_path, capsys, good, "check", "--set", f"script={script}")
    assert code == 0 and err == ""
    code, _, err = run_cli(tmp_path, capsys, good.replace("wait bell", "wait bel"), "check", "--set", f"script={script}")
    assert code == 2 and err.splitlines()[0] == f"p.hila:2:23: error: the scripted world ({script}) has no event 'bel'"
    assert err.splitlines()[-1] == "hint: did you mean 'bell'?"
    code, _, err = run_cli(tmp_path, capsys, good.replace("shelf.low", "shelf.lwo"), "check", "--set", f"script={script}")
    assert code == 2 and f"unknown scene point 'shelf.lwo' (the scripted world ({script}) does not name it)" in err
    code, _, err = run_cli(tmp_path, capsys, good, "check")  # no script: the world is empty
    assert code == 2 and err.splitlines()[-1] == ("hint: the scripted world answers what its script names: give "
                                                  "the script with --set script=FILE.yaml (points, answers, events)")


def test_a_bad_setting_value_is_exit_2_naming_it_before_anything_runs(tmp_path, capsys):
    """The issue's input: --set osila.threshold=abc used to fail the run (exit 1) at a program line."""
    code = cli.main(["exec", str(ROOT / "programs" / "game.hila"), "--backend", "dry", "--set", "osila.threshold=abc"])
    captured = capsys.readouterr()
    assert code == 2 and captured.out == ""
    assert captured.err == ("error: bad value for --set osila.threshold=abc: expected threshold as a number, "
                            "got 'abc'\nhint: the OSILA options are described in 'hila imitate --help'\n")
    assert cli.main(["check", str(ROOT / "programs" / "abc.hila"), "--set", "osila.rounds=0"]) == 2
    assert "bad value for --set osila.rounds=0" in capsys.readouterr().err


def test_opponent_on_a_world_without_one_is_refused(capsys):
    code = cli.main(["exec", str(ROOT / "programs" / "abc.hila"), "--opponent", "human"])
    err = capsys.readouterr().err
    assert code == 2 and err == ("error: unknown setting 'opponent' for world 'scripted' and back end 'dry'; known: "
                                 "hand, script, osila.OPTION\nhint: 'opponent' (--opponent) is a setting of world "
                                 "tictactoe\n")


def test_help_lists_every_registered_worlds_settings(capsys):
    for command in ("exec", "repl", "check"):
        with pytest.raises(SystemExit):
            cli.main([command, "--help"])
        text = " ".join(capsys.readouterr().out.split())
        for kind in ("world", "back end"):
            for info in registry.declarations(kind):
                assert f"{kind} {info.name}: {' '.join(info.doc.split())}" in text
                for s in info.settings:
                    assert " ".join(s.help().split()) in text
        assert "script=FILE.yaml" in text and "osila.threshold" in text


@pytest.mark.parametrize("text, message", [
    ("points: [1, 2]\n", "expected 'points' as a mapping name -> [x, y, z], got a list"),
    ("answers: 5\n", "expected 'answers' as a mapping question -> value or [values in turn], got an int"),
    ("answers: [a, b]\n", "expected 'answers' as a mapping question -> value or [values in turn], got a list"),
    ("events: [go]\n", "expected 'events' as a mapping event -> [values in turn], got a list"),
    ("events: {go: 5}\n", "expected 'events.go' as a list of values in turn, got 5"),
    ("events: {go: abc}\n", "expected 'events.go' as a list of values in turn, got 'abc'"),
    ("answers: {1: 2}\n", "expected the names in 'answers' as words, got 1"),
])
def test_a_malformed_script_is_bad_input_naming_the_file(tmp_path, capsys, text, message):
    """A script is user data: a wrong shape is exit 2 naming the file, never an internal error (exit 3)."""
    script = tmp_path / "s.yaml"
    script.write_text(text)
    for command in ("check", "exec"):
        code, out, err = run_cli(tmp_path, capsys, "main { let x = 1 }\n", command, "--set", f"script={script}")
        assert code == 2 and err == f"{script}: error: {message}\n", err


def test_help_lists_every_osila_option_a_run_can_set(capsys):
    from hila_lang.osila import OPTIONS, PER_STEP

    with pytest.raises(SystemExit):
        cli.main(["exec", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert set(PER_STEP) == {"pin", "task_times"}  # a step's own: stamps of one path, times of its pairs
    for name in OPTIONS:
        if name not in PER_STEP:  # (seed seeds reject="lmeds")
            assert f"osila.{name}" in text, name
    from hila_lang.plugins.options import OSILA_SETTABLE

    assert sorted(OSILA_SETTABLE) == sorted(set(OPTIONS) - set(PER_STEP))


def test_an_osila_setting_is_checked_by_its_declaration_which_osila_agrees_with():
    """``--set osila.NAME`` is read and checked by :data:`OSILA_OPTIONS` without OSILA (no numpy
    is imported to check it); every value a declaration takes OSILA takes, and what is of the wrong
    kind (a fraction for a count, a word for a number) both refuse."""
    import subprocess
    import sys

    from hila_lang.core.errors import InputError
    from hila_lang.osila import imitate
    from hila_lang.plugins.options import OSILA_OPTIONS, OsilaOption, osila_options

    probe = ("from hila_lang.plugins.options import osila_options; import sys; "
             "o = osila_options({'osila.rounds': '3', 'osila.smoothing': 'auto', 'osila.threshold': '2e-3', "
             "'osila.reject': 'none', 'osila.directions': 'none'}); "
             "print(o, 'numpy' in sys.modules, 'hila_lang.osila' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "{'rounds': 3, 'smoothing': 'auto', 'threshold': 0.002, 'reject': 'none', 'directions': None} " \
                  "False False"

    def osila_takes(name, value) -> bool:
        try:
            imitate([[0.0, 0.0], [1.0, 0.0]], [[0.0, 0.0]], [[0.0, 0.0]], **{name: value})
            return True
        except InputError:
            return False

    for name, option in OSILA_OPTIONS.items():
        if isinstance(option, OsilaOption):
            taken = [option.low, option.high, (option.low + option.high) / 2, *option.words]
            wrong = ["auto" if "auto" not in option.words else "many"] + ([2.5] if option.integer else [])
        else:
            taken, wrong = list(option.choices), ["sometimes"]
        for value in taken:
            parsed = option.parse("none" if value is None else str(int(value) if option.__class__ is OsilaOption
                                                                       and option.integer else value))
            assert osila_takes(name, parsed), (name, value)
        for value in wrong:
            with pytest.raises(InputError, match=f"bad value for --set osila.{name}"):
                osila_options({f"osila.{name}": str(value)})
            assert not osila_takes(name, value), (name, value)


def test_a_pin_is_the_steps_own_and_cannot_be_set_for_a_run(capsys):
    """``osila.pin`` would replace every step's exact start/end pins (and was checked against a
    two-point path: 'stamps in [-2, 1] for a path of 2 points')."""
    code = cli.main(["check", str(ROOT / "programs" / "abc.hila"), "--set", "osila.pin=[5]"])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("error: --set osila.pin: a pin fixes stamps of one path; each step pins")
    code = cli.main(["check", str(ROOT / "programs" / "abc.hila"), "--set", "osila.task_times=[0.5]"])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("error: --set osila.task_times: task times belong to one step's ICP pairs")


def test_the_readme_documents_the_scripts_setting_and_the_search_path():
    readme = (ROOT / "docs" / "language.md").read_text()  # the README's language section moved there (issue 23)
    assert "--set script=FILE.yaml" in readme and "HILA_PATH" in readme and "--max-steps" in readme


# --------------------------------------------------------------------------- dimensions


def _flat_letter(tmp_path) -> Path:
    """A 2-D template: the letter H's demonstration seen from above, named H."""
    h = load_template(ROOT / "primitives" / "letters" / "H.yaml")
    flat = Template("H", h.path[:, :2].copy(), {k: v[:2].copy() for k, v in h.icps.items()}, times=h.times,
                    segments=h.segments, description="H, flat")
    return save_template(flat, tmp_path / "H2.yaml")


def test_a_2d_template_runs_on_the_worlds_drawing_surface(tmp_path, capsys):
    _flat_letter(tmp_path)
    text = 'world letters\nimport "H2.yaml" as H\nmain { let s = ask next_slot\n run H(s.*) }\n'
    code, out, err = run_cli(tmp_path, capsys, text, "exec", "--set", "word=H", "--out", str(tmp_path / "o"))
    assert code == 0 and "wrote 'H'" in out
    from hila_lang.session.runner import finish, prepare
    from hila_lang.plugins.options import RunOptions

    interp = prepare(tmp_path / "p.hila", RunOptions(settings={"word": "H", "report": "no"}, stdout=io.StringIO()))
    interp.run()
    run = interp.last_run
    paper = interp.world.scene.surface
    assert np.allclose(run.path[:, 2], paper.z)  # on the paper
    corners = interp.world.points()
    for k in ("tl", "tr", "br", "bl"):  # the letter's box corners, met where the warp puts them
        assert np.allclose(run.icps[k][:2], corners[f"paper.slot1.{k}"][:2], atol=1e-9)
    assert interp.world.written[0]["contact_points"] == len(run.path)
    finish(interp)


def test_a_2d_template_where_the_world_has_no_surface_is_refused_with_a_reason(tmp_path, capsys):
    _flat_letter(tmp_path)
    text = 'import "H2.yaml" as H\nmain { run H(tl = (0.3, 0, 0.6), tr = (0.3, -0.03, 0.6), br = (0.27, -0.03, 0.6), bl = (0.27, 0, 0.6)) }\n'
    code, _, err = run_cli(tmp_path, capsys, text, "check")
    assert code == 2 and err.splitlines()[0] == ("p.hila:2:12: error: 'H' is a 2-D template, and world 'scripted' "
                                                 "has no drawing surface to run it on")
    assert err.splitlines()[-1] == ("hint: a 2-D template is a drawing: run it in a world with paper (letters, "
                                    "tictactoe), or learn the demonstration in 3-D")


@pytest.mark.parametrize("text, message", [
    ("import reach\nmain { run reach.reach(object = (0.3, 0), home = hand) }\n",
     "p.hila:2:24: error: ICP 'object' of the 3-D template 'reach.reach' is bound to a 2-D point"),
    ("import reach\npoint p = (0.3, 0)\nmain { run reach.reach(object = p, home = hand) }\n",
     "p.hila:3:24: error: ICP 'object' of the 3-D template 'reach.reach' is bound to a 2-D point"),
    ("import reach\nmain { let p = (0.3, 0)\n run reach.reach(object = p + (0, 1), home = hand) }\n",
     "p.hila:3:18: error: ICP 'object' of the 3-D template 'reach.reach' is bound to a 2-D point"),
    ('world letters\nimport "H2.yaml" as H\nmain { run H(tl = (0.3, 0), tr = paper.slot1.tr, br = paper.slot1.br, bl = paper.slot1.bl) }\n',
     "p.hila:3:14: error: ICP 'tl' of the 2-D template 'H' is bound to a 2-D point"),
])
def test_a_dimension_mismatch_is_caught_by_check(tmp_path, capsys, text, message):
    """The issue: a 2-D template bound to 3-D points (or the reverse) was caught only at run time."""
    _flat_letter(tmp_path)
    code, _, err = run_cli(tmp_path, capsys, text, "check")
    assert code == 2 and err.splitlines()[0] == message


# --------------------------------------------------------------------------- learn --tags


@pytest.mark.parametrize("tags, message", [
    ("reach-1,2back", "error: --tags reach-1,2back: 'reach-1' cannot be written in a program "
                      "(run TEMPLATE.reach-1(...)): a tag is a letter or '_' and then letters, digits or '_'\n"
                      "hint: e.g. 'reach_1'\n"),
    ("reach_1,2back", "error: --tags reach_1,2back: '2back' cannot be written in a program "
                      "(run TEMPLATE.2back(...)): a tag is a letter or '_' and then letters, digits or '_'\n"
                      "hint: e.g. '_2back'\n"),
    ("a,,b", "error: --tags a,,b: tag 2 is empty\nhint: separate the tags with single commas\n"),
])
def test_learn_refuses_tags_the_language_cannot_name(tmp_path, capsys, tags, message):
    data = ROOT / "tests" / "data" / "core"
    out = tmp_path / "t.yaml"
    code = cli.main(["learn", str(data / "demo.csv"), "--icps", str(data / "icps.yaml"), "--tags", tags, "-o", str(out)])
    assert code == 2 and capsys.readouterr().err == message and not out.exists()


def test_learned_tags_are_usable_in_a_program(tmp_path, capsys):
    data = ROOT / "tests" / "data" / "core"
    out = tmp_path / "t.yaml"
    assert cli.main(["learn", str(data / "demo.csv"), "--icps", str(data / "icps.yaml"), "--tags", "go,if_not",
                     "-o", str(out)]) == 0
    t = load_template(out)
    prog = tmp_path / "p.hila"
    icps = ", ".join(f"{k} = none" for k in t.icps)
    prog.write_text(f'import "t.yaml" as t\nmain {{ run t.go({icps}) \n run t.if_not({icps}) }}\n')
    capsys.readouterr()
    assert cli.main(["check", str(prog)]) == 0


# --------------------------------------------------------------------------- coincident ICPs, obstacles


def _two_at_one_point() -> Template:
    path = np.column_stack([np.linspace(0, 1, 30), np.sin(np.linspace(0, 3, 30)) * 0.2])
    return Template("t", path, {"a": [0.5, 0.3], "b": [0.5, 0.3], "c": [1.0, 0.0]})


def test_two_bindings_of_one_template_point_are_an_error_naming_both():
    """The issue: a template with coincident ICPs silently ignored a binding (the path stayed)."""
    with pytest.raises(InputError) as info:
        hila_step(_two_at_one_point(), {"a": [0.5, 0.3], "b": [0.9, 0.9], "c": [1.0, 0.0]})
    assert info.value.message == ("ICPs 'a' and 'b' of 't' are one point in the demonstration but are bound 0.721 "
                                  "apart: a = (0.500, 0.300), b = (0.900, 0.900); the warp maps one point to one "
                                  "place only")
    assert info.value.hint == "bind one of them to none (e.g. b = none), or both to the same point"
    step = hila_step(_two_at_one_point(), {"a": [0.5, 0.3], "b": None, "c": [1.0, 0.0]})  # as the hint says
    assert step.notes == []


def test_the_hands_start_wins_over_a_point_bound_at_it_and_says_so(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    reach = load_template(ROOT / "primitives" / "reach.yaml").sub("reach")  # starts at 'home'
    step = hila_step(reach, {"home": [0.18, -0.25, 0.75], "object": [0.3, -0.1, 0.6]}, [0.18, -0.25, 0.80])
    assert "home" not in step.icps and np.allclose(step.path[0], [0.18, -0.25, 0.80])
    assert step.notes == ["'home' is where 'reach.reach' starts in the demonstration; the step starts where the "
                          "hand is, 0.05 from home = (0.180, -0.250, 0.750), so that binding is not used (bind "
                          "home = none to say so)"]


def test_an_obstacle_over_an_icp_says_what_can_help(tmp_path, capsys):
    task = tmp_path / "task.yaml"
    task.write_text("icps:\n  home: [0.2, -0.2, 0.7]\n  object: [0.3, -0.1, 0.6]\n"
                    "obstacles:\n - {centre: [0.3, -0.1, 0.6], radius: 0.05}\n")
    code = cli.main(["imitate", str(ROOT / "primitives" / "reach.yaml"), "--task", str(task)])
    err = capsys.readouterr().err
    assert code == 1 and err == (
        "error: the path must pass through ICPs that an obstacle covers: ICP 'object' at (0.300, -0.100, 0.600) "
        "lies inside obstacle 0 (centre (0.300, -0.100, 0.600), radius 0.05)\n"
        "hint: move or shrink the obstacle, or bind that ICP elsewhere (or to none); raising 'rounds' or "
        "'threshold' cannot help\n")
