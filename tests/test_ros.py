"""The ROS 2 back end against ``hila robot-sim`` in another process (issue 35): programs run with
``--backend ros`` and the executed path, read back from ``/joint_states``, follows the plan; each
failure of a real arm is provoked -- no controller, other joint names, the joint states stopping
mid-move (the sim killed), a trajectory not followed (a braked joint) -- and Ctrl-C and SIGTERM
mid-move stop the arm where it is.  Every sim is killed by its fixture, even when a test fails."""

from __future__ import annotations

import json
import re
import signal
import time
import zipfile

import numpy as np
import pytest

#: every test starts hila robot-sim (PyBullet and a ROS node) in another process: 3-12 s of CPU each
pytestmark = pytest.mark.slow

pytest.importorskip("rclpy", reason="the ROS 2 tests need the 'ros' extra: pip install '.[test,ros]' then "
                                    "pip install --force-reinstall --no-deps 'lark>=1.1,<2' (.ci/run does both)")
pytest.importorskip("trajectory_msgs.msg", reason="the 'ros' extra's message packages are not installed")

from hila_lang.robot.kinematic_arm import from_spec  # noqa: E402
from hila_lang.robot.spec import resolve  # noqa: E402
from hila_lang.ros.plan import hausdorff  # noqa: E402

from ros_support import Listener, RobotSim, finish, hila, kill_leftovers, new_domain  # noqa: E402

ARM = from_spec(resolve("icub"))
SHORT = "tests/data/ros/reach.hila"
#: the Done-when bound: the executed path within 2 mm of the plan
WITHIN = 0.002


@pytest.fixture
def sims():
    """Start sims with ``sims(*args)`` (each on its own domain); all are killed at the end."""
    started: list[RobotSim] = []

    def start(*args: str) -> RobotSim:
        sim = RobotSim(new_domain(), *args)
        started.append(sim)
        return sim

    try:
        yield start
    finally:
        kill_leftovers()  # a hila exec a failed assertion left behind
        for sim in started:
            sim.stop()


def _record(path) -> dict:
    return json.loads(zipfile.ZipFile(path).read("record.json"))


def _run_steps(doc) -> list[dict]:
    return [s for s in doc["steps"] if s["kind"] == "run"]


def _check_follows_plan(doc) -> float:
    """Every run step's executed path within :data:`WITHIN` of its plan (from where the arm was);
    returns the worst distance."""
    worst = 0.0
    steps = _run_steps(doc)
    assert steps
    for s in steps:
        planned, executed = np.array(s["path"]), np.array(s["executed"])
        assert len(executed) > 20, s["state"]  # states at 120 Hz, not the plan's knots
        off = hausdorff(executed, np.vstack([executed[:1], planned]))
        assert off < WITHIN, (s["state"], off)
        worst = max(worst, off)
    return worst


def test_reach_return_runs_on_robot_sim_and_the_executed_path_follows_the_plan(sims, tmp_path):
    sim = sims()
    rec = tmp_path / "rr.hilarec"
    code, out, err = finish(hila(sim.domain, "exec", "programs/reach_return.hila", "--backend", "ros",
                                 "--record", rec))
    assert code == 0, err
    assert "result: finished: 22 steps, 10 run states" in out
    doc = _record(rec)
    assert doc["command"]["backend"] == "ros"
    _check_follows_plan(doc)
    # the trace is what the joint states said, not the plan: its points are not the plan's
    first = _run_steps(doc)[0]
    assert len(first["executed"]) != len(first["path"])
    # 1 move to 'hand at home', then 10 runs: every one a trajectory the sim took
    assert len([t for t in sim.trajectories() if "points over" in t]) == 11


def test_reach_return_runs_on_the_panda_in_robot_sim(sims, tmp_path):
    """Another arm, from its URDF: both sides take --robot panda; the plan is the Panda's."""
    sim = sims("--robot", "panda")
    assert any("panda ready: 7 joints (panda_joint1, panda_joint2," in line for line in sim.lines), sim.lines
    rec = tmp_path / "rr-panda.hilarec"
    code, out, err = finish(hila(sim.domain, "exec", "programs/reach_return.hila", "--backend", "ros",
                                 "--robot", "panda", "--record", rec))
    assert code == 0, err
    assert "result: finished: 22 steps, 10 run states" in out
    doc = _record(rec)
    _check_follows_plan(doc)
    assert len([t for t in sim.trajectories() if "points over" in t]) == 11
    # the trace is the Panda's pen through its own kinematics: it ends where the program sends it
    last = _run_steps(doc)[-1]
    assert np.linalg.norm(np.array(last["executed"][-1]) - np.array(last["path"][-1])) < WITHIN


def test_the_panda_s_joint_names_against_the_icub_s_are_named(sims):
    """The sim runs the Panda; hila is given no --robot (the iCub): nothing moves, and the error names
    both sides' joints and asks whether the robot is the arm's."""
    sim = sims("--robot", "panda")
    code, out, err = finish(hila(sim.domain, "exec", SHORT, "--backend", "ros", "--set", "ros.timeout=5"))
    assert code == 1
    assert ("error: the joint names in /joint_states do not match the robot's (icub: torso_pitch, torso_roll, "
            in err and "missing torso_pitch, torso_roll, torso_yaw, r_shoulder_pitch" in err
            and "/joint_states names panda_joint1, panda_joint2, panda_joint3, panda_joint4, panda_joint5, "
                "panda_joint6, panda_joint7" in err), err
    assert "hint: none of the icub's joints came: is the arm the icub? --robot NAME|PATH" in err
    assert "Traceback" not in err and not sim.trajectories()


def test_a_tictactoe_move_runs_on_robot_sim(sims, tmp_path):
    sim = sims()
    rec = tmp_path / "ttt.hilarec"
    code, out, err = finish(hila(sim.domain, "exec", "tests/data/ros/ttt_move.hila", "--backend", "ros",
                                 "--set", "report=no", "--record", rec))
    assert code == 0, err
    doc = _record(rec)
    _check_follows_plan(doc)
    draw = [s for s in _run_steps(doc) if s["pen_down"]]
    assert len(draw) == 1
    executed = np.array(draw[0]["executed"])
    assert np.ptp(executed[:, 2]) < 0.003  # the circle is drawn on the paper's plane (z 0.571)
    assert np.abs(executed[:, 2] - 0.571).max() < 0.003


def test_no_controller_on_the_topic_is_one_line_naming_it(sims):
    sim = sims()
    code, out, err = finish(hila(sim.domain, "exec", SHORT, "--backend", "ros",
                                 "--set", "ros.controller=/nobody/joint_trajectory", "--set", "ros.timeout=3"))
    assert code == 1
    first = err.splitlines()[0]
    assert first == "error: no controller on /nobody/joint_trajectory: nothing subscribed to it within 3 s", err
    assert "Traceback" not in err and not sim.trajectories()


def test_joint_names_that_do_not_match_are_named_and_ros_joints_mends_them(sims):
    sim = sims("--prefix", "left_")
    code, out, err = finish(hila(sim.domain, "exec", SHORT, "--backend", "ros", "--set", "ros.timeout=5"))
    assert code == 1
    assert ("the joint names in /joint_states do not match the robot's (icub: torso_pitch, " in err
            and "missing torso_pitch, torso_roll" in err and "/joint_states names left_torso_pitch, left_torso_roll" in err), err
    assert "--set ros.joints=" in err and not sim.trajectories()
    names = ",".join("left_" + j for j in ARM.joints)
    code, out, err = finish(hila(sim.domain, "exec", SHORT, "--backend", "ros", "--set", f"ros.joints={names}"))
    assert code == 0, err
    assert len([t for t in sim.trajectories() if "points over" in t]) == 3


def _signal_mid_move(sim, proc, signum, moves_before: int, into: float = 0.5):
    """Send ``signum`` to ``proc`` ``into`` s after the sim took its trajectory number ``moves_before + 1``."""
    assert sim.wait_for("points over", 120, count=moves_before + 1), sim.lines
    time.sleep(into)
    proc.send_signal(signum)


def test_the_joint_states_stopping_mid_move_ends_the_run_with_the_trace_saved(sims, tmp_path):
    sim = sims()
    rec, trace = tmp_path / "killed.hilarec", tmp_path / "trace.txt"
    proc = hila(sim.domain, "exec", SHORT, "--backend", "ros", "--record", rec, "--trace", trace)
    assert sim.wait_for("points over", 120, count=2), sim.lines  # the reach (after 'hand at home')
    time.sleep(0.5)
    sim.proc.kill()  # the arm's driver dies mid-move
    killed = time.monotonic()
    code, out, err = finish(proc)
    assert code == 1, err
    assert time.monotonic() - killed < 10  # ros.silence (0.5 s), the stop's wait (1 s), leaving the graph
    assert re.search(r"error: no joint states on /joint_states for \d\.\d\d s during a move: the last came at "
                     r"\d\d:\d\d:\d\d\.\d\d\d, \d+\.\d\d s into the move \(of \d\.\d\d s\)", err), err
    assert "no joint states said the arm rests within 1 s" in err
    assert "s into the move (of " in err and "(in state main/reach)" in err and "Traceback" not in err
    doc = _record(rec)
    assert doc["result"]["status"] == "failed" and doc["result"]["exit"] == 1
    executed = np.array(doc["result"]["executed"])
    assert len(executed) > 20  # about half a second of states at 120 Hz
    assert trace.read_text().splitlines()[-1].split()[1] == "main/reach"
    assert "failed: no joint states" in trace.read_text()


def test_a_trajectory_not_followed_is_reported_with_the_distance(sims):
    sim = sims("--brake", "r_elbow")
    code, out, err = finish(hila(sim.domain, "exec", SHORT, "--backend", "ros"))
    assert code == 1
    first = next(line for line in err.splitlines() if "error:" in line)
    assert "the arm did not follow the trajectory: " in first and "mm from the planned end" in first, err
    distance = float(first.split(" the tool is ")[1].split(" mm")[0])
    assert distance > 2.0
    assert "r_elbow is " in first and "stop sent to /joint_trajectory_controller/joint_trajectory" in err
    assert "the arm rests, the tool at" in err
    assert sim.wait_for("a stop, 1 point", 5)


@pytest.mark.parametrize("signum, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_ctrl_c_and_sigterm_mid_move_stop_the_arm_where_it_is(sims, tmp_path, monkeypatch, signum, code):
    sim = sims()
    rec = tmp_path / "stopped.hilarec"
    proc = hila(sim.domain, "exec", SHORT, "--backend", "ros", "--record", rec)
    _signal_mid_move(sim, proc, signum, moves_before=1)
    got, out, err = finish(proc)
    assert got == code, err
    assert "stop sent to /joint_trajectory_controller/joint_trajectory (hold the joints measured at" in err
    assert "the arm rests, the tool at" in err
    assert sim.wait_for("a stop, 1 point", 5), sim.lines
    listener = Listener(sim.domain, monkeypatch)
    try:
        assert listener.heard(), "no joint states from the sim after the stop"
        time.sleep(0.2)
        held = listener.over(0.6)
    finally:
        listener.close()
    assert len(held) > 30  # the sim still publishes (>= 100 Hz: 0.6 s gives about 72)
    assert np.ptp(held, axis=0).max() < 1e-4  # the arm holds
    tool = ARM.tip(held[-1])
    doc = _record(rec)
    executed = np.array(doc["result"]["executed"])
    assert np.linalg.norm(tool - executed[-1]) < 0.001  # the trace ends where the arm rests
    planned_end = np.array([0.30, -0.18, 0.60])  # the cup: the reach's end, not reached
    assert np.linalg.norm(tool - planned_end) > 0.02


def test_a_path_outside_the_workspace_box_is_refused_before_anything_is_sent(sims):
    sim = sims()
    code, out, err = finish(hila(sim.domain, "exec", SHORT, "--backend", "ros",
                                 "--set", "ros.workspace=0.1,0.7,-0.5,0.4,0.8,1.2"))
    assert code == 1
    assert "outside the workspace box (below z = 0.800); the arm did not move" in err, err
    assert SHORT + ":6:9" in err  # located: 'hand at home'
    assert "hint: the box is ros.workspace=0.1,0.7,-0.5,0.4,0.8,1.2" in err
    time.sleep(0.5)
    assert not sim.trajectories()


def test_confirm_shows_the_move_and_sends_nothing_without_a_yes(sims):
    sim = sims()
    code, out, err = finish(hila(sim.domain, "exec", SHORT, "--backend", "ros", "--confirm", "first", stdin=""),
                            stdin="n\n")
    assert code == 1
    assert "move hand at: 1 waypoints" in out and "send it to the arm? [y/N]" in out
    assert "the move hand at was not confirmed ('n'); the arm did not move" in err
    assert not sim.trajectories()
    code, out, err = finish(hila(sim.domain, "exec", SHORT, "--backend", "ros", "--confirm", "first", stdin=""),
                            stdin="y\n")
    assert code == 0, err
    assert out.count("send it to the arm?") == 1  # first: asked once
    assert len([t for t in sim.trajectories() if "points over" in t]) == 3


def test_robot_sim_publishes_joint_states_at_120_hz_and_refuses_bad_options(sims, monkeypatch):
    sim = sims()
    listener = Listener(sim.domain, monkeypatch)
    try:
        assert listener.heard(), "no joint states from the sim"
        time.sleep(0.2)
        start = time.monotonic()
        heard = listener.over(2.0)
        rate = len(heard) / (time.monotonic() - start)
    finally:
        listener.close()
    assert rate >= 100, rate
    code, out, err = finish(hila(sim.domain, "robot-sim", "--brake", "r_elbw"))
    assert code == 2 and "--brake r_elbw: the icub's arm has no such joint" in err and "did you mean 'r_elbow'" in err


def test_the_ros_back_end_built_by_the_registry_implements_the_protocol(sims, monkeypatch):
    import io

    from hila_lang.plugins import registry
    from hila_lang.plugins.options import RunOptions
    from hila_lang.plugins.protocols import CAPABILITIES, Backend, conformance

    sim = sims()
    monkeypatch.setenv("ROS_DOMAIN_ID", str(sim.domain))
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    info = registry.backend("ros")
    world = registry.world("scripted").build(RunOptions(stdout=io.StringIO()), {"script": None})
    backend = info.build(world.scene, RunOptions(stdin=io.StringIO(), stdout=io.StringIO()), info.parse({}))
    try:
        assert conformance(backend, Backend) == [] and backend.name == "ros"
        assert backend.robot.name == "icub" and backend.arm.joints == ARM.joints  # no --robot: the default robot
        assert all(getattr(backend, name) is None for name in CAPABILITIES)  # no eyes, ink, ..., no going back
        ready = ARM.tip(backend.states.latest.positions)
        assert np.linalg.norm(backend.hand_position() - ready) < 1e-9
        assert abs(ready[2] - 0.671) < 0.002  # the sim starts the pen 0.10 m above the default sheet
    finally:
        backend.close()
