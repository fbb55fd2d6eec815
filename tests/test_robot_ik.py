"""Generated URDF, forward kinematics and IK of the torso + right arm."""

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from hila_lang.core import rotation
from hila_lang.robot import ik, model
from hila_lang.core.rotation import about_z, pose


@pytest.fixture(scope="module")
def urdf_text():
    return model.urdf_path().read_text()


@pytest.fixture(scope="module")
def chain(urdf_text):
    world_T_root = pose(about_z(model.ROOT_YAW), model.ROOT_POSITION)
    return ik.KinematicChain.from_urdf(urdf_text, model.PEN_TIP_LINK, world_T_root)


def test_generated_urdf_is_pruned_and_carries_pen_and_eyes(urdf_text):
    robot = ET.fromstring(urdf_text)
    links = {link.get("name") for link in robot.findall("link")}
    assert 40 <= len(links) <= 50  # the shipped model has 212
    assert {"pen", model.PEN_TIP_LINK, *model.EYE_LINKS.values(), "r_hand_dh_frame"} <= links
    assert not any("skin" in name for name in links)
    assert robot.find(".//collision") is None
    meshes = [m.get("filename") for m in robot.iter("mesh")]
    assert meshes and all(Path(m).is_absolute() and Path(m).is_file() for m in meshes)
    assert all(link.find("inertial") is not None for link in robot.findall("link"))


def test_chain_is_torso_plus_right_arm(chain):
    assert chain.names == model.ARM_CHAIN
    assert np.all(chain.lower < chain.upper)


def test_forward_kinematics_matches_pybullet(chain):
    from hila_lang.sim.client import import_pybullet, quiet_c_output

    pb = import_pybullet()
    with quiet_c_output():
        client = pb.connect(pb.DIRECT)
        robot = pb.loadURDF(
            str(model.urdf_path()), model.ROOT_POSITION, pb.getQuaternionFromEuler([0, 0, model.ROOT_YAW]),
            useFixedBase=True, physicsClientId=client,
        )
    try:
        index = {}
        for i in range(pb.getNumJoints(robot, physicsClientId=client)):
            info = pb.getJointInfo(robot, i, physicsClientId=client)
            index[info[1].decode()] = i
            index[info[12].decode()] = i
        rng = np.random.default_rng(3)
        for _ in range(5):
            q = rng.uniform(chain.lower, chain.upper)
            for name, value in zip(chain.names, q):
                pb.resetJointState(robot, index[name], value, physicsClientId=client)
            state = pb.getLinkState(robot, index[model.PEN_TIP_LINK], computeForwardKinematics=True, physicsClientId=client)
            pose = chain.forward(q)[0]
            np.testing.assert_allclose(pose[:3, 3], state[4], atol=1e-6)
            np.testing.assert_allclose(pose[:3, :3], np.reshape(pb.getMatrixFromQuaternion(state[5]), (3, 3)), atol=1e-6)
    finally:
        pb.disconnect(physicsClientId=client)


def test_jacobian_matches_finite_differences(chain):
    rng = np.random.default_rng(4)
    for _ in range(5):
        q = rng.uniform(chain.lower, chain.upper)
        jac, pose = chain.jacobian(q)
        h = 1e-6
        for i in range(chain.dof):
            dq = np.zeros(chain.dof)
            dq[i] = h
            plus, minus = chain.forward(q + dq)[0], chain.forward(q - dq)[0]
            np.testing.assert_allclose(jac[:3, i], (plus[:3, 3] - minus[:3, 3]) / (2 * h), atol=1e-6)
            # angular column: d(pen axis)/dq_i = omega_i x z
            dz = (plus[:3, 2] - minus[:3, 2]) / (2 * h)
            np.testing.assert_allclose(np.cross(jac[3:, i], pose[:3, 2]), dz, atol=1e-6)


def test_ik_reaches_forward_kinematics_targets_with_the_pen_vertical(chain):
    SEED_POSTURE = np.array(model.SEED_POSTURE)  # the iCub spec's seed (hila_lang.robot.model)

    rng = np.random.default_rng(5)
    for _ in range(10):
        target = np.array([rng.uniform(0.22, 0.40), rng.uniform(-0.20, 0.02), rng.uniform(0.575, 0.70)])
        result = ik.solve(chain, target, SEED_POSTURE)
        assert result.converged, (target, result.error)
        np.testing.assert_allclose(chain.tip_position(result.q), target, atol=1e-5)
        assert chain.forward(result.q)[0][2, 2] == pytest.approx(-1.0, abs=1e-5)  # pen axis points down
        assert np.all(result.q >= chain.lower) and np.all(result.q <= chain.upper)


def test_ik_never_leaves_the_limits_it_is_given(chain):
    SEED_POSTURE = np.array(model.SEED_POSTURE)  # the iCub spec's seed (hila_lang.robot.model)

    lower, upper = chain.lower.copy(), chain.upper.copy()
    lower[:3] = upper[:3] = 0.0  # torso frozen upright
    upper[6] = 0.6  # elbow hardly bent
    for target in ([0.25, -0.10, 0.58], [0.80, -0.10, 0.60]):
        result = ik.solve(chain, np.array(target), SEED_POSTURE, lower=lower, upper=upper)
        assert not result.converged and result.error > 1e-3
        assert np.all(result.q >= lower - 1e-12) and np.all(result.q <= upper + 1e-12)
        # the pose reported is the one the joints give
        np.testing.assert_allclose(chain.tip_position(result.q), result.position, atol=1e-12)


@pytest.mark.parametrize("seed", range(5))
def test_rotations_follow_one_convention(seed):
    """URDF rpy = Rz(yaw) Ry(pitch) Rx(roll); quaternions (x, y, z, w); the FK's Rodrigues fast
    path equals the one library's axis-angle rotation."""
    rng = np.random.default_rng(seed)
    r, p, y = rng.uniform(-1.5, 1.5, 3)

    def Rx(a):
        return np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])

    def Ry(a):
        return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])

    def Rz(a):
        return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])

    R = rotation.from_rpy((r, p, y))
    np.testing.assert_allclose(R, Rz(y) @ Ry(p) @ Rx(r), atol=1e-12)
    np.testing.assert_allclose(rotation.to_rpy(R), (r, p, y), atol=1e-9)
    q = rotation.to_quat(R)
    np.testing.assert_allclose(rotation.from_quat(q), R, atol=1e-12)
    np.testing.assert_allclose(q[:3] / np.linalg.norm(q[:3]), rotation.to_quat(R)[:3] / np.linalg.norm(q[:3]))
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = rng.uniform(-3, 3)
    # the forward kinematics' joint turns (Rodrigues, kept in three constant parts per joint)
    one = ik.KinematicChain(("j",), np.eye(4)[None], axis[None], np.eye(4), np.array([-4.0]), np.array([4.0]))
    np.testing.assert_allclose(one._turned(np.array([angle]))[0], rotation.from_axis_angle(axis, angle), atol=1e-12)
    np.testing.assert_allclose(one.forward(np.array([angle]))[0][:3, :3], rotation.from_axis_angle(axis, angle), atol=1e-12)
    np.testing.assert_allclose(rotation.about_z(y), Rz(y), atol=1e-12)


def test_force_limits_read_the_urdf_once_and_give_each_joint_s_effort(monkeypatch):
    """The arm's force limits come from one reading of the URDF (the game's start-up read it
    once per joint: ten parses of the iCub's model), and are the chain's joints' efforts."""
    from hila_lang.robot import spec as spec_module

    robot = spec_module.resolve("icub")
    robot.chain()  # the chain is cached; only the limits' own reading is counted
    reads = []
    real = spec_module.read
    monkeypatch.setattr(spec_module, "read", lambda path: reads.append(path) or real(path))
    forces = robot.force_limits()
    assert len(reads) == 1
    limits = robot.limits()
    assert forces == [limits[n]["effort"] for n in robot.chain().names] and len(forces) == robot.chain().dof



def test_an_aim_turns_with_the_jacobians_angular_rows_and_looks_where_it_is_told():
    """:func:`ik.aim` takes the Jacobian's angular rows from the forward kinematics (the world
    axes): they are :meth:`jacobian`'s rows 3-5 to the bit, the tip's pose too, at seeded
    postures of the iCub's gaze chain.  Aimed from the head straight ahead (the torso turned) at
    seeded points around its table, the eyes' +z then points at each within the tolerance, or a
    joint stops it at its limit."""
    import math

    from hila_lang.robot.eyes import GAZE_WEIGHTS

    chain = ik.KinematicChain.from_urdf(model.urdf_path().read_text(), "eyes_tilt_link",
                                        pose(about_z(model.ROOT_YAW), model.ROOT_POSITION))
    weights = np.array([GAZE_WEIGHTS.get(n, 0.0) for n in chain.names])
    rng = np.random.default_rng(4)
    for _ in range(40):
        q = rng.uniform(chain.lower, chain.upper)
        jac, tip = chain.jacobian(q)
        forward_tip, _, axes = chain.forward(q)
        assert np.array_equal(jac[3:], np.ascontiguousarray(axes.T)) and np.array_equal(tip, forward_tip)
    pinned = 0
    for _ in range(40):
        q0 = np.where(weights > 0, 0.0, rng.uniform(-0.3, 0.3, chain.dof))
        target = np.array([rng.uniform(-0.6, 0.1), rng.uniform(-0.5, 0.5), rng.uniform(-0.3, 0.5)])
        q, angle = ik.aim(chain, q0, target, weights)
        assert np.array_equal(q[weights == 0], q0[weights == 0])  # the torso is not the gaze's to move
        z, eye = chain.forward(q)[0][:3, 2], chain.forward(q)[0][:3, 3]
        d = (target - eye) / np.linalg.norm(target - eye)
        at_limit = bool(np.any(((q <= chain.lower + 1e-9) | (q >= chain.upper - 1e-9)) & (weights > 0)))
        if angle <= 1e-4:  # it looks there
            assert math.atan2(np.linalg.norm(np.cross(z, d)), z @ d) == pytest.approx(angle, abs=1e-12)
        else:  # a limit stops it
            assert at_limit
        pinned += at_limit
    assert pinned >= 3  # some aims end at a joint's limit
