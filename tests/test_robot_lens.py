"""The eyes' lenses (``hila_lang/robot/lens.py``): the robot's own calibration, made once and cached."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pybullet")
pytest.importorskip("cv2")

from hila_lang.core.fileio import cache_folders  # noqa: E402
from hila_lang.perception.distortion import TRUE_DISTORTION  # noqa: E402
from hila_lang.robot import lens  # noqa: E402


def test_the_calibration_finds_the_true_lens_without_being_told():
    calib = lens.eye_calibration("left")
    true_k = lens.ICUB_EYE_K
    assert calib.rms < 0.1 and calib.n_views >= 20
    assert abs(calib.K[0, 0] - true_k[0, 0]) < 0.5 and abs(calib.K[1, 1] - true_k[1, 1]) < 0.5
    assert np.abs(calib.K[:2, 2] - true_k[:2, 2]).max() < 0.5  # principal point, pixels
    np.testing.assert_allclose(calib.dist[:2], TRUE_DISTORTION[:2], atol=0.01)
    # it was kept in the cache, under a name that hashes what it depends on
    assert any(p.name.startswith("eye_left_") for folder in cache_folders("lens") if folder.is_dir()
               for p in folder.iterdir())


def test_the_eye_pair_calibration_recovers_the_eyes_in_the_head():
    pair = lens.eyes_calibration()
    left_T_right = np.linalg.inv(pair.right_T_left)
    head = lens.eyes_in_head()
    assert np.linalg.norm(left_T_right[:3, 3] - head[:3, 3]) < 1e-3  # 68 mm apart, within 1 mm
    assert pair.rms < 0.1


def test_a_cache_is_made_once_read_after_and_made_again_when_damaged(tmp_path, monkeypatch):
    monkeypatch.setenv("HILA_CACHE_DIR", str(tmp_path))
    made = []

    def make(folder):
        made.append(folder)
        return {"value": len(made)}

    def save(path, value):
        from hila_lang.core.fileio import dump_yaml
        dump_yaml(path, value)

    def load(path):
        from hila_lang.core.fileio import load_yaml
        return load_yaml(path)

    assert lens._cached("x.yaml", load, make, save) == {"value": 1}
    path = tmp_path / "hila" / "lens" / "x.yaml"
    assert path.is_file() and made == [tmp_path / "hila" / "lens"]
    assert lens._cached("x.yaml", load, make, save) == {"value": 1} and len(made) == 1  # read, not made
    path.write_text("value: [unclosed\n")
    assert lens._cached("x.yaml", load, make, save) == {"value": 2}  # damaged: made again, and saved
    assert lens._cached("x.yaml", load, make, save) == {"value": 2} and len(made) == 2
    assert [p.name for p in path.parent.iterdir()] == ["x.yaml"]  # written atomically: no leftovers


def test_an_eye_is_placed_by_its_joint_angles_and_missing_angles_are_named():
    from hila_lang.core.errors import InputError
    from hila_lang.robot.backend import PyBulletBackend
    from hila_lang.robot.eyes import eye_pose

    with PyBulletBackend(arm="rest") as robot:
        chain, joints = robot.eyes.chain("right"), robot.eyes.joints("right")
        np.testing.assert_array_equal(eye_pose(chain, joints), robot.eyes.camera_pose("right"))
        turned = {**joints, "neck_yaw": joints["neck_yaw"] + 0.1}
        assert not np.allclose(eye_pose(chain, turned), eye_pose(chain, joints))
        with pytest.raises(InputError, match="joint angles lack 'neck_pitch'"):
            eye_pose(chain, {k: v for k, v in joints.items() if k != "neck_pitch"})
        with pytest.raises(InputError, match=r"light level must be a number in \(0, 3\]"):
            robot.lighting.set_light(0.0)


def test_the_shipped_calibrations_are_the_ones_this_code_would_name():
    """The files shipped with hila (read when nothing is cached: a first game after an install)
    carry the names the current code hashes for the OpenCV they were made with: a change to the
    lens, the views, the seeds or the eyes in the head without ``python -m hila_lang.robot.lens``
    fails here instead of silently costing every new user 25 s."""
    import json

    manifest = json.loads((lens.SHIPPED / lens.SHIPPED_MANIFEST).read_text())
    assert manifest["files"] == lens.names(manifest["opencv"])
    assert sorted(p.name for p in lens.SHIPPED.glob("*.yaml")) == sorted(manifest["files"])


def test_a_first_run_reads_the_shipped_calibration_when_nothing_is_cached(tmp_path, monkeypatch):
    import cv2

    manifest = __import__("json").loads((lens.SHIPPED / lens.SHIPPED_MANIFEST).read_text())
    if manifest["opencv"] != cv2.__version__:
        pytest.skip(f"the shipped calibrations were made with OpenCV {manifest['opencv']}, this is {cv2.__version__}")
    monkeypatch.setenv("HILA_CACHE_DIR", str(tmp_path))
    lens.eye_calibration.cache_clear()
    from hila_lang.perception import calibration

    def no_rendering(*args, **kwargs):
        raise AssertionError("calibrated again instead of reading the shipped file")

    monkeypatch.setattr(calibration, "chessboard_views", no_rendering)
    monkeypatch.setattr(calibration, "stereo_views", no_rendering)
    try:
        got = lens.eye_calibration("right")
        pair = lens.eyes_calibration()
    finally:
        lens.eye_calibration.cache_clear()
        lens.pair_calibration.cache_clear()
    assert got.n_views >= 20 and pair.rms < 0.1
    assert not (tmp_path / "hila" / "lens").exists() or not any((tmp_path / "hila" / "lens").iterdir())


@pytest.mark.slow
def test_the_shipped_calibrations_are_what_the_robot_makes_itself(tmp_path):
    """Made afresh (nothing cached or shipped read: the chessboard rendered through each eye,
    OpenCV's calibration), the three calibrations equal the shipped ones."""
    import cv2

    from hila_lang.core.fileio import load_yaml

    manifest = __import__("json").loads((lens.SHIPPED / lens.SHIPPED_MANIFEST).read_text())
    if manifest["opencv"] != cv2.__version__:
        pytest.skip(f"the shipped calibrations were made with OpenCV {manifest['opencv']}, this is {cv2.__version__}")
    written = lens.ship(tmp_path)
    assert [p.name for p in written] == manifest["files"]
    for path in written:
        fresh, shipped = load_yaml(path), load_yaml(lens.SHIPPED / path.name)
        assert fresh.keys() == shipped.keys()
        for key in fresh:
            np.testing.assert_allclose(np.asarray(fresh[key], float), np.asarray(shipped[key], float),
                                       rtol=1e-6, atol=1e-9, err_msg=f"{path.name}: {key}")
