"""Record and replay: ``hila exec --record`` writes one file; ``hila replay`` steps through it with
no simulator; ``hila replay --verify`` re-runs it and reports the first difference."""

from __future__ import annotations

import io
import json
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from hila_lang import cli
from hila_lang.session.recording import read_record, write_record
from hila_lang.session.replay import ReplayEngine
from hila_lang.session.repl import Repl

ROOT = Path(__file__).resolve().parent.parent


def hila(*args: str, cwd=ROOT, stdin: str = "") -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "hila_lang", *args], input=stdin, capture_output=True, text=True,
                          cwd=cwd, timeout=300)


@pytest.fixture(scope="module")
def game(tmp_path_factory) -> Path:
    """A whole game on PyBullet, recorded with the eye images."""
    folder = tmp_path_factory.mktemp("game")
    proc = hila("exec", "programs/game.hila", "--record", str(folder / "game.hilarec"), "--record-eyes",
                "--out", str(folder / "out"), "--quiet")
    assert proc.returncode == 0, proc.stderr
    return folder / "game.hilarec"


@pytest.mark.slow
def test_a_recorded_game_verifies_with_no_difference(game):
    proc = hila("replay", "--verify", str(game))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    record = read_record(game)
    assert proc.stdout.splitlines() == [f"no difference: {len(record['steps'])} steps verified (tolerance 0.001 mm)"]


@pytest.mark.slow
def test_the_recording_holds_the_run(game):
    record = read_record(game)
    assert record["hila_record"] == 1 and record["command"]["backend"] == "pybullet"
    assert record["program"]["text"] == (ROOT / "programs" / "game.hila").read_text()
    assert record["templates"]["circle"]["text"] == (ROOT / "primitives" / "circle.yaml").read_text()
    assert record["result"] == {"status": "finished"}
    runs = [s for s in record["steps"] if s["kind"] == "run"]
    assert runs and all(s["path"].shape[1] == 3 and len(s["executed"]) > len(s["path"]) for s in runs)
    draws = [s for s in runs if s["pen_down"]]
    assert draws and all(s["osila"]["rounds"] >= 1 and s["osila"]["warp"] for s in draws)
    eyes = [s["eye"] for s in runs]
    assert sorted(eyes) == sorted(record["images"])
    import cv2

    image = cv2.imdecode(np.frombuffer(record["images"][eyes[-1]], np.uint8), cv2.IMREAD_COLOR)
    assert image.shape == (240, 320, 3) and image.std() > 5
    with zipfile.ZipFile(game) as z:  # any ZIP tool opens it; record.json is plain JSON
        doc = json.loads(z.read("record.json"))
    assert doc["steps"][0]["state"] == record["steps"][0]["state"]


@pytest.mark.slow
def test_replay_steps_back_where_icps_and_plots_without_a_simulator(game, tmp_path):
    png = tmp_path / "p.png"
    script = "\n".join(["break main/mark/draw", "run", "where", "icps", "step", "path --plot " + str(png),
                        "back 1", "where", "explain", "quit"]) + "\n"
    code = ("import sys, io\n"
            "from hila_lang.session.recording import read_record\n"
            "from hila_lang.session.replay import ReplayEngine\n"
            "from hila_lang.session.repl import Repl\n"
            f"Repl(ReplayEngine(read_record({str(game)!r})), stdin=io.StringIO({script!r}), stdout=sys.stdout).cmdloop()\n"
            "heavy = sorted(m for m in ('pybullet', 'hila_lang.robot.backend', 'hila_lang.sim.scene') if m in sys.modules)\n"
            "print('loaded:', heavy)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout.splitlines()
    assert out[-1] == "loaded: []"  # no simulator
    assert "breakpoint: main/mark/draw" in out
    assert ("at main/mark/draw (run): run circle.draw({main/mark:c}.*, hand = none) pen down track {main/mark:c} "
            "every 100 ms threshold 1 mm blend 5 mm lift above 8 mm") in out
    assert any(line.startswith("  tl           = (") for line in out)  # the ICPs it is about to bind
    assert any(line.startswith("main/mark/draw: ") and "points" in line for line in out)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert any(line.startswith("back 1 step: at main/mark/draw; hand at (") for line in out)
    assert any(line.startswith("main/mark/draw (line ") and "about to run: circle.draw" in line for line in out)


def test_a_recording_from_a_modified_template_reports_the_first_differing_state(tmp_path):
    shutil.copy(ROOT / "programs" / "reach_return.hila", tmp_path / "task.hila")
    template = tmp_path / "reach.yaml"
    shutil.copy(ROOT / "primitives" / "reach.yaml", template)
    proc = hila("exec", "task.hila", "--record", "r.hilarec", "--quiet", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert hila("replay", "--verify", "r.hilarec", cwd=tmp_path).returncode == 0
    text = template.read_text()
    template.write_text(text.replace("- {tag: back, start: 36, stop: 71, contact: false}",
                                     "- {tag: back, start: 40, stop: 71, contact: false}")
                            .replace("- {tag: reach, start: 0, stop: 36, contact: false}",
                                     "- {tag: reach, start: 0, stop: 40, contact: false}"))
    proc = hila("replay", "--verify", "r.hilarec", cwd=tmp_path)
    assert proc.returncode == 1
    assert proc.stdout.splitlines() == [
        f"note: template reach ({template}) has changed since the recording",
        "first difference at step 2, state main/visit#1/reach (task.hila:12): the planned path: recorded 36 "
        "points, now 40",
    ]


def test_a_failed_run_is_recorded_and_verifies_as_failing_the_same_way(tmp_path):
    prog = tmp_path / "p.hila"
    prog.write_text("import reach\nhand at (0.18, -0.25, 0.75)\nmain {\n"
                    "  run reach.reach(object = (0.3, -0.18, 0.6), home = hand)\n"
                    "  run reach.back(object = (0.3, -0.18, 0.6), home = hand) via (0.25, -0.2, 0.7) "
                    "avoid (0.25, -0.2, 0.7) radius 0.02\n}\n")  # a contradiction: only the run finds it
    proc = hila("exec", str(prog), "--record", str(tmp_path / "f.hilarec"), "--quiet")
    assert proc.returncode == 1 and "contradictory constraints" in proc.stderr
    record = read_record(tmp_path / "f.hilarec")
    assert record["result"]["status"] == "failed" and record["result"]["exit"] == 1
    assert "contradictory constraints" in record["result"]["error"]
    assert [s["state"] for s in record["steps"]] == ["main/reach"]  # the failing state is in the result
    assert record["result"]["state"] == "main/back"
    out = io.StringIO()
    Repl(ReplayEngine(record), stdin=io.StringIO("step\nstep\nquit\n"), stdout=out).cmdloop()
    assert "the recorded run failed here:" in out.getvalue()
    proc = hila("replay", "--verify", str(tmp_path / "f.hilarec"))
    assert proc.returncode == 0 and proc.stdout.startswith("no difference: 1 steps verified")


def test_a_run_stopped_by_the_step_limit_verifies(tmp_path):
    """The step limit is part of the recorded command: a run it stopped verifies (it reported
    'the recording failed there, the re-run went on')."""
    prog = tmp_path / "loop.hila"
    prog.write_text("main {\n    while true { let x = 1 }\n}\n")
    proc = hila("exec", str(prog), "--max-steps", "10", "--record", str(tmp_path / "l.hilarec"), "--quiet")
    assert proc.returncode == 1 and "the step limit" in proc.stderr
    assert read_record(tmp_path / "l.hilarec")["command"]["max_steps"] == 10
    proc = hila("replay", "--verify", str(tmp_path / "l.hilarec"))
    assert proc.returncode == 0 and proc.stdout.startswith("no difference: 10 steps verified"), proc.stdout


@pytest.mark.slow
def test_a_person_s_moves_are_recorded_and_typed_again(tmp_path):
    moves = "5\n1\n2\n3\n4\n6\n7\n8\n9\n"
    proc = hila("exec", "programs/game.hila", "--backend", "dry", "--opponent", "human", "--set", "report=no",
                "--record", str(tmp_path / "h.hilarec"), "--quiet", stdin=moves)
    assert proc.returncode == 0, proc.stderr
    record = read_record(tmp_path / "h.hilarec")
    assert record["input"] and "".join(record["input"]) == moves[: len("".join(record["input"]))]
    proc = hila("replay", "--verify", str(tmp_path / "h.hilarec"))
    assert proc.returncode == 0, proc.stdout


def test_bad_recordings_and_record_paths_are_refused_with_exit_2(tmp_path, capsys):
    bad = tmp_path / "x.hilarec"
    bad.write_text("hello")
    assert cli.main(["replay", str(bad)]) == 2
    assert f"{bad}: error: not a hila recording (expected a ZIP file holding record.json)" in capsys.readouterr().err
    write_record(bad, {"hila_record": 2})
    assert cli.main(["replay", str(bad)]) == 2
    assert "this hila reads recordings of version 1, got 2" in capsys.readouterr().err
    assert cli.main(["exec", "programs/abc.hila", "--record", str(tmp_path)]) == 2
    err = capsys.readouterr()
    assert "expected --record to name a file, got a folder" in err.err and err.out == ""  # refused before running
    assert cli.main(["exec", "programs/abc.hila", "--record-eyes"]) == 2
    assert "--record-eyes needs --record FILE.hilarec" in capsys.readouterr().err


def test_a_replay_offers_every_member_the_repl_reads_from_its_engine(game):
    """The REPL drives an Interpreter or a ReplayEngine alike: every ``it.NAME`` /
    ``self.interp.NAME`` it reads must exist on a replay too (a new engine member used by a REPL
    command, missing from the replay, fails here instead of in a user's session)."""
    import re

    from hila_lang.session import repl

    used = set(re.findall(r"\b(?:it|self\.interp)\.([a-z_]+)", Path(repl.__file__).read_text()))
    engine = ReplayEngine(read_record(game))
    engine.step()
    assert used and not sorted(name for name in used if not hasattr(engine, name))
