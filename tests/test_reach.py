"""``check`` knows the arm (issue 23 item 3, issue 20 item 4's last clause): a bound target outside
the iCub arm's kinematic reach is refused by ``hila check`` at the statement that binds it; the
dry back end checks a planned path as PyBullet's arm does, and a run that cannot reach names the
run's target and how far off it is, not a waypoint index."""

from __future__ import annotations

import numpy as np
import pytest

from hila_lang import cli
from hila_lang.core.errors import UnreachableError
from hila_lang.robot import reach

HEAD = "import reach\npoint home = (0.18, -0.25, 0.75)\n"


def _run(tmp_path, capsys, text, *args):
    prog = tmp_path / "p.hila"
    prog.write_text(text)
    code = cli.main([args[0], str(prog), *args[1:]])
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return code, out, err.replace(str(prog), "p.hila")


def test_the_bound_is_the_chains_length_measured_from_the_urdf():
    """REACH is recomputed from the generated iCub URDF (no simulator): the torso pitch origin and
    the sum of the link lengths to the pen tip; no sampled posture gets the pen beyond it."""
    from hila_lang.robot import ik, model
    from hila_lang.core.rotation import about_z, pose

    chain = ik.KinematicChain.from_urdf(model.generate_urdf(), model.PEN_TIP_LINK,
                                        pose(about_z(model.ROOT_YAW), model.ROOT_POSITION))
    _, joints, _ = chain.forward(np.zeros(chain.dof))
    length = sum(np.linalg.norm(chain.origins[i][:3, 3]) for i in range(1, chain.dof)) + np.linalg.norm(chain.tip[:3, 3])
    np.testing.assert_allclose(joints[0], reach.REACH_CENTRE, atol=1e-6)
    assert length <= reach.REACH_RADIUS < length + 0.001
    rng = np.random.default_rng(0)
    farthest = max(np.linalg.norm(chain.tip_position(rng.uniform(chain.lower, chain.upper)) - joints[0])
                   for _ in range(2000))
    assert 0.5 < farthest < reach.REACH_RADIUS


def _at(distance: float) -> tuple[float, float, float]:
    """A point ``distance`` m from the arm's base, in front of and above the robot (3 decimals)."""
    direction = np.array([0.8, 0.5, 0.33]) / np.linalg.norm([0.8, 0.5, 0.33])
    return tuple(float(v) for v in np.round(np.asarray(reach.REACH_CENTRE) + distance * direction, 3))


def test_check_refuses_a_target_1_33_m_away_at_the_binding(tmp_path, capsys):
    far = _at(1.33)
    text = HEAD + f"point far = ({far[0]}, {far[1]}, {far[2]})\nmain {{\n    run reach.reach(object = far, home = home)\n}}\n"
    code, out, err = _run(tmp_path, capsys, text, "check", "--backend", "pybullet")
    lines = err.splitlines()
    assert code == 2 and out == ""
    assert lines[0] == (f"p.hila:5:21: error: ICP 'object' of 'reach.reach' is bound to ({far[0]:.3f}, {far[1]:.3f}, "
                        f"{far[2]:.3f}), which the arm cannot reach: it is 1.330 m from the arm's base (0.000, -0.027, "
                        "0.620), 0.554 m beyond the farthest the pen can be (0.776 m)")
    assert lines[2] == " " * 24 + "^" and lines[3].startswith("hint: back end 'pybullet' moves the iCub's arm")
    near = _at(0.7)  # inside the bound: check cannot tell, it passes
    code, out, _ = _run(tmp_path, capsys, text.replace(f"({far[0]}, {far[1]}, {far[2]})", str(near)), "check",
                        "--backend", "pybullet")
    assert code == 0


def test_check_finds_it_through_a_task_parameter_and_written_out(tmp_path, capsys):
    text = HEAD + "task visit(t) {\n    run reach.reach(object = t, home = home)\n}\nmain {\n    visit((1.0, 1.0, 1.0))\n}\n"
    code, _, err = _run(tmp_path, capsys, text, "check")  # the scripted world's dry back end checks it too
    assert code == 2 and err.splitlines()[0].startswith(
        "p.hila:7:11: error: ICP 'object' of 'reach.reach' is bound to (1.000, 1.000, 1.000) (through parameter 't' "
        "of task 'visit'), which the arm cannot reach: it is 1.483 m")
    text = HEAD + "main {\n    let p = (1.0, 1.0, 1.0)\n    run reach.reach(object = p, home = home)\n}\n"
    code, _, _ = _run(tmp_path, capsys, text, "check")  # a variable: known only when it runs
    assert code == 0


def test_a_dry_run_of_an_unreachable_target_fails_and_names_it(tmp_path, capsys):
    text = HEAD + "main {\n    let p = (1.0, 1.0, 1.0)\n    run reach.reach(object = p, home = home)\n}\n"
    code, out, err = _run(tmp_path, capsys, text, "exec")
    assert code == 1
    assert err.splitlines()[0].startswith(
        "p.hila:5:5: error: cannot reach the target object = (1.000, 1.000, 1.000) of 'reach.reach': it is 1.48")
    assert "waypoint" not in err and "the arm did not move (in state main/reach)" in err
    assert out.splitlines()[-1].startswith("result: stopped at step 2 (main/reach, line 5)")


def test_the_dry_back_end_checks_the_paper_as_pybullet_does():
    from hila_lang.robot.dry import DryBackend

    dry = DryBackend((0.3, -0.1, 0.7), surface_z=0.571)
    with pytest.raises(UnreachableError, match=r"cannot reach \(0\.300, -0\.100, 0\.560\) m: it is 11\.0 mm below "
                                               r"the paper; the arm did not move"):
        dry.move(np.array([[0.3, -0.1, 0.7], [0.3, -0.1, 0.56]]), label="s")
    assert len(dry.moves) == 0  # refused before it moved
    dry.move(np.array([[0.3, -0.1, 0.7], [0.3, -0.1, 0.571]]))  # on the paper: fine
    np.testing.assert_allclose(dry.hand_position(), [0.3, -0.1, 0.571])


def test_an_ik_failure_on_the_way_is_told_as_the_target():
    """PyBullet's arm reports the waypoint that failed; the run says whose target it was."""
    exc = reach.unreachable((0.018, -0.405, 0.875), "the pen gets no closer than 22.7 mm", 0.0227, "main/reach",
                            where=" (waypoint 16 of 84)")
    assert "waypoint 16 of 84" in exc.message
    told = reach.name_the_target(exc, {"home": np.array([0.18, -0.25, 0.75]), "object": np.array([-0.05, -0.45, 0.95]),
                                       "start": np.array([0.18, -0.25, 0.75])}, "reach.reach")
    assert told.message == ("cannot reach (0.018, -0.405, 0.875) on the way to the target object = (-0.050, -0.450, "
                            "0.950) of 'reach.reach' (0.111 m from it): the pen gets no closer than 22.7 mm; the arm "
                            "did not move")
    assert told.state == "main/reach" and told.distance == pytest.approx(0.0227)


def test_check_refuses_a_via_waypoint_out_of_reach(tmp_path, capsys):
    text = HEAD + "point cup = (0.30, -0.18, 0.60)\nmain {\n    run reach.reach(object = cup, home = home) via (1.0, 1.0, 1.0)\n}\n"
    code, _, err = _run(tmp_path, capsys, text, "check")
    assert code == 2 and err.splitlines()[0].startswith(
        "p.hila:5:52: error: the 'via' waypoint is (1.000, 1.000, 1.000), which the arm cannot reach: it is 1.483 m")


def _away_template(folder) -> None:
    """``away.yaml``: reach from ``home`` to ``object``, then a retract that heads back to ``home``,
    which lies 0.87 m from the arm's base: beyond the reach bound (0.776 m)."""
    from hila_lang.osila.template import save_template, Segment, Template

    home, obj = np.array([-0.4, -0.7, 1.0]), np.array([0.34, -0.1, 0.6])
    s = np.linspace(0.0, 1.0, 20)[:, None]
    lift = np.column_stack([np.zeros((20, 2)), 0.05 * np.sin(np.pi * s[:, 0])])
    there = home + s * (obj - home) + lift
    back = obj + s * (home - obj) + lift
    save_template(Template(name="away", path=np.vstack([there, back]), icps={"home": home, "object": obj},
                           segments=[Segment("reach", 0, 20, False), Segment("back", 20, 40, False)],
                           units="m"), folder / "away.yaml")


def test_a_free_end_out_of_reach_is_pulled_into_reach_and_said(tmp_path, capsys):
    """The retract's end is free (home = none): its demonstrated end is 0.87 m from the arm's
    base; the run pulls the free part in, says so in the trace, and ends; the waypoints the bound
    ICPs place are moved as planned."""
    _away_template(tmp_path)
    text = ("import away\npoint p = (0.30, -0.05, 0.65)\nmain {\n    run away.reach(object = p, home = none)\n"
            "    run away.back(object = p, home = none)\n}\n")
    code, out, err = _run(tmp_path, capsys, text, "exec")
    assert code == 0, err
    line = next(x for x in out.splitlines() if "run away.back" in x)
    assert "note: the free end of 'away.back' (waypoints" in line and "home = none, end unbound" in line
    assert "pulled into reach in" in line and "where the demonstration went" in line
    end = np.array([float(v) for v in line.split(" -> (")[1].split(")")[0].split(",")])
    assert reach.beyond(end) <= 0  # it ends inside the bound
    from hila_lang.engine.run import PULL

    from hila_lang.hierarchy.step import free_tail, hila_step
    from hila_lang.osila.template import load_template

    sub = load_template(tmp_path / "away.yaml").sub("back")
    planned = hila_step(sub, {"object": np.array([0.30, -0.05, 0.65]), "home": None}, np.array([0.30, -0.05, 0.65]))
    tail = free_tail(sub, planned.icps)
    assert 0 < tail < len(sub.path)  # the start and the object place the first waypoints
    assert reach.beyond(planned.path[-1]) > 0  # as demonstrated, it would leave the bound
    pulls = int(line.split("pulled into reach in ")[1].split(" ")[0])
    assert 1 <= pulls and f"to {PULL ** pulls:.0%} of its length" in line


def test_a_bound_end_out_of_reach_is_still_the_located_error(tmp_path, capsys):
    _away_template(tmp_path)
    text = ("import away\npoint p = (0.30, -0.05, 0.65)\nmain {\n    run away.reach(object = p, home = none)\n"
            "    let far = (-0.4, -0.7, 1.0)\n    run away.back(object = p, home = far)\n}\n")
    code, out, err = _run(tmp_path, capsys, text, "exec")
    assert code == 1
    assert err.splitlines()[0].startswith("p.hila:6:5: error: cannot reach the target home = (-0.400, -0.700, 1.000) "
                                          "of 'away.back': it is 0.8")
    assert "pulled" not in out


def test_check_notes_a_free_end_before_the_run_and_not_a_placed_one(tmp_path, capsys):
    _away_template(tmp_path)
    text = ("import away\npoint p = (0.30, -0.05, 0.65)\nmain {\n    run away.reach(object = p, home = none)\n"
            "    run away.back(object = p, home = none)\n}\n")
    code, out, err = _run(tmp_path, capsys, text, "check")
    assert code == 0 and err.splitlines() == [
        "p.hila:5:5: note: the end of 'away.back' is free (home = none; 'end' not bound): waypoints 11-20 of 20 go "
        "where the demonstration went, ending 1.033 m from the nearest bound ICP ('object'), wherever the bound "
        "points are; where that leaves the arm's reach a run made in one move (no track, a still scene) pulls them in and says so in the trace; bind 'end' to "
        "say where it ends"]  # the reach ends at the object it binds: placed, no note
    code, _, err = _run(tmp_path, capsys, text.replace("back(object = p, home = none)", "back(object = p, home = p)"),
                        "check")
    assert code == 0 and err == ""  # its end bound (home): placed
    # the shipped game: its retract's end is free (hand = none), its reach and its mark are placed
    code = cli.main(["check", "programs/game.hila"])
    err = capsys.readouterr().err
    assert code == 0 and len(err.splitlines()) == 1 and err.startswith("programs/game.hila:47:5: note: the end of "
                                                                       "'circle.retract' is free (hand = none;")
