"""Cheaper eye images that are the same images: links out of view left out of the render
(hila_lang.sim.culling), and an eye reading only the part of its sensor that sees a region
(hila_lang.robot.lens.sensor_window / through_lens).

One iCub is loaded for the module (the slow part); each check compares an image made the cheap
way with the one made the whole way, pixel for pixel."""

from __future__ import annotations

import numpy as np
import pytest

from hila_lang.core.errors import InputError
from hila_lang.robot import model
from hila_lang.robot.backend import PyBulletBackend
from hila_lang.robot.lens import sensor_window, true_lens
from hila_lang.sim.camera import Camera, intrinsics, look_at
from hila_lang.sim.culling import mesh_bounds
from hila_lang.worlds.tictactoe.board import Grid

GRID = Grid.game()


@pytest.fixture(scope="module")
def robot():
    backend = PyBulletBackend(GRID.paper())
    yield backend
    backend.close()


def _without_culling(sim, camera):
    culler, sim.culler = sim.culler, None
    try:
        return sim.render(camera)
    finally:
        sim.culler = culler


def _postures(robot, n=4, seed=3):
    """The arm at ``n`` seeded places over the sheet (and back where it was)."""
    rng = np.random.default_rng(seed)
    start = robot.body.arm_angles()
    for _ in range(n):
        x, y = rng.uniform(-0.08, 0.08, 2)
        robot.reset_hand(GRID.grid_to_world(x, y) + np.array([0.0, 0.0, rng.uniform(0.01, 0.08)]))
        yield
    robot.body.set_arm(start)


@pytest.mark.slow
def test_culled_images_are_the_same_images_and_leave_links_out(robot):
    sim = robot.sim
    assert sim.culler is not None and len(sim.culler.shapes[robot.body.id][0]) >= 30  # the iCub's meshes
    ideal = true_lens(1).render_camera
    hand = robot.body.link_position("r_hand")
    outside = Camera(intrinsics(320, 240, 70), look_at(hand + np.array([0.5, 0.6, 0.4]), hand), 320, 240)
    culled_by_eye = []
    for _ in _postures(robot):
        cameras = [Camera(ideal.K, robot.body.link_pose(model.EYE_LINKS[e]), ideal.width, ideal.height)
                   for e in ("left", "right")]
        for camera in [*cameras, outside]:
            fast = sim.render(camera)
            culled_by_eye.append(sim.culler.last_culled)
            assert np.array_equal(fast, _without_culling(sim, camera))
    # the eyes look down at the table: the legs, hips and head are never drawn for them
    assert min(c for k, c in enumerate(culled_by_eye) if k % 3 != 2) >= 15


@pytest.mark.slow
def test_an_eye_reading_a_region_gives_that_part_of_its_whole_image(robot):
    eyes = robot.eyes
    centre = GRID.grid_to_world(0.0, 0.0)
    region = centre + np.array([[-0.09, -0.09, 0.0], [0.09, -0.09, 0.0], [0.09, 0.09, 0.0], [-0.09, 0.09, 0.0]])
    for eye in ("left", "right"):
        whole = eyes.camera_image(eye)
        part = eyes.camera_image(eye, region=region)
        u0, v0, u1, v1 = sensor_window(region, eyes.calibration(eye), eyes.camera_pose(eye))
        assert part.rgb.shape == (v1 - v0, u1 - u0, 3) and (part.width, part.height) == (u1 - u0, v1 - v0)
        assert part.rgb.size < 0.6 * whole.rgb.size  # a glance reads much less than the whole sensor
        assert np.array_equal(part.rgb, whole.rgb[v0:v1, u0:u1])
        # its K places the world where the whole image's K does, shifted by the window's corner
        assert np.allclose(part.project(region), whole.project(region) - [u0, v0])
        assert part.dist == whole.dist
    far_away = region + np.array([0.0, 0.0, -50.0])  # nothing of it in view: the whole image
    assert eyes.camera_image("left", region=far_away).rgb.shape == (240, 320, 3)


def test_sensor_window_is_the_regions_projection_grown_and_clipped():
    from hila_lang.robot.lens import eye_calibration

    calib = eye_calibration("left")
    camera = look_at((0.0, 0.0, 0.5), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0))
    square = np.array([[-0.02, -0.02, 0.0], [0.02, -0.02, 0.0], [0.02, 0.02, 0.0], [-0.02, 0.02, 0.0]])
    u0, v0, u1, v1 = sensor_window(square, calib, camera, margin=3)
    cx, cy = calib.K[0, 2], calib.K[1, 2]
    assert u0 < cx < u1 and v0 < cy < v1  # the middle of the view
    assert 20 < u1 - u0 < 60 and 20 < v1 - v0 < 60  # 4 cm at 0.5 m: about 20 px each way, plus margins
    wide = sensor_window(square * 40, calib, camera)
    assert wide is None or wide == (0, 0, 320, 240)
    behind = square + np.array([0.0, 0.0, 1.0])
    assert sensor_window(behind, calib, camera) is None
    with pytest.raises(InputError, match=r"region must be finite world points of shape \(N, 3\)"):
        sensor_window(np.array([1.0, 2.0]), calib, camera)
    with pytest.raises(InputError, match="region"):
        sensor_window(np.full((2, 3), np.nan), calib, camera)


def test_mesh_bounds_read_binary_and_text_meshes(tmp_path):
    rng = np.random.default_rng(0)
    tri = rng.uniform(-2, 3, (5, 3, 3)).astype(np.float32)
    rows = np.zeros(5, dtype=np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")]))
    rows["v"] = tri
    binary = tmp_path / "part.stl"
    binary.write_bytes(b"\0" * 80 + np.uint32(5).tobytes() + rows.tobytes())
    lo, hi = mesh_bounds(str(binary))
    assert np.allclose(lo, tri.reshape(-1, 3).min(axis=0)) and np.allclose(hi, tri.reshape(-1, 3).max(axis=0))
    text = tmp_path / "part_text.stl"
    text.write_text("solid x\n" + "".join(f"  vertex {a} {b} {c}\n" for a, b, c in tri.reshape(-1, 3)) + "endsolid x\n")
    assert np.allclose(mesh_bounds(str(text))[1], hi)
    obj = tmp_path / "part.obj"
    obj.write_text("# a mesh\nv 1 2 3\nv -1 5 0\nvn 0 0 1\nf 1 2 1\n")
    assert mesh_bounds(str(obj)) == ((-1.0, 2.0, 0.0), (1.0, 5.0, 3.0))
    (tmp_path / "part.dae").write_text("<COLLADA/>")
    assert mesh_bounds(str(tmp_path / "part.dae")) is None  # unknown extent: never left out
    assert mesh_bounds(str(tmp_path / "missing.stl")) is None
