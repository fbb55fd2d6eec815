"""A pen on the printed sheet before one camera (issue 36): the sheet, synthetic videos, the
tracker, ``hila learn VIDEO --sheet``, and the template it makes playing ``game.hila``.

The tests that render and track a video are marked slow (tests/conftest.py): ``pytest -m slow``."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

from hila_lang import cli  # noqa: E402
from hila_lang.core.errors import InputError  # noqa: E402
from hila_lang.perception.extraction import detect_blob  # noqa: E402
from hila_lang.perception.pen import PenTracker, fit_ball, focal_constraints, solve_focal  # noqa: E402
from hila_lang.perception.penvideo import PenVideo, PenVideoSpec, write_video, write_y4m  # noqa: E402
from hila_lang.perception.sheet import (MARGIN_MM, MARKER_MM, PT_PER_MM, SheetLayout, layout_for_ids,  # noqa: E402
                                        marker_bits, pdf_bytes, png_bytes)

ROOT = Path(__file__).resolve().parents[1]
SPEC = PenVideoSpec(seed=4, cell=5)


# -- the sheet -----------------------------------------------------------------------------------

@pytest.mark.parametrize("paper,grid", [("a4", False), ("letter", True)])
def test_png_sheet_markers_are_found_where_the_layout_says(paper, grid):
    layout = SheetLayout(paper, grid)
    dpi = 150.0
    data = png_bytes(layout, dpi)
    assert data[12:16] == b"IHDR" and data[37:41] == b"pHYs"
    assert int.from_bytes(data[41:45], "big") == round(dpi / 0.0254)  # pixels per metre
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_GRAYSCALE)
    s = dpi / 25.4
    assert img.shape == (round(layout.size[1] * s), round(layout.size[0] * s))
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    detector = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50), params)
    corners, ids, _ = detector.detectMarkers(img)
    assert sorted(ids.ravel().tolist()) == sorted(layout.ids)
    for c, i in zip(corners, ids.ravel()):
        mm = layout.marker_corners()[int(i)]
        # pixel (u, v): its centre is at ((u + 0.5) / s, height - (v + 0.5) / s) mm
        px = np.column_stack([mm[:, 0] * s - 0.5, (layout.size[1] - mm[:, 1]) * s - 0.5])
        assert np.abs(c.reshape(4, 2) - px).max() < 0.3
    assert layout_for_ids(ids.ravel()) == layout


def _pdf_objects(data: bytes) -> dict[int, bytes]:
    """A PDF's objects by number, found through its cross-reference table (which must be right)."""
    start = int(re.search(rb"startxref\n(\d+)\n%%EOF", data).group(1))
    xref = data[start:].split(b"trailer")[0].split(b"\n")
    count = int(xref[1].split()[1])
    objects = {}
    for number in range(1, count):
        offset = int(xref[2 + number].split()[0])
        head = data[offset:offset + 20]
        assert head.startswith(f"{number} 0 obj".encode()), (number, head)
        objects[number] = data[offset:data.index(b"endobj", offset)]
    return objects


def test_pdf_sheet_is_a_valid_page_of_the_paper_size_with_the_markers_drawn():
    layout = SheetLayout("a4", True)
    data = pdf_bytes(layout)
    assert data.startswith(b"%PDF-1.4") and data.rstrip().endswith(b"%%EOF")
    objects = _pdf_objects(data)
    box = re.search(rb"/MediaBox \[0 0 ([\d.]+) ([\d.]+)\]", objects[3])
    assert abs(float(box.group(1)) - 210 * PT_PER_MM) < 0.01 and abs(float(box.group(2)) - 297 * PT_PER_MM) < 0.01
    stream = objects[4]
    content = zlib.decompress(stream[stream.index(b"stream\n") + 7:stream.rindex(b"\nendstream")]).decode("latin-1")
    # every black rectangle (grey 0) rasterised at one cell per module: marker 8 (top left) is its bits
    module = MARKER_MM / 6
    x0, y0 = MARGIN_MM, 297 - MARGIN_MM - MARKER_MM
    cells = np.zeros((6, 6), bool)
    black = False
    for line in content.split("\n"):
        if line.endswith(" g") and len(line.split()) == 2:
            black = float(line.split()[0]) == 0.0
        if line.endswith(" re") and black:
            x, y, w, h = (float(v) / PT_PER_MM for v in line.split()[:4])
            for col in range(6):
                for row in range(6):
                    cx, cy = x0 + (col + 0.5) * module, y0 + (5 - row + 0.5) * module
                    if x <= cx <= x + w and y <= cy <= y + h:
                        cells[row, col] = True
    assert (cells == marker_bits(8)).all()
    assert "Tj" in content and "DICT_4X4_50" in content


def test_hila_sheet_writes_pdf_or_png_and_refuses_other_names(tmp_path, capsys):
    assert cli.main(["sheet", "--out", str(tmp_path / "s.pdf"), "--paper", "letter"]) == 0
    assert (tmp_path / "s.pdf").read_bytes().startswith(b"%PDF")
    assert cli.main(["sheet", "--out", str(tmp_path / "s.png"), "--dpi", "100", "--grid"]) == 0
    assert "markers 8, 9, 10, 11" in capsys.readouterr().out
    assert cli.main(["sheet", "--out", str(tmp_path / "s.txt")]) == 2
    assert "expected a .pdf or .png" in capsys.readouterr().err
    with pytest.raises(SystemExit) as stop:
        cli.main(["sheet", "--out", str(tmp_path / "s.png"), "--dpi", "nan"])
    assert stop.value.code == 2 and "expected a finite number >= 72 <= 1200 dots per inch" in capsys.readouterr().err
    assert not (tmp_path / "s.txt").exists()


# -- video files ---------------------------------------------------------------------------------

def test_y4m_is_read_back_by_ffmpeg_frame_for_frame(tmp_path):
    rng = np.random.default_rng(0)
    frames = [np.clip(rng.normal(128, 40, (48, 64, 3)), 0, 255).astype(np.uint8) for _ in range(5)]
    frames = [cv2.GaussianBlur(f, (0, 0), 2.0) for f in frames]  # smooth: 4:2:0 keeps colour at half size
    path = write_y4m(tmp_path / "v.y4m", frames, 30.0)
    assert path.read_bytes().startswith(b"YUV4MPEG2 W64 H48 F30:1 Ip A1:1 C420jpeg\nFRAME\n")
    cap = cv2.VideoCapture(str(path))
    assert cap.get(cv2.CAP_PROP_FPS) == pytest.approx(30.0)
    back = []
    while True:
        ok, bgr = cap.read()
        if not ok:
            break
        back.append(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
    assert len(back) == 5
    for a, b in zip(frames, back):
        assert np.abs(a.astype(int) - b.astype(int)).mean() < 4.0
    with pytest.raises(InputError, match="even size"):
        write_y4m(tmp_path / "odd.y4m", [np.zeros((5, 6, 3), np.uint8)], 30.0)
    assert not (tmp_path / "odd.y4m").exists()


@pytest.mark.slow  # renders and tracks a synthetic video
def test_frames_folder_and_video_give_the_same_frames_with_times(tmp_path):
    from hila_lang.perception.recording import iter_frames

    video = PenVideo(PenVideoSpec(seed=1))
    short = type("Short", (), {"spec": video.spec, "__iter__": lambda self: (x for _, x in zip(range(6), video))})()
    write_video(tmp_path / "frames", short)
    write_video(tmp_path / "v.y4m", short)
    folder = list(iter_frames(tmp_path / "frames", fps=25.0))
    y4m = list(iter_frames(tmp_path / "v.y4m"))
    assert [n for _, n, _ in folder] == [f"frame_{i:05d}.png" for i in range(6)]
    assert [t for *_, t in folder] == pytest.approx(np.arange(6) / 25.0)
    assert [t for *_, t in y4m] == pytest.approx(np.arange(6) / 30.0)
    assert np.abs(folder[3][0].astype(int) - y4m[3][0].astype(int)).mean() < 3.0


# -- pieces of the tracker -----------------------------------------------------------------------

def test_fit_ball_ignores_the_part_of_the_outline_a_pen_hides():
    rng = np.random.default_rng(3)
    centre, radius = np.array([100.3, 80.7]), 7.0
    angles = np.linspace(0, 2 * np.pi, 48, endpoint=False)
    pts = centre + radius * np.column_stack([np.cos(angles), np.sin(angles)]) + rng.normal(0, 0.05, (48, 2))
    hidden = np.sin(angles) < -0.45  # the pen's body covers the top: the outline stops short there
    pts[hidden] = centre + np.column_stack([np.cos(angles[hidden]), np.sin(angles[hidden])]) * \
        (-0.45 * radius / np.sin(angles[hidden]))[:, None]
    c, r = fit_ball(pts, centre + [0.8, 1.2], np.array([100.0, 80.0]), 500.0)
    assert np.linalg.norm(c - centre) < 0.1 and abs(r - radius) < 0.1
    A = np.column_stack([2 * pts, np.ones(48)])  # one plain least-squares circle is pulled off
    a, b, _ = np.linalg.lstsq(A, (pts ** 2).sum(1), rcond=None)[0]
    assert np.linalg.norm([a, b] - centre) > 0.5


def test_focal_length_from_a_tilted_plane_and_none_face_on():
    from hila_lang.sim.camera import Camera, intrinsics, look_at

    K = intrinsics(640, 480, 62.0)
    for eye, expect in (((105, 500, 380), True), ((105, 150, 600), False)):
        cam = Camera(K, look_at(np.array(eye, float), np.array([105.0, 148.0, 0.0]),
                                up=(0, 1, 0) if eye[1] == 150 else (0, 0, 1)), 640, 480)
        R = np.linalg.inv(cam.world_T_camera)[:3]
        H = K @ np.column_stack([R[:, 0], R[:, 1], R[:, 3]])
        f = solve_focal(focal_constraints(H, np.array([319.5, 239.5])), 640, H, np.array([319.5, 239.5]))
        assert (f is not None and abs(f - K[0, 0]) < 0.01 * K[0, 0]) if expect else f is None


# -- the tracker on a video ----------------------------------------------------------------------

@pytest.fixture(scope="module")
def video(tmp_path_factory):
    folder = tmp_path_factory.mktemp("pen")
    v = PenVideo(SPEC)
    write_video(folder / "pen.y4m", v)
    return v, folder / "pen.y4m"


@pytest.fixture(scope="module")
def track(video):
    v, _ = video
    tracker = PenTracker()
    live = []
    for t, rgb in v:
        frame = tracker.feed(rgb, t)
        live.append(frame)
    return tracker.finish(), live


@pytest.mark.slow  # renders and tracks a synthetic video
def test_tracker_finds_the_tip_on_the_paper_within_a_millimetre(video, track):
    v, _ = video
    tr, _ = track
    truth = v.truth
    down = truth.contact
    err = np.linalg.norm(tr.tip[down, :2] - truth.tip[down, :2], axis=1)
    assert np.median(err) <= 1.0 and np.percentile(err, 95) <= 3.0
    assert tr.focal_measured and abs(tr.focal_px - truth.K[0, 0]) < 0.03 * truth.K[0, 0]
    # in the air the height comes from the ball's size: well above the paper where it is
    high = truth.tip[:, 2] > 20
    assert np.median(np.abs(tr.height[high] - truth.tip[high, 2])) < 6.0


@pytest.mark.slow  # renders and tracks a synthetic video
def test_tracker_says_when_the_pen_touched_and_left_within_two_frames(video, track):
    v, _ = video
    tr, _ = track
    changes = np.flatnonzero(np.diff(tr.contact.astype(int))) + 1
    assert len(changes) == 2 and tr.contact[changes[0]] and not tr.contact[changes[1]]
    dt = 1 / v.spec.fps
    assert abs(tr.times[changes[0]] - v.truth.touch) <= 2 * dt
    assert abs(tr.times[changes[1]] - v.truth.lift) <= 2 * dt


@pytest.mark.slow  # renders and tracks a synthetic video
def test_tracker_frame_by_frame_gives_markers_and_a_live_tip(video, track):
    v, _ = video
    _, live = track
    frame = live[len(live) // 2]
    assert sorted(frame.markers) == [8, 9, 10, 11] and frame.H is not None
    d = frame.to_dict()
    assert d["sheet"] and len(d["markers"]) == 4 and len(d["ball"]["uv"]) == 2
    on_paper = [f for f in live if v.truth.contact[f.index]]
    err = [np.linalg.norm(f.tip - v.truth.tip[f.index, :2]) for f in on_paper]
    assert np.median(err) < 1.5


@pytest.mark.slow  # renders and tracks a synthetic video
def test_hand_over_a_marker_and_the_ball_is_bridged_and_said():
    v = PenVideo(PenVideoSpec(seed=2, cell=5, occluder=True))
    tracker = PenTracker()
    for t, rgb in v:
        tracker.feed(rgb, t)
    tr = tracker.finish()
    assert set(v.truth.hidden) <= set(tr.ball_bridged)
    assert tr.markers_seen[v.truth.marker_hidden].min() < 4  # the hand did cover a marker
    assert "ball interpolated" in tr.summary()
    down = v.truth.contact
    assert np.median(np.linalg.norm(tr.tip[down, :2] - v.truth.tip[down, :2], axis=1)) <= 1.0


# -- hila learn VIDEO --sheet ----------------------------------------------------------------------

@pytest.fixture(scope="module")
def learned(video, tmp_path_factory):
    _, path = video
    out = tmp_path_factory.mktemp("learned")
    r = subprocess.run([sys.executable, "-m", "hila_lang", "learn", str(path), "--sheet", "--cell", "5", "-k", "3",
                        "--tags", "reach,draw,retract", "--contact", "draw", "-o", str(out / "circle.yaml")],
                       capture_output=True, text=True, cwd=out)
    assert r.returncode == 0, r.stderr
    return out, r.stdout


@pytest.mark.slow  # renders and tracks a synthetic video
def test_learn_sheet_writes_the_same_template_as_learn_on_its_csv(learned, tmp_path):
    from hila_lang.osila.demofile import read_demo

    out, stdout = learned
    assert "A4 with grid sheet" in stdout and "focal length" in stdout
    assert sorted(p.name for p in out.iterdir()) == ["circle.demo.csv", "circle.icps.yaml", "circle.yaml"]
    r = subprocess.run([sys.executable, "-m", "hila_lang", "learn", str(out / "circle.demo.csv"), "--icps",
                        str(out / "circle.icps.yaml"), "-k", "3", "--tags", "reach,draw,retract", "--contact", "draw",
                        "--name", "circle", "-o", str(tmp_path / "again.yaml")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "again.yaml").read_text() == (out / "circle.yaml").read_text()
    demo = read_demo(out / "circle.demo.csv")
    assert demo.pen is not None and demo.path.shape[1] == 3
    assert np.allclose(np.diff(demo.times), 0.05) and (demo.path[demo.pen, 2] == 0).all()


@pytest.mark.slow  # renders and tracks a synthetic video
def test_learn_sheet_path_pen_and_icps_match_the_truth(video, learned):
    from hila_lang.osila.demofile import read_demo
    from hila_lang.osila.template import load_template
    from hila_lang.perception.penvideo import tip_at

    v, _ = video
    out, _ = learned
    demo = read_demo(out / "circle.demo.csv")
    truth = tip_at(v.truth.times, v.truth.tip, demo.times) / 1000.0
    true_pen = np.interp(demo.times, v.truth.times, v.truth.contact.astype(float)) > 0.5
    assert np.mean(demo.pen == true_pen) > 0.95
    both = demo.pen & true_pen
    assert np.median(np.linalg.norm(demo.path[both, :2] - truth[both, :2], axis=1)) < 0.001
    template = load_template(out / "circle.yaml")
    feats = SheetLayout("a4", True).features()
    for corner in ("tl", "tr", "br", "bl"):
        assert template.icps[corner] == pytest.approx([*(feats[f"cell5.{corner}"] / 1000.0), 0.0])
    assert template.icps["hand"] == pytest.approx(demo.path[0])
    assert np.linalg.norm(template.icps["hand"] - truth[0]) < 0.015


@pytest.mark.slow  # renders and tracks a synthetic video
def test_a_template_learned_from_the_camera_plays_the_game(learned, tmp_path):
    out, _ = learned
    shutil.copy(out / "circle.yaml", tmp_path / "circle.yaml")
    shutil.copy(ROOT / "programs" / "game.hila", tmp_path / "game.hila")
    r = subprocess.run([sys.executable, "-m", "hila_lang", "exec", "game.hila", "--backend", "dry", "--opponent",
                        "minimax", "--out", str(tmp_path / "game")], capture_output=True, text=True, cwd=tmp_path,
                       timeout=300)
    assert r.returncode == 0, r.stderr + r.stdout
    assert "result:" in r.stdout and "circle.draw" in r.stdout


# -- refusals: nothing written ------------------------------------------------------------------------

def _doctored(video, tmp_path, name, change):
    """The test video's first 60 frames with ``change(index, rgb)`` applied to each, as a .y4m."""
    v, _ = video
    frames = (change(i, v.frame(i).copy()) for i in range(60))
    return write_y4m(tmp_path / f"{name}.y4m", frames, v.spec.fps)


def _paint_markers(v, rgb, which):
    for marker_id in which:
        corners = v.camera.project(np.column_stack([v.layout.marker_corners()[marker_id], np.zeros(4)]))
        centre = corners.mean(axis=0)
        grown = centre + (corners - centre) * 1.3
        cv2.fillConvexPoly(rgb, np.round(grown).astype(np.int32), (235, 235, 232))
    return rgb


@pytest.mark.parametrize("case,message", [
    ("no-markers", "no marker of a hila sheet in any of its"),
    ("no-ball", r"no green ball \(the pen's tip\) in any of its"),
    ("hidden-sheet", r"sheet \(at least 3 of its 4 markers\) lost in .* frames; cannot bridge frames \S+#0\.\."),
])
@pytest.mark.slow  # renders and tracks a synthetic video
def test_a_video_without_markers_ball_or_sheet_is_refused_saying_which(video, tmp_path, case, message):
    v, _ = video

    def change(i, rgb):
        if case == "no-markers":
            return _paint_markers(v, rgb, v.layout.ids)
        if case == "no-ball":
            g = rgb.astype(int)
            green = g[:, :, 1] - np.maximum(g[:, :, 0], g[:, :, 2]) > 10
            rgb[green] = rgb[green].mean(axis=1, keepdims=True).astype(np.uint8)
            return rgb
        return _paint_markers(v, rgb, v.layout.ids[:2]) if i < 40 else rgb

    path = _doctored(video, tmp_path, case, change)
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "hila_lang", "learn", str(path), "--sheet", "-o", str(out / "t.yaml")],
                       capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    assert re.search(message, r.stderr), r.stderr
    assert "Traceback" not in r.stderr
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.slow  # renders and tracks a synthetic video
def test_learn_sheet_option_mistakes_are_bad_input(video, tmp_path, capsys):
    _, path = video
    out = tmp_path / "t.yaml"
    assert cli.main(["learn", str(path), "--sheet", "--ball", "purple", "-o", str(out)]) == 2
    assert "unknown ball colour 'purple'" in capsys.readouterr().err
    with pytest.raises(SystemExit) as stop:
        cli.main(["learn", str(path), "--sheet", "--cell", "12", "-o", str(out)])
    assert stop.value.code == 2 and "expected a whole number from 1 to 9" in capsys.readouterr().err
    assert cli.main(["learn", "demo.csv", "--icps", "x.yaml", "--cell", "5", "-o", str(out)]) == 2
    assert "--cell goes with --sheet" in capsys.readouterr().err
    assert cli.main(["learn", "--sheet", "--from-sim", "-o", str(out)]) == 2
    assert "--sheet learns from one video" in capsys.readouterr().err
    assert cli.main(["learn", str(path), "--sheet", "--robot", "panda", "-o", str(out)]) == 2
    assert "(not with --robot/--set)" in capsys.readouterr().err
    assert not out.exists()


def test_blob_of_another_colour():
    img = np.full((40, 40, 3), 230, np.uint8)
    cv2.circle(img, (20, 18), 6, (40, 80, 200), -1)
    blob = detect_blob(img, colour="blue")
    assert np.linalg.norm(blob.centre - [20, 18]) < 0.2 and 100 < blob.area < 140
    assert detect_blob(img, colour="green") is None
    with pytest.raises(InputError, match="unknown marker colour"):
        detect_blob(img, colour="purple")
