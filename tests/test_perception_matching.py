"""Scene matching (hila_lang.perception.matching) on rendered images of a printed map.

Two pinhole cameras 6.8 cm apart (the iCub's eyes' baseline) look at a map sheet, flat at one
pose (the demonstration) and moved, turned, smaller and bent at another (the task).  The truth
(where each matched feature really is on the sheet) only scores.
"""

import math

import numpy as np
import pytest

from hila_lang.perception import matching as M
from hila_lang.sim.camera import STUDIO, Camera, intersect_plane_z, look_at, project
from hila_lang.sim.sheet import Sheet
from hila_lang.worlds.picture.texture import map_texture

K = np.array([[257.34, 0.0, 160.0], [0.0, 257.34, 120.0], [0.0, 0.0, 1.0]])
EYES = {"left": np.array([0.08, 0.034, 0.88]), "right": np.array([0.08, -0.034, 0.88])}
MESH = (24, 8)
TEX = map_texture((0.21, 0.297), 3)
TARGET = np.array([0.32, 0.0, 0.57])
DEMO = Sheet((0.32, 0.0), math.radians(10), 0.57, (0.21, 0.297))
TASK = Sheet((0.34, 0.03), math.radians(-25), 0.57, (0.21 * 0.85, 0.297 * 0.85), bend=0.03)


def shots(sheet):
    from hila_lang.sim.camera import CameraImage
    from hila_lang.sim.scene import SimScene

    with SimScene(style=STUDIO) as sim:
        v, uv, idx = sheet.mesh(MESH[0], MESH[1])
        sim.add_mesh(TEX, v, uv, idx, lit=False)
        out = []
        for eye in ("left", "right"):
            cam = Camera(K, look_at(EYES[eye], TARGET), 320, 240)
            out.append(CameraImage(sim.render(cam), K, cam.world_T_camera, 320, 240))
    return out


@pytest.fixture(scope="module")
def scenes():
    demo, task = shots(DEMO), shots(TASK)
    return M.scene_features(*demo), M.scene_features(*task), demo, task


def truth(pairs, demo_left):
    """Where each pair's demonstration feature is on the task sheet (world), by the truth."""
    X = intersect_plane_z(pairs.template_uv, K, demo_left.world_T_camera, DEMO.z)
    loc = DEMO.flat.to_local(X)
    uv = np.column_stack([loc[:, 0] / DEMO.size[0] + 0.5, 0.5 - loc[:, 1] / DEMO.size[1]])
    return TASK.to_world(uv)


def test_triangulated_demonstration_features_lie_on_the_sheet(scenes):
    demo, _, _, _ = scenes
    assert len(demo) >= 60
    assert np.median(np.abs(demo.points[:, 2] - DEMO.z)) < 0.004  # most pairs are right


def test_matching_gives_true_pairs_on_a_bent_sheet_and_rejection_raises_precision(scenes):
    demo, task, d_img, t_img = scenes
    pairs = M.match_scenes(demo, task, "local")
    c = pairs.counts
    assert c["matched"] == c["kept"] + c["rejected"] and c["kept"] >= 10
    # a pair is true when the task's left eye sees the demonstration's feature where it was matched
    seen = project(truth(pairs, d_img[0]), K, t_img[0].world_T_camera)
    true = np.linalg.norm(seen - pairs.task_uv, axis=1) < 4.0
    assert true[pairs.kept].mean() >= 0.95
    assert true[pairs.kept].mean() >= true.mean()
    err = np.linalg.norm(truth(pairs, d_img[0]) - pairs.task_points, axis=1)
    assert np.median(err[pairs.kept & true]) < 0.006
    assert np.all((pairs.confidence > 0) & (pairs.confidence <= 1))


@pytest.mark.parametrize("model", ["local", "homography"])
def test_verification_rejects_shuffled_matches(scenes, model):
    demo, task, _, _ = scenes
    pairs = M.match_scenes(demo, task, "local").accepted()
    rng = np.random.default_rng(0)
    a, b = pairs.template_uv.copy(), pairs.task_uv.copy()
    bad = rng.choice(len(a), size=max(3, len(a) // 4), replace=False)
    b[bad] = b[rng.permutation(bad)] + rng.uniform(15, 40, (len(bad), 2))
    keep, _ = M.verify(a, b, model)
    assert not keep[bad].any()
    keep_none, _ = M.verify(a, b, "none")
    assert keep_none.all()


def test_unknown_method_and_model_are_input_errors():
    from hila_lang.core.errors import InputError

    with pytest.raises(InputError, match="unknown feature method 'surf'"):
        M._detector("surf")
    with pytest.raises(InputError, match="unknown verification model"):
        M.verify(np.zeros((5, 2)), np.zeros((5, 2)), "affine")


def test_a_bent_sheet_keeps_its_length_rests_on_its_edges_and_maps_back():
    uv = np.random.default_rng(0).uniform(0, 1, (50, 2))
    assert np.abs(TASK.to_uv(TASK.to_world(uv)) - uv).max() < 1e-9
    edge = TASK.to_world(np.column_stack([np.linspace(0, 1, 400), np.full(400, 0.5)]))
    assert np.linalg.norm(np.diff(edge, axis=0), axis=1).sum() == pytest.approx(TASK.size[0], rel=1e-4)
    assert TASK.to_world([[0.5, 0.5]])[0, 2] == pytest.approx(TASK.z + TASK.bend)
    assert np.allclose(TASK.corners()[:, 2], TASK.z)


def test_the_3d_check_rejects_task_points_off_the_sheet(scenes):
    """A wrong stereo pair puts a task point along the eye's ray: the 2-D verification cannot
    see it, the 3-D check does."""
    demo, task, _, _ = scenes
    pairs = M.match_scenes(demo, task, "local")
    keep = pairs.kept.copy()
    moved = pairs.task_points.copy()
    bad = np.flatnonzero(keep)[::4]
    moved[bad] += [0.0, 0.0, 0.03]
    ok = M.spatially_consistent(pairs.template_points, moved, keep)
    assert not ok[bad].any()
    assert ok[np.setdiff1d(np.flatnonzero(keep), bad)].mean() >= 0.8
    assert not ok[~keep].any()
