"""The arm you have (issue 33): a robot is a declared description -- the iCub, the Panda and the
KUKA shipped, any arm from its URDF -- with its reach computed from its chain, its meshes found
from ``package://`` URIs, every refusal located, and eyes on a stand for an arm without a head.

The arm that hila does not ship is ``tests/data/robots/hila_test_arm`` (a 4-joint arm with a
continuous yaw joint, its one mesh given as ``package://hila_test_arm/meshes/box.obj``); nothing
in ``hila_lang`` knows it by name.
"""

from __future__ import annotations

import ast
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from hila_lang import cli
from hila_lang.core.errors import InputError
from hila_lang.robot import spec as S

ROOT = Path(__file__).resolve().parent.parent
ARM = ROOT / "tests" / "data" / "robots" / "hila_test_arm"
ARM_URDF = ARM / "urdf" / "arm4.urdf"


def run_cli(capsys, *argv: str) -> tuple[int, str, str]:
    code = cli.main([str(a) for a in argv])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return code, captured.out, captured.err


# --------------------------------------------------------------------------- finding a robot
def test_the_shipped_robots_are_plug_ins_with_their_chains():
    from hila_lang.plugins import registry

    assert {"icub", "panda", "kuka"} <= set(registry.names("robot"))
    chains = {name: S.resolve(name).chain() for name in ("icub", "panda", "kuka")}
    assert chains["icub"].dof == 10 and chains["icub"].names[0] == "torso_pitch"
    assert chains["panda"].names == tuple(f"panda_joint{i}" for i in range(1, 8))
    assert chains["kuka"].names == tuple(f"lbr_iiwa_joint_{i}" for i in range(1, 8))
    assert S.resolve().name == "icub"  # the default


def test_a_bare_urdf_gets_the_stated_defaults_and_a_found_flange():
    spec = S.resolve(str(ARM_URDF))
    assert spec.tip == "flange" and spec.base_link == "base"  # the flange found below the last movable joint
    assert spec.pen_length == S.DEFAULT_PEN and spec.eyes is not None  # a rig on a stand
    (cx, cy, cz), radius = spec.reach()
    # the base stands behind the sheet's centre at half its reach radius (0.30-0.60 m), 2 cm below the table
    distance = spec.sheet_center[0] - spec.base_position[0]
    assert distance == pytest.approx(min(max(0.5 * radius, 0.30), 0.60))
    assert spec.base_position[2] == pytest.approx(0.57 - S.PEDESTAL_BELOW_TABLE)
    # the seed posture it found holds the pen vertical 0.10 m above the sheet's centre
    chain = spec.chain()
    tip = chain.forward(np.array(spec.seed))[0]
    assert np.linalg.norm(tip[:3, 3] - [*spec.sheet_center, 0.67]) < 1e-3
    assert tip[:3, 2] @ [0, 0, -1] > 0.999


def test_a_continuous_joint_is_accepted_with_a_whole_turn_each_way():
    chain = S.resolve(str(ARM_URDF)).chain()
    assert chain.names == ("yaw", "shoulder", "elbow", "wrist_pitch")
    assert chain.lower[0] == pytest.approx(-2 * np.pi) and chain.upper[0] == pytest.approx(2 * np.pi)
    assert chain.lower[1] == pytest.approx(-1.2)


def test_nothing_in_hila_knows_the_test_arm_by_name():
    for path in (ROOT / "hila_lang").rglob("*"):
        if path.is_file() and path.suffix in (".py", ".yaml", ".lark", ".hila"):
            text = path.read_text(encoding="utf-8", errors="ignore")
            assert "hila_test_arm" not in text and "arm4" not in text and "xarm" not in text, path


@pytest.mark.parametrize("name", ["icub", "panda", "kuka", "arm4"])
def test_the_reach_bound_holds_every_posture_and_is_computed_from_the_chain(name):
    spec = S.resolve(str(ARM_URDF) if name == "arm4" else name)
    chain = spec.chain()
    centre, radius = spec.reach()
    computed = S.chain_reach(chain)
    assert computed[1] == pytest.approx(radius, abs=1e-3) and np.allclose(computed[0], centre, atol=1e-3)
    rng = np.random.default_rng(3)
    lo, hi = np.maximum(chain.lower, -np.pi), np.minimum(chain.upper, np.pi)
    far = max(np.linalg.norm(chain.tip_position(rng.uniform(lo, hi)) - centre) for _ in range(3000))
    assert far <= radius + 1e-9  # sound ...
    assert far > 0.6 * radius  # ... and not a loose constant


def test_check_uses_the_chosen_robots_reach(tmp_path, capsys):
    prog = tmp_path / "far.hila"
    prog.write_text("import reach\npoint home = (0.18, -0.25, 0.75)\npoint far = (0.78, -0.09, 0.60)\n"
                    "hand at home\nmain {\n    run reach.reach(object = far, home = home)\n}\n")
    code, _, err = run_cli(capsys, "check", prog)  # the iCub: 0.78 m from its torso, beyond its 0.776 m
    assert code == 2 and "which the arm cannot reach" in err and "moves the iCub's arm" in err
    code, out, err = run_cli(capsys, "check", prog, "--robot", "panda")
    assert code == 0, err
    code, _, err = run_cli(capsys, "check", prog, "--set", "robot=kuka")
    assert code == 0, err


# --------------------------------------------------------------------------- refusals, located
def _copy_arm(tmp_path: Path, edit=lambda text: text) -> Path:
    target = tmp_path / "arm"
    shutil.copytree(ARM, target)
    urdf = target / "urdf" / "arm4.urdf"
    urdf.write_text(edit(urdf.read_text()))
    return urdf


@pytest.mark.parametrize("args, message", [
    (["--set", "robot.tip=hand"], "the robot's tip 'hand' is not a link of the URDF"),
    (["--set", "robot.tip=upper_arm"], "the chain from 'base' to 'upper_arm' has 2 movable joints; an arm that "
                                       "holds a pen needs at least 3"),
    (["--set", "robot.tipp=flange"], "unknown setting --set robot.tipp"),
])
def test_a_bad_tip_or_setting_is_a_located_error(capsys, args, message):
    code, _, err = run_cli(capsys, "check", ROOT / "programs" / "reach_return.hila", "--robot", ARM_URDF, *args)
    assert code == 2
    assert message in err
    if "robot.tip=" in args[1]:
        assert err.startswith(f"{ARM_URDF}")  # FILE[:LINE]: error: ...


def test_a_tip_not_below_the_base_is_no_serial_chain(tmp_path, capsys):
    spec = tmp_path / "arm.yaml"
    spec.write_text(f"urdf: {ARM_URDF}\nbase_link: forearm\ntip: column\nseed: [0, 0, 0]\n")
    code, _, err = run_cli(capsys, "check", ROOT / "programs" / "reach_return.hila", "--robot", spec)
    assert code == 2
    assert "no serial chain from the base link 'forearm' to the tip 'column'" in err
    assert f"{ARM_URDF}:" in err


def test_a_prismatic_joint_on_the_chain_is_refused_at_its_line(tmp_path, capsys):
    urdf = _copy_arm(tmp_path, lambda t: t.replace('<joint name="elbow" type="revolute">',
                                                   '<joint name="elbow" type="prismatic">'))
    line = next(i for i, text in enumerate(urdf.read_text().splitlines(), 1) if '<joint name="elbow"' in text)
    code, _, err = run_cli(capsys, "check", ROOT / "programs" / "reach_return.hila", "--robot", urdf)
    assert code == 2
    assert f"{urdf}:{line}: error: joint 'elbow' on the chain to 'flange' is prismatic" in err


def test_malformed_urdf_unknown_robot_and_missing_file_are_bad_input(tmp_path, capsys):
    broken = tmp_path / "broken.urdf"
    broken.write_text('<robot name="x">\n  <link name="a">\n</robot>\n')
    code, _, err = run_cli(capsys, "check", ROOT / "programs" / "reach_return.hila", "--robot", broken)
    assert code == 2 and f"{broken}:3:" in err and "not well-formed" in err
    code, _, err = run_cli(capsys, "check", ROOT / "programs" / "reach_return.hila", "--robot", "pandaa")
    assert code == 2 and "unknown robot 'pandaa'" in err and "did you mean 'panda'" in err
    code, _, err = run_cli(capsys, "check", ROOT / "programs" / "reach_return.hila", "--robot", tmp_path / "no.urdf")
    assert code == 2 and "no such URDF file" in err
    code, _, err = run_cli(capsys, "check", ROOT / "programs" / "reach_return.hila", "--robot", "")
    assert code == 2 and "--robot needs a robot's name" in err
    code, _, err = run_cli(capsys, "check", ROOT / "programs" / "reach_return.hila", "--robot", "panda",
                           "--set", "robot.tip=panda_link3")  # 3 joints: no pen held vertical over the sheet
    assert code == 2 and "robot 'panda' cannot hold its pen vertical 0.10 m above the sheet's centre" in err


def test_the_icub_is_fixed(capsys):
    code, _, err = run_cli(capsys, "check", ROOT / "programs" / "reach_return.hila", "--set", "robot.tip=r_elbow")
    assert code == 2 and "robot 'icub' is fixed" in err


# --------------------------------------------------------------------------- package:// meshes
def _without_meshes(tmp_path: Path) -> tuple[Path, Path]:
    """The arm's URDF alone in one folder, its package in another (not above the URDF)."""
    alone = tmp_path / "alone"
    alone.mkdir()
    urdf = alone / "arm4.urdf"
    shutil.copy(ARM_URDF, urdf)
    packages = tmp_path / "packages"
    shutil.copytree(ARM, packages / "hila_test_arm")
    return urdf, packages


def test_package_meshes_are_found_beside_the_urdf_and_made_absolute():
    from hila_lang.robot.urdf import prepared_text

    text = prepared_text(S.resolve(str(ARM_URDF)))
    assert "package://" not in text
    meshes = {line.split('filename="')[1].split('"')[0] for line in text.splitlines() if "filename=" in line}
    assert meshes == {str((ARM / "meshes" / "box.obj").resolve())}


def test_a_missing_mesh_is_one_line_naming_it(tmp_path, capsys):
    urdf, _ = _without_meshes(tmp_path)
    code, _, err = run_cli(capsys, "check", ROOT / "programs" / "reach_return.hila", "--robot", urdf)
    assert code == 2
    first = err.splitlines()[0]
    assert first.startswith(f"{urdf}: error: mesh 'package://hila_test_arm/meshes/box.obj' of link 'base' not found")
    assert "robot.packages" in err  # the hint says what to do


def test_packages_setting_and_ros_package_path_find_the_meshes(tmp_path, monkeypatch):
    urdf, packages = _without_meshes(tmp_path)
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    with pytest.raises(InputError, match="not found"):
        S.resolve(str(urdf))
    assert S.resolve(str(urdf), {"robot.packages": str(packages)}).chain().dof == 4
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{tmp_path / 'nothing'}{os.pathsep}{packages}")
    assert S.resolve(str(urdf)).chain().dof == 4


# --------------------------------------------------------------------------- iCub constants stay in robot/
def test_no_icub_constant_is_imported_outside_the_robot_package():
    """An iCub constant: any name of ``hila_lang/robot/model.py`` (the iCub's spec), the iCub's
    eye intrinsics (``ICUB_*``) and its declared ``REACH``.  Outside ``hila_lang/robot/`` no
    module imports one (nor ``model`` itself)."""
    model = ast.parse((ROOT / "hila_lang" / "robot" / "model.py").read_text())
    icub = {t.id for node in model.body if isinstance(node, ast.Assign) for t in node.targets
            if isinstance(t, ast.Name) and t.id.isupper()} | {"REACH"}
    assert {"ARM_CHAIN", "ROOT_POSITION", "PEN_LENGTH", "SEED_POSTURE", "EYE_LINKS"} <= icub
    found = []
    for path in (ROOT / "hila_lang").rglob("*.py"):
        if (ROOT / "hila_lang" / "robot") in path.parents:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and "robot" in (node.module or ""):
                for alias in node.names:
                    if alias.name in icub or alias.name == "model" or alias.name.startswith("ICUB") \
                            or (node.module or "").endswith("robot.model"):
                        found.append(f"{path.relative_to(ROOT)}: {node.module}.{alias.name}")
    assert found == []


# --------------------------------------------------------------------------- in PyBullet
@pytest.mark.parametrize("name", ["panda", "arm4"])
def test_the_prepared_urdf_in_pybullet_agrees_with_the_spec_chain(name):
    from hila_lang.sim.scene import SimScene
    from hila_lang.robot.body import Body

    spec = S.resolve(str(ARM_URDF) if name == "arm4" else name)
    chain = spec.chain()
    with SimScene() as sim:
        body = Body(sim, spec)
        rng = np.random.default_rng(0)
        lo, hi = np.maximum(chain.lower, -np.pi), np.minimum(chain.upper, np.pi)
        for _ in range(5):
            q = rng.uniform(lo, hi)
            body.set_arm(q)
            pen = body.link_pose(spec.tip_link())
            mine = chain.forward(q)[0]
            assert np.linalg.norm(pen[:3, 3] - mine[:3, 3]) < 1e-6
            assert pen[:3, 2] @ mine[:3, 2] > 1 - 1e-9  # the pen's axis too


@pytest.fixture(scope="module")
def panda_backend():
    from hila_lang.robot.backend import PyBulletBackend

    backend = PyBulletBackend(robot=S.resolve("panda"))
    yield backend
    backend.close()


def test_the_rig_is_fixed_eyes_with_the_robots_own_calibration(panda_backend):
    from hila_lang.perception.rig import EYE_K

    eyes = panda_backend.eyes
    assert eyes.chain("left").dof == 0 and eyes.joints("left") == {}
    assert np.allclose(eyes.chain("right").forward(np.zeros(0))[0], eyes.camera_pose("right"))
    image = eyes.camera_image("right")
    assert image.rgb.shape == (240, 320, 3) and image.dist is not None
    assert not np.allclose(image.K, EYE_K) and np.allclose(image.K, EYE_K, atol=3.0)  # measured, not given
    # the pair's calibration measured the stand's baseline from chessboard images
    stereo = eyes.stereo()
    assert np.linalg.norm(stereo.right_T_left[:3, 3]) == pytest.approx(eyes.rig.baseline, abs=0.002)
    assert eyes.look_at(eyes.target) < 0.3 and eyes.look_at(eyes.camera_pose()[:3, 3] - [0, 0, 1]) > 0.5
    with pytest.raises(InputError, match="eye must be"):
        eyes.camera_image("middle")


def test_the_rig_sees_the_arm_it_outlines(panda_backend):
    """The body outline follows the joint angles: the pen's tip is its last capsule's end."""
    outline = panda_backend.eyes.body_outline()
    assert np.allclose(outline[-1][0][1], panda_backend.hand_position(), atol=1e-6)
    assert len(outline) == panda_backend.arm.chain.dof + 1


def test_a_urdf_hila_does_not_ship_runs_reach_return(capsys):
    code, out, err = run_cli(capsys, "exec", ROOT / "programs" / "reach_return.hila", "--backend", "pybullet",
                             "--robot", ARM_URDF, "--set", "robot.tip=flange")
    assert code == 0, err
    assert "result: finished" in out


def test_a_urdf_hila_does_not_ship_plays_the_game(tmp_path, capsys):
    """PyBullet's xArm 6 (its meshes ``package://xarm_description/...`` URIs), given as a bare
    URDF with its flange: the robot reads the board through the rig and wins or draws."""
    import pybullet_data

    urdf = Path(pybullet_data.getDataPath()) / "xarm" / "xarm6_robot.urdf"
    out = tmp_path / "game"
    code, stdout, err = run_cli(capsys, "exec", ROOT / "programs" / "game.hila", "--robot", urdf,
                                "--set", "robot.tip=link6", "--out", out, "--opponent", "random", "--seed", "1")
    assert code == 0, err
    report = json.loads((out / "report.json").read_text())
    assert report["robot"] == "xarm6_robot"
    assert report["result"] in ("robot", "draw")
    assert report["vision"]["misreads"] in (0, []) and report["marks_outside_cell"] == 0


def test_a_spec_file_names_the_urdf_relative_to_itself(tmp_path, capsys):
    target = tmp_path / "robots"
    shutil.copytree(ARM, target / "hila_test_arm")
    spec = target / "arm.yaml"
    spec.write_text("name: arm4\nurdf: hila_test_arm/urdf/arm4.urdf\ntip: flange\npen: {length: 0.12}\n")
    code, out, err = run_cli(capsys, "exec", ROOT / "programs" / "reach_return.hila", "--robot", spec)
    assert code == 0, err  # the dry back end, with the arm's own reach
    assert S.resolve(str(spec)).pen_length == 0.12


def test_the_studio_run_page_runs_and_shows_the_chosen_robot():
    """The Run page's robot choice reaches the run: the back end moves the Panda and the 3-D view
    (rendered by the simulator holding that arm) is not the iCub's."""
    pytest.importorskip("starlette")
    from hila_lang.studio.run import RunSession

    views = {}
    for robot in ("panda", None):
        session = RunSession(ROOT / "programs" / "reach_return.hila", lambda message: None, backend="pybullet",
                             robot=robot)
        try:
            assert session.interp.backend.robot.name == (robot or "icub")
            views[robot] = session.robot  # the 3-D view, a PNG data URL
        finally:
            session.close()
    assert views["panda"] and views[None] and views["panda"] != views[None]


@pytest.mark.slow
def test_a_demonstration_is_learned_through_the_rig(tmp_path):
    """``hila learn --from-sim --robot panda``: the demonstration recorded through the rig's
    cameras where they stand, learned by perception as for the iCub (a short recording, as
    ``tests/test_perception_pipeline.py`` makes for the iCub)."""
    from hila_lang.core.fileio import load_yaml
    from hila_lang.perception.learn import template_from_frames
    from hila_lang.robot.rig import rig_poses
    from hila_lang.worlds.tictactoe.board import Grid
    from hila_lang.worlds.tictactoe.recording import demonstration_rig, record_demonstration
    from hila_lang.worlds.tictactoe.vision import demonstration_icps

    panda = S.resolve("panda")
    rig = demonstration_rig(Grid.demonstration(), panda)
    assert np.allclose(rig.left.world_T_camera, rig_poses(panda.eyes)["left"])  # the rig does not turn
    out = tmp_path / "rec"
    record_demonstration(out, seed=0, n_calibration=16, n_stereo=8, frames=40, robot=panda)
    template = template_from_frames(out, read_icps=demonstration_icps)
    truth = load_yaml(out / "truth.yaml")
    for name in ("tl", "tr", "br", "bl"):
        assert np.linalg.norm(template.icps[name] - truth["icps"][name]) < 2e-3, name
    assert np.linalg.norm(template.icps["hand"] - truth["icps"]["hand"]) < 5e-3
