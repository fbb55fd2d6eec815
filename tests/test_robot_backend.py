"""The PyBullet iCub back end: reaching, drawing, ink, joint limits, cameras, errors.

One robot is loaded per module (loading is the slow part); tests that need a clean sheet use
their own small moves and check only what they drew.
"""

import numpy as np
import pytest

from hila_lang.core.errors import InputError, UnreachableError
from hila_lang.plugins.protocols import Backend
from hila_lang.plugins.options import RunOptions
from hila_lang.sim.surface import Scene
from hila_lang.metrics import correlation
from hila_lang.robot.backend import PyBulletBackend, make_backend
from hila_lang.sim.canvas import INK_RGB
from hila_lang.worlds.tictactoe.board import Grid, cell_center, cell_corners

LIFT = np.array([0.0, 0.0, 0.02])
#: the game board (its sheet is what the back end knows)
GRID = Grid.game()


@pytest.fixture(scope="module")
def robot():
    backend = PyBulletBackend(GRID.paper())
    yield backend
    backend.close()


def circle(scene, cell, radius, n=90):
    right, far = scene.axes()
    angle = np.linspace(0, 2 * np.pi, n + 1)
    return cell_center(scene, cell) + radius * (np.cos(angle)[:, None] * right + np.sin(angle)[:, None] * far)


def park(robot):
    """Move the hand beside the board so cameras see all of it."""
    half = GRID.grid_size / 2
    robot.move(np.array([robot.hand_position() + LIFT, GRID.grid_to_world(half + 0.06, -half) + 4 * LIFT]))


@pytest.fixture(scope="module")
def drawn(robot):
    """Draw a circle in cell 3 (far-right) with images of the board before and after."""
    park(robot)
    before = robot.eyes.camera_image("left")
    planned = circle(GRID, 3, 0.018)
    robot.move(np.array([planned[0] + LIFT, planned[0]]), label="reach")
    robot.move(planned, pen_down=True, label="draw")
    trace = robot.traces[-1]
    park(robot)
    after = robot.eyes.camera_image("left")
    return planned, trace, before, after


def test_is_a_backend(robot):
    assert isinstance(robot, Backend) and robot.name == "pybullet"


@pytest.mark.slow
def test_every_cell_corner_is_reached_within_1_mm(robot):
    for cell in range(1, 10):
        for name, corner in cell_corners(GRID, cell).items():
            executed = robot.move(np.array([corner + LIFT, corner]), label=f"cell{cell}.{name}")
            assert np.linalg.norm(executed[-1] - corner) < 1e-3, (cell, name)
            assert np.linalg.norm(robot.hand_position() - corner) < 1e-3, (cell, name)
    assert not any(t.inked for t in robot.traces)  # pen up: no ink


def test_drawn_circle_inked_trace_correlates_with_the_plan(robot, drawn):
    planned, trace, _, _ = drawn
    touching = robot.ink.touching(trace.executed)
    assert trace.pen_down and trace.inked == touching.sum() > 0.9 * len(trace.executed)
    inked = trace.executed[touching]
    assert correlation(inked[:, :2], planned[:, :2]) >= 0.99
    tracking = np.linalg.norm(trace.executed - trace.reference, axis=1)
    assert np.median(tracking) < 1e-3 and tracking.max() < 3e-3


def test_ink_lands_in_the_paper_texture_under_the_planned_circle(robot, drawn):
    planned, _, _, _ = drawn
    image = robot.ink.ink_image().astype(int)
    pix = np.round(robot.ink.canvas.to_pixels(planned)).astype(int)
    colours = image[pix[:, 1], pix[:, 0]]
    ink = np.array(INK_RGB["robot"])
    assert np.mean(np.abs(colours - ink).sum(axis=1) < 120) > 0.95
    # and not at the circle's centre
    centre = np.round(robot.ink.canvas.to_pixels(cell_center(GRID, 3)[None])).astype(int)[0]
    assert np.abs(image[centre[1], centre[0]] - ink).sum() > 200


def test_joint_limits_are_never_exceeded_over_a_whole_drawing(robot, drawn):
    chain = robot.arm.chain
    joints = np.vstack([t.joints for t in robot.traces])
    assert len(joints) > 1000
    assert np.all(joints >= chain.lower) and np.all(joints <= chain.upper)


def test_eye_camera_sees_ink_where_it_was_drawn(drawn):
    planned, _, before, after = drawn
    assert after.rgb.shape == (240, 320, 3) and after.rgb.dtype == np.uint8
    uv = np.round(after.project(planned)).astype(int)
    assert np.all((uv >= 0) & (uv < [320, 240]))

    def blue(img):
        rgb = img.rgb[uv[:, 1], uv[:, 0]].astype(int)
        return (rgb[:, 2] - rgb[:, 0] > 40) & (rgb[:, 2] - rgb[:, 1] > 30)

    assert blue(after).mean() > 0.8
    assert blue(before).mean() < 0.05


def test_top_view_sees_the_grid_and_the_ink(robot, drawn):
    planned, _, _, _ = drawn
    top = robot.overview.top_view_image(240)
    assert top.rgb.shape == (240, 240, 3)
    uv = np.round(top.project(planned)).astype(int)
    rgb = top.rgb[uv[:, 1], uv[:, 0]].astype(int)
    assert np.mean(rgb[:, 2] - rgb[:, 0] > 40) > 0.8
    # cell 3 is far-right: top-right quadrant of the image
    assert np.all(uv[:, 0] > 120) and np.all(uv[:, 1] < 120)


def test_top_view_with_the_arm_aside_sees_the_ink_under_the_hand_and_puts_the_arm_back(robot, drawn):
    """A report's picture of the board (``arm_aside``): the hand held low over the drawn circle
    hides it from the top camera; aside, the circle is seen, and the arm is back where it was."""
    planned, _, _, _ = drawn
    centre = planned.mean(axis=0)
    robot.move(np.array([robot.hand_position() + LIFT, centre + LIFT]))
    q, tip = robot.arm.joint_positions(), robot.hand_position()
    state = robot.sim.pb.getJointStates(robot.body.id, robot.body.arm_joints, physicsClientId=robot.sim.client)

    def blue(image):
        uv = np.round(image.project(planned)).astype(int)
        rgb = image.rgb[uv[:, 1], uv[:, 0]].astype(int)
        return np.mean(rgb[:, 2] - rgb[:, 0] > 40)

    hidden, aside = blue(robot.overview.top_view_image(240)), blue(robot.overview.top_view_image(240, arm_aside=True))
    assert hidden < 0.5 and aside > 0.8
    assert np.array_equal(robot.arm.joint_positions(), q) and np.array_equal(robot.hand_position(), tip)
    after = robot.sim.pb.getJointStates(robot.body.id, robot.body.arm_joints, physicsClientId=robot.sim.client)
    assert [s[:2] for s in after] == [s[:2] for s in state]  # angles and velocities
    park(robot)


def test_unreachable_target_raises_and_the_arm_stays(robot):
    start = robot.hand_position()
    far = np.array([0.90, -0.10, 0.60])  # beyond the arm's kinematic reach bound: refused before any IK
    with pytest.raises(UnreachableError, match=r"cannot reach \(0\.900, -0\.100, 0\.600\) m: it is 0\.903 m from the "
                       r"arm's base"):
        robot.move(np.array([start, far]), label="reach cell")
    behind = np.array([-0.05, -0.45, 0.95])  # inside the bound, but the IK cannot get the pen there
    with pytest.raises(UnreachableError, match=r"cannot reach \(-0\.050, -0\.450, 0\.950\) m \(waypoint 2 of 2\): "
                       r"the pen gets no closer than \d+\.\d mm") as info:
        robot.move(np.array([start, behind]), label="reach cell")
    assert info.value.exit_code == 1 and info.value.state == "reach cell"
    assert "(in state reach cell)" in str(info.value)
    np.testing.assert_allclose(robot.hand_position(), start, atol=1e-9)
    below = cell_center(GRID, 5) - np.array([0, 0, 0.01])
    with pytest.raises(UnreachableError, match=r"10\.0 mm below the paper"):
        robot.move(np.array([below]))


@pytest.mark.parametrize("path", [np.zeros(3), np.zeros((0, 3)), np.zeros((4, 2)), [[0.3, 0.0, float("nan")]], "abc"])
def test_malformed_path_is_an_input_error(robot, path):
    with pytest.raises(InputError, match="path"):
        robot.move(path)


def test_reset_hand_puts_the_pen_there_at_once(robot):
    point = cell_center(GRID, 7) + np.array([0, 0, 0.1])
    n = len(robot.traces)
    robot.reset_hand(point)
    np.testing.assert_allclose(robot.hand_position(), point, atol=1e-4)
    assert len(robot.traces) == n
    with pytest.raises(UnreachableError):
        robot.reset_hand([1.5, 0.0, 0.6])


def test_markers_and_textured_quads_show_in_the_eye_cameras(robot):
    point = cell_center(GRID, 8) + np.array([0, 0, 0.02])
    marker = robot.sim.add_sphere(0.012, (0.0, 1.0, 0.0, 1.0))
    robot.sim.set_position(marker, point)
    image = robot.eyes.camera_image("right")
    u, v = np.round(image.project(point[None])[0]).astype(int)
    r, g, b = image.rgb[v, u].astype(int)
    assert g > r + 60 and g > b + 60
    robot.sim.remove(marker)
    # a red square facing the left eye, 0.3 m in front of it
    eye = robot.eyes.camera_pose("left")
    pose = eye.copy()
    pose[:3, 3] = eye[:3, 3] + 0.3 * eye[:3, 2]
    pose[:3, :3] = eye[:3, :3] @ np.diag([1.0, -1.0, -1.0])  # quad +z towards the camera
    square = np.zeros((8, 8, 3), np.uint8)
    square[:] = (220, 0, 0)
    quad = robot.sim.add_quad(square, pose, (0.05, 0.05))
    rgb = robot.eyes.camera_image("left").rgb[120, 160].astype(int)
    robot.sim.remove(quad)
    assert rgb[0] > 120 and rgb[1] < 60 and rgb[2] < 60


def _marker_offsets(robot, image_of, n=16, seed=7):
    """Per random small sphere 0.10-0.20 m in front of each eye: where it is seen minus where
    ``image_of(eye)``'s own model says it is (pixels, (2 * n, 2))."""
    from hila_lang.perception.distortion import distort_points
    from hila_lang.perception.extraction import detect_marker
    from hila_lang.robot.eyes import ICUB_EYE_K
    from hila_lang.sim.camera import pixel_rays

    rng = np.random.default_rng(seed)
    marker = robot.sim.add_sphere(0.005, (0.0, 1.0, 0.0, 1.0))
    offsets = []
    for eye in ("left", "right"):
        pose = robot.eyes.camera_pose(eye)
        for _ in range(n):
            origin, ray = pixel_rays(rng.uniform([40, 30], [280, 210])[None], ICUB_EYE_K, pose)
            point = origin + rng.uniform(0.10, 0.20) * ray[0]
            robot.sim.set_position(marker, point)
            image = image_of(eye)
            seen = detect_marker(image.rgb)
            assert seen is not None, (eye, point)
            expected = image.project(point[None])
            if image.dist is not None:
                expected = distort_points(expected, image.K, image.dist)
            offsets.append(seen - expected[0])
    robot.sim.remove(marker)
    return np.array(offsets)


@pytest.mark.slow
def test_the_gl_projection_puts_a_marker_where_project_says():
    """The GL projection puts a small sphere's centroid at ``CameraImage.project`` (sub-pixel),
    rendered as an ideal pinhole at an eye's pose.

    The textbook ``cx + 0.5, cy + 0.5`` put it (+0.48, -0.50) px off; PyBullet's tiny renderer
    needs ``cx`` and ``cy + 1`` (:func:`hila_lang.sim.camera.gl_projection_matrix`).  The
    markers are 0.10-0.20 m in front of the eye, with the arm at rest by the robot's side (a
    drawing arm crosses the right eye's view there); one sample's centroid is quantised by the
    renderer's hard edges (about 0.1 px), the bias is what the fix removed.
    """
    from hila_lang.robot import model
    from hila_lang.robot.eyes import ICUB_EYE_K
    from hila_lang.sim.camera import Camera, CameraImage

    def pinhole(eye):
        camera = Camera(ICUB_EYE_K, robot.body.link_pose(model.EYE_LINKS[eye]), 320, 240)
        return CameraImage(robot.sim.render(camera), camera.K, camera.world_T_camera, 320, 240)

    robot = PyBulletBackend(arm="rest")
    try:
        offsets = _marker_offsets(robot, pinhole)
    finally:
        robot.close()
    assert np.abs(offsets.mean(axis=0)).max() < 0.05, offsets.mean(axis=0)  # the bias, px
    assert np.median(np.linalg.norm(offsets, axis=1)) < 0.2, offsets
    assert np.linalg.norm(offsets, axis=1).max() < 0.35, offsets


@pytest.mark.slow
def test_an_eye_image_matches_the_lens_the_robot_calibrated():
    """Through the fish-eye lens, a marker is where the robot's own calibration (``K``, ``dist``)
    and the pose from its joint angles put it (measured: median 0.33 px, max 0.45 px; the
    calibration's principal point is 0.1-0.3 px off), and the distortion is real: the same
    image read as an ideal pinhole misses by up to 7.8 px (median 3.2 px) at these points."""
    from hila_lang.perception.distortion import TRUE_DISTORTION

    robot = PyBulletBackend(arm="rest")
    try:
        offsets = _marker_offsets(robot, robot.eyes.camera_image, n=10, seed=3)
        image = robot.eyes.camera_image("left")
        ideal = _marker_offsets(robot, lambda eye: type(image)(**{**robot.eyes.camera_image(eye).__dict__,
                                                                   "dist": None}), n=4, seed=3)
    finally:
        robot.close()
    assert np.median(np.linalg.norm(offsets, axis=1)) < 0.5, offsets
    assert np.linalg.norm(offsets, axis=1).max() < 1.0, offsets
    assert np.linalg.norm(ideal, axis=1).max() > 5.0
    np.testing.assert_allclose(image.dist[:2], TRUE_DISTORTION[:2], atol=0.01)  # k1, k2 recovered
    assert image.dist is not None and image.K[0, 0] == pytest.approx(257.34, abs=0.5)


def test_repeated_eye_images_of_the_same_view_are_identical(robot):
    """The head re-aim is exact: no drift between calls, and the same after looking elsewhere."""
    first = robot.eyes.camera_image("left")
    second = robot.eyes.camera_image("left")
    np.testing.assert_array_equal(first.world_T_camera, second.world_T_camera)
    np.testing.assert_array_equal(first.rgb, second.rgb)
    target = GRID.grid_to_world(0.0, 0.0)
    assert robot.eyes.look_at(target + [0.05, 0.10, 0.0]) < 1e-3
    assert robot.eyes.look_at(target) < 1e-3  # converges even with the eyes' tilt at its limit
    np.testing.assert_allclose(robot.eyes.camera_image("left").world_T_camera, first.world_T_camera, atol=1e-9)


def test_ink_polyline_draws_without_the_robot(robot):
    centre = cell_center(GRID, 1)  # far-left cell: top-left of the texture
    robot.ink.ink_polyline(np.array([centre - [0.01, 0, 0], centre + [0.01, 0, 0]]), color="opponent")
    image = robot.ink.ink_image()
    red = (image[:, :, 0] > 150) & (image[:, :, 1] < 80)
    rows, cols = np.nonzero(red)
    assert len(rows) > 20
    assert rows.max() < image.shape[0] / 2 and cols.max() < image.shape[1] / 2
    with pytest.raises(InputError):
        robot.ink.ink_polyline(np.zeros((0, 3)))


def test_demonstration_scene_sheet_is_in_both_eyes_and_the_arm_out_of_the_way(capfd):
    board = Grid.demonstration()
    with PyBulletBackend(board.paper()) as demo:
        out, err = capfd.readouterr()
        assert out == "" and err == ""  # nothing from the URDF importer reaches the console
        for eye in ("left", "right"):
            image = demo.eyes.camera_image(eye)
            uv = image.project(board.paper_corners())
            assert np.all((uv > 0) & (uv < [320, 240])), (eye, uv)
            # the sheet's centre pixel is paper, not the robot's hand
            u, v = np.round(image.project(board.grid_to_world(0.05, 0.05)[None])[0]).astype(int)
            assert np.ptp(image.rgb[v, u].astype(int)) < 20 and image.rgb[v, u].min() > 120


def test_make_backend_uses_the_worlds_scene_and_gui_needs_a_display(monkeypatch):
    spec = Grid((0.30, -0.08), 0.12, 0.0, 0.571).paper()
    with make_backend(Scene(surface=spec), RunOptions(seed=3), {}) as backend:
        assert backend.surface == spec and backend.ink.surface == spec
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(InputError, match="needs a display"):
        PyBulletBackend(gui=True)


def run_snapshot(*argv):
    """``hila snapshot ARGV`` through the command module (independent of the CLI registry)."""
    import argparse

    from hila_lang.commands import snapshot

    parser = argparse.ArgumentParser()
    snapshot.add_arguments(parser)
    return snapshot.run(parser.parse_args(list(argv)))


SNAPSHOT_SCRIPT = (
    "import argparse, sys\n"
    "from hila_lang.commands import snapshot\n"
    "parser = argparse.ArgumentParser()\n"
    "snapshot.add_arguments(parser)\n"
    "sys.exit(snapshot.run(parser.parse_args(sys.argv[1:])))\n"
)


def test_snapshot_command_writes_two_pngs(tmp_path, capsys):
    import cv2

    assert run_snapshot("--out", str(tmp_path), "--size", "200") == 0
    eye = cv2.imread(str(tmp_path / "eye_left.png"))
    top = cv2.imread(str(tmp_path / "board_top.png"))
    assert eye.shape == (240, 320, 3) and top.shape == (200, 200, 3)
    assert capsys.readouterr().out.split() == [str(tmp_path / "eye_left.png"), str(tmp_path / "board_top.png")]
    # the opponent's cross (red) and the robot's circle (blue) are both on the board
    rgb = top[:, :, ::-1].astype(int)
    assert ((rgb[:, :, 0] - rgb[:, :, 2]) > 80).sum() > 50
    assert ((rgb[:, :, 2] - rgb[:, :, 0]) > 60).sum() > 50
    with pytest.raises(InputError, match="--cell must be 1..9"):
        run_snapshot("--out", str(tmp_path), "--cell", "12")
    with pytest.raises(SystemExit) as refused:  # argparse's type, as for every command's --seed
        run_snapshot("--out", str(tmp_path), "--seed", "-3")
    assert refused.value.code == 2
    assert "argument --seed: expected a whole number >= 0, got -3" in capsys.readouterr().err


def test_nothing_but_the_paths_reaches_the_console(tmp_path):
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-c", SNAPSHOT_SCRIPT, "--out", str(tmp_path), "--size", "64"],
        capture_output=True, text=True, timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == [str(tmp_path / "eye_left.png"), str(tmp_path / "board_top.png")]
    assert done.stderr == ""


def test_the_paper_can_be_moved_during_a_run_and_keeps_its_ink():
    """A world may nudge the sheet between moves (a referee's perturbation): the quad moves, the
    ink stays on the sheet, and contact follows the sheet."""
    sheet = GRID.paper()
    with PyBulletBackend(sheet, arm="rest") as robot:
        robot.ink.ink_polyline(np.array([sheet.to_world(-0.02, 0.0), sheet.to_world(0.02, 0.0)]), color="black")
        before = robot.overview.top_view_image(160).rgb
        ink = robot.ink.ink_image()
        moved = sheet.moved(center=(sheet.center[0] + 0.03, sheet.center[1] - 0.02), rotation=sheet.rotation + 0.2)
        robot.ink.move_to(moved)
        assert np.array_equal(robot.ink.ink_image(), ink)
        assert robot.ink.touching(np.array([moved.to_world(0.09, 0.13)]))[0]
        assert not robot.ink.touching(np.array([sheet.to_world(-0.10, -0.14)]))[0]
        assert not np.array_equal(robot.overview.top_view_image(160).rgb, before)
        with pytest.raises(InputError, match="stays on the table"):
            robot.ink.move_to(moved.moved(z=moved.z + 0.01))


def test_every_render_is_counted_for_the_benchmarks(robot):
    n, seconds = robot.stats["renders"], robot.stats["render_seconds"]
    robot.eyes.camera_image("right")
    robot.overview.top_view_image(64)
    assert robot.stats["renders"] == n + 2 and robot.stats["render_seconds"] > seconds


def test_an_eye_image_carries_what_the_robot_knows_to_place_it(robot):
    """Joint angles + the eye's kinematic chain give the camera pose by forward kinematics."""
    for eye in ("left", "right"):
        image = robot.eyes.camera_image(eye)
        chain = robot.eyes.chain(eye)
        assert set(chain.names) <= set(image.joints) and "neck_pitch" in chain.names
        world_T_eye = chain.forward(np.array([image.joints[n] for n in chain.names]))[0]
        np.testing.assert_allclose(world_T_eye, image.world_T_camera, atol=1e-6)


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
    """Links out of a camera's view are left out of its image (hila_lang.sim.culling): the
    eyes' images and an outside view, at several arm postures, equal those drawn with every link."""
    sim = robot.sim
    assert sim.culler is not None and len(sim.culler.shapes[robot.body.id][0]) >= 30  # the iCub's meshes
    from hila_lang.robot import model
    from hila_lang.robot.lens import true_lens
    from hila_lang.sim.camera import Camera, intrinsics, look_at

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
    """A glance's fovea (``camera_image(region=...)``) is those pixels of the whole image."""
    from hila_lang.robot.lens import sensor_window

    eyes = robot.eyes
    centre = GRID.grid_to_world(0.0, 0.0)
    region = centre + np.array([[-0.09, -0.09, 0.0], [0.09, -0.09, 0.0], [0.09, 0.09, 0.0], [-0.09, 0.09, 0.0]])
    render, canvases = eyes.render, []

    def sized(camera, **kw):  # what the renderer is asked for: only the part the window needs
        canvases.append(camera.width * camera.height)
        return render(camera, **kw)

    eyes.render = sized
    try:
        whole = eyes.camera_image("left")
        eyes.camera_image("left", region=region)
    finally:
        eyes.render = render
    assert canvases[1] < 0.5 * canvases[0]
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


def test_the_head_aims_the_same_whether_the_aim_is_kept_or_solved_again(robot):
    """:meth:`Eyes.look_at` keeps an aim per (torso, point): a second look at the same point with
    the torso unchanged sets the head exactly as a fresh solve does, a new point is solved."""
    from hila_lang.robot import eyes as eyes_module

    eyes = robot.eyes
    original = eyes.target
    point = np.array(GRID.grid_to_world(0.01, -0.02))
    names = [n for n in eyes._gaze_chain.names if n in robot.body.held]
    eyes.look_at(point)
    first = robot.body.angles(names)
    calls = []
    solve = eyes_module.aim_gaze
    eyes_module.aim_gaze = lambda *a: calls.append(a) or solve(*a)
    try:
        eyes.look_at(point + 0.0)  # kept: no solve, the same angles
        assert calls == [] and robot.body.angles(names) == first
        eyes._aims.clear()
        eyes.look_at(point)  # solved again: the same angles bit for bit
        assert len(calls) == 1 and robot.body.angles(names) == first
        eyes.look_at(point + np.array([0.03, 0.0, 0.0]))  # another point: solved, another aim
        assert len(calls) == 2 and robot.body.angles(names) != first
    finally:
        eyes_module.aim_gaze = solve
        eyes.look_at(original)
