"""Cameras: the PyBullet render agrees with the pinhole model; the lens model round-trips."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pybullet")
pytest.importorskip("cv2")

from hila_lang.sim.camera import Camera, intrinsics, look_at, pixel_rays, project  # noqa: E402
from hila_lang.perception.distortion import (  # noqa: E402
    TRUE_DISTORTION,
    DistortedCamera,
    distort_points,
    undistort_image,
    undistort_points,
)
from hila_lang.perception.extraction import detect_marker  # noqa: E402
from hila_lang.worlds.tictactoe.recording import DemonstrationScene, demonstration_rig  # noqa: E402


@pytest.fixture(scope="module")
def world():
    with DemonstrationScene(table=False, paper=False) as w:
        yield w


def test_rendered_marker_centre_matches_projection(world):
    """The GL matrices put a sphere where K and world_T_camera say (sub-pixel)."""
    cam = Camera(intrinsics(320, 240, 64.0), look_at([0.0, 0.05, 0.9], [0.35, -0.05, 0.4]), 320, 240)
    rng = np.random.default_rng(3)
    errors = []
    for _ in range(6):
        point = np.array([0.35, -0.05, 0.45]) + rng.uniform(-0.08, 0.08, 3)
        world.set_marker(point)
        uv = detect_marker(world.render(cam.with_size(640, 480, 2.0)))
        uv = (uv + 0.5) / 2 - 0.5  # back to 320x240 pixel coordinates
        errors.append(np.linalg.norm(uv - project(point, cam.K, cam.world_T_camera)[0]))
    assert max(errors) < 0.15, errors


def test_look_at_sees_right_side_on_the_right():
    """Facing +x, the robot's right (-y) appears at larger u."""
    cam = look_at([0, 0, 1], [1, 0, 1])
    K = intrinsics(320, 240, 60)
    left_pt, right_pt = project(np.array([[1, 0.2, 1], [1, -0.2, 1]]), K, cam)
    assert right_pt[0] > 160 > left_pt[0]


@pytest.mark.parametrize("seed", range(3))
def test_distort_undistort_round_trip(seed):
    K = intrinsics(320, 240, 64)
    uv = np.random.default_rng(seed).uniform([0, 0], [320, 240], (50, 2))
    back = undistort_points(distort_points(uv, K, TRUE_DISTORTION), K, TRUE_DISTORTION)
    assert np.abs(back - uv).max() < 1e-4
    # barrel distortion pulls points towards the centre
    d = distort_points(uv, K, TRUE_DISTORTION)
    centre = K[:2, 2]
    assert np.all(np.linalg.norm(d - centre, axis=1) <= np.linalg.norm(uv - centre, axis=1) + 1e-9)


def test_distorted_camera_images_the_marker_where_the_lens_model_says(world):
    rig = demonstration_rig()
    dcam = DistortedCamera(rig.left)
    o, d = pixel_rays(np.array([[45.0, 40.0]]), rig.left.K, rig.left.world_T_camera)
    point = o + 0.6 * d[0]  # near the image's corner, where the distortion is strong
    world.set_marker(point)
    img = dcam.distort(world.render(dcam.render_camera))
    assert img.shape == (240, 320, 3)
    ideal = project(point, rig.left.K, rig.left.world_T_camera)
    seen = detect_marker(img)
    expected = distort_points(ideal, rig.left.K, TRUE_DISTORTION)[0]
    assert np.linalg.norm(seen - expected) < 0.15
    assert np.linalg.norm(ideal[0] - expected) > 3  # the lens really moved it
    # undistorting the image brings the marker back to the ideal projection
    und = undistort_image(img, rig.left.K, TRUE_DISTORTION)
    assert np.linalg.norm(detect_marker(und) - ideal[0]) < 0.3
