"""The ROS 2 back end's planning without ROS (issue 35): IK along a path from measured joint angles,
timing under the tool's and the joints' caps, the whole-trajectory checks and their located
refusals, the interpolation a trajectory controller uses, the settings' parsing, and lark 0.x
refused with how to mend it."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

from hila_lang.core.errors import HilaError, HilaRuntimeError, UnreachableError
from hila_lang.robot.arm import ACCELERATION, DRAW_SPEED, TRAVEL_SPEED
from hila_lang.robot.kinematic_arm import ACCELERATION_CAP, DEFAULT_VELOCITY, from_spec, speed_caps
from hila_lang.robot.spec import resolve
from hila_lang.robot.trajectory import trapezoid_profile, trapezoid_times
from hila_lang.ros.backend import default_workspace
from hila_lang.ros.plan import (SPEED_SLACK, JointPlan, Workspace, check_plan, hausdorff, hermite, off_path,
                                plan_move, sample_times, time_joint_path)

ARM = from_spec(resolve("icub"))
#: a posture with the pen 7 cm above the default sheet
START = ARM.posture_at(np.array([0.30, -0.10, 0.64]))
BOX = default_workspace(0.571)


def _line(a, b, n=20):
    return np.linspace(a, b, n)


def test_the_description_gives_the_icub_chain_limits_and_caps():
    assert ARM.robot == "icub" and ARM.joints[:3] == ("torso_pitch", "torso_roll", "torso_yaw") and ARM.dof == 10
    assert np.all(ARM.ik_lower > ARM.lower) and np.all(ARM.ik_upper < ARM.upper)
    # the iCub URDF's velocities (50000) are placeholders: every joint gets the default cap
    assert np.all(ARM.velocity == DEFAULT_VELOCITY) and np.all(ARM.acceleration == ACCELERATION_CAP)
    assert START is not None and np.linalg.norm(ARM.tip(START) - [0.30, -0.10, 0.64]) < 1e-4


def test_speed_caps_keep_a_urdf_velocity_and_replace_a_placeholder():
    velocity, acceleration = speed_caps([2.175, 2.61, 10.0, 50000.0, 0.0, float("nan"), 6.28])
    assert velocity.tolist() == [2.175, 2.61, DEFAULT_VELOCITY, DEFAULT_VELOCITY, DEFAULT_VELOCITY,
                                 DEFAULT_VELOCITY, 6.28]
    assert acceleration.tolist() == [ACCELERATION_CAP] * 7


@pytest.mark.parametrize("name", ["panda", "kuka"])
def test_the_description_of_an_arm_from_its_urdf_is_its_spec(name):
    """Joints, limits, IK limits, weights, postures, reach and caps come from the robot's spec,
    as the PyBullet arm (hila_lang/robot/arm.py) takes them."""
    from hila_lang.robot.arm import LIMIT_MARGIN

    spec = resolve(name)
    arm = from_spec(spec)
    chain = spec.chain()
    assert arm.robot == name and arm.joints == chain.names and arm.dof == 7
    assert np.array_equal(arm.lower, chain.lower) and np.array_equal(arm.upper, chain.upper)
    lo, hi = spec.ik_limits(LIMIT_MARGIN)
    assert np.array_equal(arm.ik_lower, lo) and np.array_equal(arm.ik_upper, hi)
    assert np.array_equal(arm.weights, spec.joint_weights()) and arm.reach == spec.reach()
    assert np.allclose(arm.seed, spec.posture("seed")) and np.allclose(arm.rest, np.clip(spec.posture("rest"), lo, hi))
    urdf = np.array([spec.limits()[n]["velocity"] for n in arm.joints])
    if name == "panda":  # its URDF gives the datasheet's velocities: kept
        assert np.array_equal(arm.velocity, urdf) and set(urdf) == {2.175, 2.61}
    else:  # pybullet_data's iiwa says 10 rad/s for every joint: a placeholder
        assert np.all(urdf == 10.0) and np.all(arm.velocity == DEFAULT_VELOCITY)
    # its pen held vertical 0.10 m above the robot's own sheet, solved from the seed
    ready = spec.default_surface().to_world(0.0, 0.0) + [0.0, 0.0, 0.10]
    q = arm.posture_at(ready)
    assert q is not None and np.linalg.norm(arm.tip(q) - ready) < 1e-4


def test_a_panda_move_is_planned_with_the_panda_and_refused_beyond_its_reach():
    panda = from_spec(resolve("panda"))
    start = panda.posture_at(np.array([0.30, -0.10, 0.64]))
    here = panda.tip(start)
    plan = plan_move(panda, start, _line(here, here + [0.08, 0.05, -0.05]), workspace=BOX, label="reach")
    assert plan.joints == panda.joints
    assert off_path(panda.tips(plan.positions), np.vstack([here, here + [0.08, 0.05, -0.05]])).max() < 1.5e-4
    # 5 cm beyond the Panda's reach ball (1.146 m around (-0.190, -0.090, 0.883)), which the refusal names
    (cx, cy, cz), radius = panda.reach
    far = np.array([[cx + radius + 0.05, cy, cz]])
    with pytest.raises(UnreachableError, match=r"from the arm's base \(-0.190, -0.090, 0.883\), 0.050 m beyond the "
                                               r"farthest the pen can be \(1.146 m\)"):
        plan_move(panda, start, far, workspace=None, gap=10.0)


def test_batched_forward_kinematics_matches_one_posture_at_a_time():
    rng = np.random.default_rng(1)
    qs = rng.uniform(ARM.lower, ARM.upper, size=(50, ARM.dof))
    one_by_one = np.array([ARM.chain.tip_position(q) for q in qs])
    assert np.allclose(ARM.tips(qs), one_by_one, atol=1e-12)


def test_hermite_matches_scipy_on_seeded_random_knots():
    from scipy.interpolate import CubicHermiteSpline

    rng = np.random.default_rng(0)
    for _ in range(20):
        times = np.cumsum(rng.uniform(0.01, 0.3, size=8)) - 0.01
        q, qd = rng.normal(size=(8, 3)), rng.normal(size=(8, 3))
        t = rng.uniform(times[0], times[-1], size=50)
        ref = CubicHermiteSpline(times, q, qd)
        got_q, got_qd = hermite(times, q, qd, t)
        assert np.allclose(got_q, ref(t), atol=1e-12) and np.allclose(got_qd, ref(t, 1), atol=1e-10)
    # past the last knot: the last point, at rest
    q_end, qd_end = hermite(times, q, qd, times[-1] + 1.0)
    assert np.allclose(q_end, q[-1]) and np.allclose(qd_end, 0.0)


def test_trapezoid_times_agree_with_the_stepped_profile():
    arc = np.linspace(0.0, 0.3, 151)
    times, speeds = trapezoid_times(arc, TRAVEL_SPEED, ACCELERATION)
    profile = np.array(trapezoid_profile(0.3, TRAVEL_SPEED, ACCELERATION, 1e-3))
    stepped = np.interp(arc, profile[:, 0], 1e-3 * np.arange(1, len(profile) + 1))
    assert np.max(np.abs(times[1:] - stepped[1:])) < 2e-3
    assert times[0] == 0 and np.all(np.diff(times) > 0) and speeds.max() <= TRAVEL_SPEED + 1e-12
    assert speeds[0] == 0 and speeds[-1] == pytest.approx(0.0, abs=1e-9)


def test_a_move_is_planned_from_the_measured_joints_and_timed_at_the_pen_speed():
    here = ARM.tip(START)
    path = _line(here, here + [0.08, 0.05, -0.05])
    plan = plan_move(ARM, START, path, pen_down=False, speed=0.15, workspace=BOX, label="reach")
    assert np.allclose(plan.positions[0], START) and plan.times[0] == 0 and np.all(np.diff(plan.times) > 0)
    assert np.allclose(plan.velocities[[0, -1]], 0.0)
    # every knot's tool point is on the path (the IK accepts 0.1 mm)
    assert off_path(ARM.tips(plan.positions), path).max() < 1.5e-4
    assert np.linalg.norm(plan.end - path[-1]) < 1e-4
    # the tool's speed, sampled through the controller's interpolation, reaches the pen speed and no more
    t = sample_times(plan.times)
    tips = ARM.tips(plan.sample(t)[0])
    speed = np.linalg.norm(np.diff(tips, axis=0), axis=1) / np.diff(t)
    assert TRAVEL_SPEED * 0.9 < speed.max() <= TRAVEL_SPEED * (1 + SPEED_SLACK)
    down = plan_move(ARM, START, path, pen_down=True, speed=0.15, workspace=BOX)
    assert down.duration > 2 * plan.duration  # 0.05 m/s down against 0.15 up (the ramps are shorter)
    slow = plan_move(ARM, START, path, pen_down=False, speed=0.03, workspace=BOX)
    assert slow.duration > 3.5 * plan.duration  # ros.speed caps the pen speed (0.03 against 0.15)


def test_the_timing_stretches_until_no_joint_exceeds_its_caps():
    here = ARM.tip(START)
    path = _line(here, here + [0.10, 0.0, 0.0])
    free = plan_move(ARM, START, path, workspace=BOX)
    assert free.stretch == pytest.approx(1.0, abs=0.01)
    slow_joints = dataclasses.replace(ARM, velocity=np.full(ARM.dof, 0.05), acceleration=np.full(ARM.dof, 0.5))
    capped = plan_move(slow_joints, START, path, workspace=BOX)
    assert capped.stretch > 2 and capped.duration == pytest.approx(free.duration * capped.stretch / free.stretch, rel=1e-6)
    t = sample_times(capped.times)
    q, qd = capped.sample(t)
    assert np.abs(qd).max() <= 0.05 + 1e-9
    qdd = np.gradient(capped.velocities, capped.times, axis=0)
    assert np.abs(qdd).max() <= 0.5 * 1.01
    # the same joint path, the same shape: only slower
    assert np.allclose(capped.positions, free.positions)


def test_time_joint_path_uses_the_least_stretch_that_fits():
    arc = np.linspace(0, 0.1, 51)
    qs = np.outer(arc, [2.0, -1.0])  # 2 rad per metre on joint 0
    times, stretch, qd = time_joint_path(arc, qs, 0.1, 0.5, np.array([0.1, 1.0]), np.array([100.0, 100.0]))
    assert stretch == pytest.approx(2.0, rel=1e-6)  # 2 rad/m x 0.1 m/s = 0.2 rad/s against a cap of 0.1
    assert np.abs(qd[:, 0]).max() == pytest.approx(0.1, rel=1e-6)


@pytest.mark.parametrize("offset, match", [
    ((0.0, 0.0, 0.30), "the path starts 300 mm from where the tool is .*ros.gap = 150 mm; the arm did not move"),
])
def test_a_path_that_starts_away_from_the_tool_is_refused(offset, match):
    here = ARM.tip(START)
    with pytest.raises(HilaRuntimeError, match=match):
        plan_move(ARM, START, _line(here + offset, here + offset + [0.05, 0, 0]), workspace=BOX, label="reach")


def test_a_waypoint_outside_the_box_or_the_reach_is_refused_by_name_before_any_ik():
    here = ARM.tip(START)
    box = Workspace((0.2, -0.3, 0.6), (0.5, 0.2, 0.8))
    path = _line(here + [0, 0, 0.03], here + [0.0, 0.0, -0.09], 7)  # ends 3 cm under the box's floor
    with pytest.raises(UnreachableError, match=r"waypoint 7 of 7\): it is 50.0 mm outside the workspace box \(below z = 0.600\)"):
        plan_move(ARM, START, path, workspace=box, gap=1.0)
    far = np.array([[1.5, 0.0, 0.8]])
    with pytest.raises(UnreachableError, match="beyond the farthest the pen can be"):
        plan_move(ARM, START, far, workspace=None, gap=10.0)


def test_a_point_the_ik_cannot_reach_names_its_waypoint():
    here = ARM.tip(START)
    behind = np.array([here, [0.1, 0.3, 0.6]])  # inside the reach ball, across the body: 23 mm short
    with pytest.raises(UnreachableError, match=r"waypoint 2 of 2\): the pen gets no closer than"):
        plan_move(ARM, START, behind, workspace=None, gap=1.0)


def test_measured_joints_outside_the_description_are_refused():
    bad = START.copy()
    bad[6] = ARM.upper[6] + 0.2
    with pytest.raises(HilaRuntimeError, match="(?s)the arm reports r_elbow at 2.050 rad, outside its limits 0.262..1.850.*is the description"):
        plan_move(ARM, bad, [ARM.tip(START)], workspace=BOX)


def _plan(plan: JointPlan, **changes) -> JointPlan:
    return dataclasses.replace(plan, **changes)


def test_check_plan_refuses_a_trajectory_over_a_cap_or_a_limit_and_says_when():
    here = ARM.tip(START)
    plan = plan_move(ARM, START, _line(here, here + [0.06, 0, 0]), workspace=BOX, label="reach")
    check_plan(ARM, plan, speed=0.15, workspace=BOX)  # as planned: fine
    hurried = _plan(plan, times=plan.times / 8, velocities=plan.velocities * 8)
    with pytest.raises(HilaRuntimeError, match=r"refused in reach: .* would turn at .* rad/s, over its cap 1.00 rad/s, "
                                               r"0\.\d\d s into the move \(of 0\.\d\d s\), on the way to waypoint"):
        check_plan(ARM, hurried, speed=0.15, workspace=BOX)
    with pytest.raises(HilaRuntimeError, match="the tool would move at 0.1.. m/s, over the cap ros.speed = 0.100 m/s"):
        check_plan(ARM, plan, speed=0.10, workspace=BOX)
    positions = plan.positions.copy()
    positions[len(positions) // 2, 4] = ARM.upper[4] + 0.1
    with pytest.raises(HilaRuntimeError, match="r_shoulder_roll would reach .* outside its limits"):
        check_plan(ARM, _plan(plan, positions=positions), speed=0.15, workspace=BOX)


def test_the_executed_path_distance_is_the_brute_force_one():
    rng = np.random.default_rng(3)
    path = np.cumsum(rng.normal(size=(30, 3)), axis=0)
    points = rng.normal(size=(40, 3)) * 3
    dense = np.concatenate([np.linspace(a, b, 2001) for a, b in zip(path[:-1], path[1:])])
    brute = np.linalg.norm(points[:, None] - dense[None], axis=2).min(axis=1)
    assert np.allclose(off_path(points, path), brute, atol=5e-3)
    shifted = path + [0.0, 0.0, 0.002]
    assert hausdorff(shifted, path) == pytest.approx(0.002, abs=1e-9)


def test_workspace_text_is_parsed_and_refused_with_what_it_expects():
    box = Workspace.parse("0.1,0.7,-0.5,0.4,0.57,1.0")
    assert box.lower == (0.1, -0.5, 0.57) and box.upper == (0.7, 0.4, 1.0)
    assert Workspace.parse(box.text()) == box
    with pytest.raises(ValueError, match="six finite numbers"):
        Workspace.parse("0,1,2")
    with pytest.raises(ValueError, match="XMIN < XMAX, got 0.7 and 0.1"):
        Workspace.parse("0.7,0.1,-0.5,0.4,0.57,1.0")


@pytest.mark.parametrize("setting, message", [
    ("ros.workspace=0,1,2", "bad value for --set ros.workspace=0,1,2 (back end ros): expected XMIN,XMAX"),
    ("ros.speed=nan", "bad value for --set ros.speed=nan (back end ros): expected a finite number"),
    ("ros.controller=not a topic", "expected a ROS topic name"),
    ("ros.confirm=maybe", "expected first|each|no"),
])
def test_a_bad_ros_setting_is_exit_2_before_anything_starts(setting, message):
    proc = subprocess.run([sys.executable, "-m", "hila_lang", "exec", "programs/reach_return.hila", "--backend", "ros",
                           "--set", setting], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and message in proc.stderr and "Traceback" not in proc.stderr


def test_lark_older_than_1_is_refused_with_how_to_mend_it(monkeypatch):
    import lark

    from hila_lang.language.transformer import grammar

    grammar.cache_clear()
    monkeypatch.setattr(lark, "__version__", "0.12.0")
    try:
        with pytest.raises(HilaError, match=r"hila needs lark 1.x, but the installed 'lark' module is 0.12.0") as info:
            grammar()
        assert "pip install --force-reinstall --no-deps 'lark>=1.1,<2'" in str(info.value)
    finally:
        monkeypatch.undo()
        grammar.cache_clear()
    assert grammar() is not None


def test_the_part_of_a_move_made_before_it_failed_is_kept_in_the_trace_and_the_recording(tmp_path):
    import io
    import json
    import zipfile

    from hila_lang.plugins.options import RunOptions
    from hila_lang.session.recording import Recorder, read_record
    from hila_lang.session.runner import prepare

    interp = prepare("tests/data/ros/reach.hila", RunOptions(stdout=io.StringIO()), "dry")
    made = np.array([[0.18, -0.25, 0.75], [0.20, -0.23, 0.72], [0.22, -0.22, 0.70]])

    def move(path, *, pen_down=False, label=""):  # a back end that loses its arm part of the way
        exc = HilaRuntimeError("no joint states on /joint_states for 0.50 s during a move")
        exc.executed = made
        raise exc

    interp.backend.move = move
    recorder = Recorder(interp, tmp_path / "r.hilarec", {"program": "tests/data/ros/reach.hila", "backend": "dry",
                                                         "seed": 0, "settings": {}})
    with pytest.raises(HilaRuntimeError) as info:
        interp.run()
    failed = interp.trace[-1]
    assert failed.error and failed.state == "main/reach" and np.array_equal(failed.executed, made)
    recorder.close(info.value)
    result = json.loads(zipfile.ZipFile(tmp_path / "r.hilarec").read("record.json"))["result"]
    assert result["status"] == "failed" and np.allclose(result["executed"], made)
    assert np.allclose(read_record(tmp_path / "r.hilarec")["result"]["executed"], made)
