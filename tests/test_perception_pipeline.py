"""The whole pipeline on a short simulated recording: calibration, 3-D path, ICPs, bad input.

One recording (the first 40 frames of the seed-0 demonstration: the reach and the start of the
circle; fewer chessboard views than ``hila learn --from-sim`` uses) is made once per module;
the bad-input tests damage copies of it.  Full-length figures: ``bench/perception.py``.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest

pytest.importorskip("pybullet")
cv2 = pytest.importorskip("cv2")

from hila_lang.core.errors import InputError  # noqa: E402
from hila_lang.core.fileio import load_yaml  # noqa: E402
from hila_lang.perception.calibration import calibrate, load_calibration, save_calibration  # noqa: E402
from hila_lang.perception.learn import template_from_frames  # noqa: E402
from hila_lang.core.fileio import write_png  # noqa: E402
from hila_lang.perception.recording import load_frames, read_image  # noqa: E402
from hila_lang.worlds.tictactoe.recording import record_demonstration  # noqa: E402
from hila_lang.worlds.tictactoe.vision import demonstration_icps  # noqa: E402

FRAMES = 40


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    out = tmp_path_factory.mktemp("perception") / "rec"
    record_demonstration(out, seed=0, n_calibration=16, n_stereo=8, frames=FRAMES)
    return out


@pytest.fixture(scope="module")
def learned(recording):
    return template_from_frames(recording, read_icps=demonstration_icps, return_perception=True)


@pytest.fixture
def copy(recording, tmp_path):
    dst = tmp_path / "rec"
    shutil.copytree(recording, dst)
    return dst


@pytest.mark.slow
def test_recording_layout_and_atomicity(recording):
    assert len(list((recording / "left").glob("*.png"))) == FRAMES
    assert len(list((recording / "right").glob("*.png"))) == FRAMES
    assert len(list((recording / "calibration" / "left").glob("*.png"))) == 16
    # no temporary folders left beside it
    assert [p.name for p in recording.parent.iterdir()] == ["rec"]
    img = read_image(recording / "left" / "frame_00000.png")
    assert img.shape == (240, 320, 3) and img.dtype == np.uint8
    with pytest.raises(InputError, match="recording folder exists and is not empty"):
        record_demonstration(recording, frames=2)


@pytest.mark.slow
def test_calibration_reprojection_error_and_intrinsics(learned, recording):
    truth = load_yaml(recording / "truth.yaml")
    K = np.array(truth["K"])
    for eye, cal in learned[1].calibration.items():
        assert cal.rms < 0.5, (eye, cal.rms)
        assert np.abs(cal.K - K).max() < 1.0, (eye, cal.K)
        assert abs(cal.dist[0] - truth["dist"][0]) < 0.01


@pytest.mark.slow
def test_triangulated_path_against_ground_truth(learned, recording):
    template, perception = learned
    truth = np.array(load_yaml(recording / "truth.yaml")["path"])
    err_mm = np.linalg.norm(perception.path - truth, axis=1) * 1000
    assert np.median(err_mm) < 2.5, np.median(err_mm)
    assert err_mm.max() < 6.0, err_mm.max()
    assert max(perception.reprojection_px.values()) < 0.2
    assert template.path.shape == (FRAMES, 3)
    # the pen-down part of the template lies exactly on the paper (the robot inks within 0.5 mm)
    surface_z = load_yaml(recording / "cameras.yaml")["surface_z"]
    contact = np.array(load_yaml(recording / "truth.yaml")["path"])[:, 2] <= surface_z + 1e-9
    on_paper = np.isclose(template.path[contact, 2], surface_z, rtol=0, atol=1e-12)
    assert contact.sum() >= 10 and on_paper.mean() >= 0.9, template.path[contact, 2] - surface_z


def test_icps_detected_from_the_images(learned, recording):
    template, perception = learned
    truth = load_yaml(recording / "truth.yaml")
    assert perception.icp_reading.detail["cell"] == truth["cell"]
    assert list(template.icps) == ["tl", "tr", "br", "bl", "hand"]
    for name in ("tl", "tr", "br", "bl"):
        assert np.linalg.norm(template.icps[name] - truth["icps"][name]) < 2e-3, name
    assert np.linalg.norm(template.icps["hand"] - truth["icps"]["hand"]) < 5e-3
    assert template.tags() == ["reach", "draw", "retract"]
    assert template.segment("draw").contact
    assert "Learned by perception" in template.description


def test_calibration_file_round_trip(learned, tmp_path):
    cal = learned[1].calibration["left"]
    path = save_calibration(tmp_path / "left.yaml", cal)
    back = load_calibration(path)
    assert np.allclose(back.K, cal.K) and np.allclose(back.dist, cal.dist) and back.rms == pytest.approx(cal.rms)


# -- bad input ----------------------------------------------------------------------------------
def test_missing_frame_is_named(copy):
    (copy / "left" / "frame_00017.png").unlink()
    with pytest.raises(InputError, match=r"missing left frames: frame number\(s\) 17 absent"):
        template_from_frames(copy, read_icps=demonstration_icps)


def test_unreadable_frame_is_named(copy):
    (copy / "right" / "frame_00003.png").write_bytes(b"not a png")
    with pytest.raises(InputError, match="unreadable frame") as info:
        template_from_frames(copy, read_icps=demonstration_icps)
    assert "frame_00003.png" in str(info.value)


def test_left_right_counts_differ(copy):
    (copy / "right" / f"frame_{FRAMES - 1:05d}.png").unlink()
    with pytest.raises(InputError, match=f"left and right frame counts differ: {FRAMES} left, {FRAMES - 1} right"):
        template_from_frames(copy, read_icps=demonstration_icps)


def _hide_marker(folder, frames):
    for i in frames:
        path = folder / f"frame_{i:05d}.png"
        img = read_image(path)
        f = img.astype(int)
        green = (f[:, :, 1] - np.maximum(f[:, :, 0], f[:, :, 2])) > 5
        img[green] = (200, 200, 200)
        write_png(path, img)


def test_marker_lost_briefly_is_bridged(copy, learned):
    _hide_marker(copy / "left", [20, 21])
    template, perception = template_from_frames(copy, read_icps=demonstration_icps, return_perception=True)
    assert perception.bridged["left"] == [20, 21] and perception.bridged["right"] == []
    assert np.linalg.norm(perception.path - learned[1].path, axis=1).max() < 3e-3


def test_marker_lost_too_long_names_the_frames(copy):
    _hide_marker(copy / "right", range(12, 18))
    with pytest.raises(InputError, match=r"marker lost in 6 of 40 right frames; cannot bridge "
                                         r"frames frame_00012.png..frame_00017.png"):
        template_from_frames(copy, read_icps=demonstration_icps)


def test_no_chessboard_found(copy):
    for path in (copy / "calibration" / "left").glob("*.png"):
        write_png(path, np.full((240, 320, 3), 128, np.uint8))
    with pytest.raises(InputError, match=r"left camera: no 9x6 chessboard found in 16 of 16 images"):
        template_from_frames(copy, read_icps=demonstration_icps)


def test_calibrate_needs_images_of_one_size():
    with pytest.raises(InputError, match="differ in size"):
        calibrate([np.zeros((240, 320, 3), np.uint8), np.zeros((120, 160, 3), np.uint8)])


def test_missing_folder_and_video(tmp_path):
    with pytest.raises(InputError, match="frames folder not found"):
        load_frames(tmp_path / "nope")
    video = tmp_path / "broken.avi"
    video.write_bytes(b"garbage")
    with pytest.raises(InputError, match="video file"):
        load_frames(video)


def test_a_file_that_is_not_a_video_is_named_and_ffmpeg_stays_quiet(tmp_path, capfd):
    video = tmp_path / "fake.mp4"
    video.write_bytes(np.random.default_rng(0).integers(0, 256, 5000, dtype=np.uint8).tobytes())
    with pytest.raises(InputError, match="video file"):
        load_frames(video)
    assert capfd.readouterr().err == ""  # FFmpeg's own "moov atom not found" is silenced


def test_frames_from_a_video_file(recording, tmp_path):
    frames, _ = load_frames(recording / "left")
    path = tmp_path / "left.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 20.0, (320, 240))
    for f in frames[:5]:
        writer.write(cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
    writer.release()
    video, names = load_frames(path)
    assert len(video) == 5 and video[0].shape == (240, 320, 3) and names[0] == "left.avi#0"


@pytest.mark.slow
def test_template_from_sim_says_how_it_was_made(tmp_path):
    from hila_lang.worlds.tictactoe.recording import learn_from_sim as template_from_sim
    from hila_lang.osila.template import load_template, save_template

    template = template_from_sim(3, frames=36, n_calibration=12, n_stereo=6, recording_dir=tmp_path / "rec")
    assert template.description.startswith("Learned by perception from a simulated recording")
    assert "seed 3" in template.description and "hila learn --from-sim --seed 3" in template.description
    assert "stereo frames" not in template.description  # the recording's folder is not named
    back = load_template(save_template(template, tmp_path / "circle.yaml"))
    assert back.tags() == ["reach", "draw", "retract"] and list(back.icps) == ["tl", "tr", "br", "bl", "hand"]


def test_hila_learn_from_recorded_frames(recording, learned, tmp_path, capsys):
    from hila_lang.cli import main
    from hila_lang.osila.template import load_template

    out = tmp_path / "seen.yaml"
    rc = main(["learn", "--frames", str(recording), "-k", "3", "--tags", "reach,draw,retract",
               "--contact", "draw", "-o", str(out)])
    assert rc == 0, capsys.readouterr().err
    template = load_template(out)
    assert template.tags() == ["reach", "draw", "retract"] and template.segment("draw").contact
    assert set(template.icps) == {"tl", "tr", "br", "bl", "hand"}
    np.testing.assert_allclose(template.path, learned[0].path, atol=1e-9)  # the library's result
    assert "learned template 'seen'" in capsys.readouterr().out


def test_hila_learn_frames_errors_exit_2(copy, tmp_path, capsys):
    from hila_lang.cli import main

    (copy / "left" / "frame_00017.png").unlink()
    rc = main(["learn", "--frames", str(copy), "-o", str(tmp_path / "x.yaml")])
    assert rc == 2
    assert "missing left frames: frame number(s) 17 absent" in capsys.readouterr().err
    assert not (tmp_path / "x.yaml").exists()
