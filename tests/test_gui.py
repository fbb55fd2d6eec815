"""``--gui`` under a virtual display (Xvfb): the window is framed on the robot and the board, shows
the running state and the left eye's image, with no PyBullet panels.  Skipped where Xvfb is not
installed (CI has none); without a display ``--gui`` says so and exits 2 (tested in any case).

The screenshot is read by colour: the iCub's red shell and white head/hands, the paper (light,
grey, unsaturated) where the robot's hand is, the text (near-black pixels) in the top-left band.
"""

from __future__ import annotations

import os
import queue
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from xscreen import VirtualDisplay, xvfb_missing

ROOT = Path(__file__).resolve().parent.parent


def test_without_a_display_gui_is_refused_with_exit_2():
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    proc = subprocess.run([sys.executable, "-m", "hila_lang", "exec", "programs/abc.hila", "--backend", "pybullet",
                           "--gui"], capture_output=True, text=True, cwd=ROOT, env=env, timeout=120)
    assert proc.returncode == 2
    assert "--gui needs a display, and none is available (DISPLAY is not set)" in proc.stderr


def _regions(img: np.ndarray):
    r, g, b = (img[:, :, k].astype(int) for k in range(3))
    red = (r > 110) & (g < 70) & (b < 70)
    grey = (np.abs(r - g) < 14) & (np.abs(g - b) < 14) & (r > 115) & (r < 225)
    dark = (r < 60) & (g < 60) & (b < 60)
    return red, grey, dark


def _box(mask: np.ndarray):
    ys, xs = np.nonzero(mask)
    return xs.min(), ys.min(), xs.max(), ys.max()


@pytest.mark.slow
@pytest.mark.skipif(xvfb_missing() is not None, reason=f"no virtual display: {xvfb_missing()}")
def test_gui_frames_the_robot_and_board_and_shows_the_state_and_the_eye(tmp_path):
    import cv2

    with VirtualDisplay(1280, 800) as display:
        env = dict(os.environ, DISPLAY=display.name)
        proc = subprocess.Popen([sys.executable, "-m", "hila_lang", "repl", "programs/game.hila", "--gui",
                                 "--out", str(tmp_path / "out")], cwd=ROOT, env=env, text=True,
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        lines: queue.Queue = queue.Queue()
        threading.Thread(target=lambda: [lines.put(line) for line in proc.stdout], daemon=True).start()
        try:
            proc.stdin.write("step 5\n")  # until, if, let, call, reach: the circle is next
            proc.stdin.flush()
            seen = []
            while not any(line.startswith("at main/mark/draw") for line in seen):
                seen.append(lines.get(timeout=300))
            time.sleep(4)  # the window redraws on its own thread
            shot = display.screenshot()
            proc.stdin.write("quit\n")
            proc.stdin.flush()
            proc.wait(timeout=120)
        finally:
            if proc.poll() is None:
                proc.kill()
    cv2.imwrite(str(tmp_path / "gui.png"), shot[:, :, ::-1])
    height, width = shot.shape[:2]
    red, grey, dark = _regions(shot)
    # the robot: its red shell spans a large part of the window's height
    x0, y0, x1, y1 = _box(red)
    assert (y1 - y0) / height > 0.3, (x0, y0, x1, y1)
    # the board: the paper is the grey region around the pen below the robot; robot and board
    # together span most of the window's height
    paper = grey.copy()
    paper[: y0 + (y1 - y0) // 2] = False  # below the robot's middle
    paper[:, : max(x0 - 150, 0)] = False
    paper[:, x1 + 250:] = False
    from scipy import ndimage

    labels, n = ndimage.label(paper)
    sizes = ndimage.sum(paper, labels, range(1, n + 1))
    board = labels == 1 + int(np.argmax(sizes))
    bx0, by0, bx1, by1 = _box(board)
    assert sizes.max() > 0.02 * height * width  # a sheet, not a speck
    top, bottom = min(y0, by0), max(y1, by1)
    assert (bottom - top) / height > 0.6, (top, bottom)
    # the state text: dark writing in the top band, where no panel is
    band = dark[: int(0.08 * height), : width // 2]
    assert band.sum() > 400
    cols = np.nonzero(band.any(axis=0))[0]
    assert cols.max() - cols.min() > 0.3 * width  # a line of text, name and program line
    # PyBullet's side panels are off: the left edge is scene, not a white panel
    left = shot[int(0.1 * height): int(0.8 * height), :200]
    assert (left.min(axis=2) > 235).mean() < 0.2
    # the eye's screen in the top right shows the table (brown) the eye looks at
    corner = shot[: height // 2, int(0.65 * width):].astype(int)
    brown = (corner[:, :, 0] > 70) & (corner[:, :, 0] < 150) & (corner[:, :, 1] > 45) & \
        (corner[:, :, 1] < 110) & (corner[:, :, 2] < 80) & (corner[:, :, 0] - corner[:, :, 2] > 30)
    assert brown.sum() > 1500


class _FakePyBullet:
    """Records the debug-drawing calls a Window makes (no window needed)."""

    COV_ENABLE_GUI, COV_ENABLE_RGB_BUFFER_PREVIEW, COV_ENABLE_DEPTH_BUFFER_PREVIEW = 1, 2, 3
    COV_ENABLE_SEGMENTATION_MARK_PREVIEW, COV_ENABLE_RENDERING = 4, 7

    def __init__(self):
        import pybullet

        self.real = pybullet
        self.calls: list[tuple] = []
        self.items = 0

    def configureDebugVisualizer(self, flag, value, physicsClientId=0):
        self.calls.append(("configure", flag, value))

    def resetDebugVisualizerCamera(self, *args, physicsClientId=0):
        self.calls.append(("camera", *args))

    def computeViewMatrixFromYawPitchRoll(self, *args, physicsClientId=0):
        return self.real.computeViewMatrixFromYawPitchRoll(*args)

    def getDebugVisualizerCamera(self, physicsClientId=0):
        projection = self.real.computeProjectionMatrixFOV(90.0, 1280 / 800, 0.01, 1000.0)
        return (1280, 800, None, projection)

    def _item(self, *record):
        self.calls.append(record)
        self.items += 1
        return self.items

    def addUserDebugText(self, text, position, color, size, replaceItemUniqueId=-1, physicsClientId=0):
        return self._item("text", text, replaceItemUniqueId)

    def addUserDebugLine(self, a, b, color, width, physicsClientId=0):
        return self._item("line", tuple(a), tuple(b), tuple(color))

    def addUserDebugPoints(self, points, colors, size, physicsClientId=0):
        return self._item("points", [tuple(p) for p in points], tuple(colors[0]))


class _FakeSim:
    def __init__(self):
        self.pb, self.client = _FakePyBullet(), 0
        self.quads = []

    def add_quad(self, image, pose, size, lit=True):
        self.quads.append((pose, size))
        return 7

    def set_texture(self, body, image):
        self.quads.append(("texture", body, image.shape))


def test_window_turns_panels_off_places_things_in_view_and_draws_paths():
    import pybullet

    from hila_lang.robot import window as W
    from hila_lang.robot.workspace import default_surface

    sim = _FakeSim()
    w = W.Window(sim, default_surface(), np.array([[0.0, 0.0, 0.45], [0.0, 0.0, 1.0]]))
    assert {(c[1], c[2]) for c in sim.pb.calls if c[0] == "configure"} == {(1, 0), (2, 0), (3, 0), (4, 0), (7, 1)}
    # a point placed at (right, up) in the view projects back there
    view = np.array(pybullet.computeViewMatrixFromYawPitchRoll(w.target.tolist(), W.CAMERA[0], W.CAMERA[1],
                                                               W.CAMERA[2], 0.0, 2)).reshape(4, 4).T
    proj = np.array(sim.pb.getDebugVisualizerCamera()[3]).reshape(4, 4).T
    for u, v, depth in [(-0.96, 0.9, 0.3), (0.62, 0.52, 0.95), (0.0, 0.0, 0.5)]:
        clip = proj @ view @ np.append(w.at(u, v, depth), 1.0)
        assert np.allclose(clip[:2] / clip[3], (u, v), atol=1e-5)  # PyBullet's matrices are float32
    # the eye screen faces the camera, in the top right
    pose, size = sim.quads[0]
    assert size == W.SCREEN_SIZE and np.allclose(pose[:3, 2], -w.forward)
    path = np.array([[0.3, -0.1, 0.6], [0.31, -0.1, 0.6], [0.32, -0.1, 0.6]])
    w.planned(path)
    drawn = [c for c in sim.pb.calls if c[0] in ("line", "points")]
    assert len(drawn) == 1 and drawn[0][0] == "points" and drawn[0][2] == W.PLANNED_RGB  # one item: one frame's wait
    planned = np.array(drawn[0][1])
    assert np.allclose(planned[0], path[0]) and np.allclose(planned[-1], path[-1])
    assert np.linalg.norm(np.diff(planned, axis=0), axis=1).max() <= W.PLANNED_SPACING + 1e-12
    steps = 2 * W.TRACE_EVERY * W.TRACE_BATCH + 5  # two full batches and a few steps more
    for k in range(steps):
        w.executed_point(np.array([0.3 + 0.0001 * k, -0.1, 0.6]))
    traced = [c for c in sim.pb.calls if c[0] == "points" and c[2] == W.EXECUTED_RGB]
    assert len(traced) == 2 and traced[0][1][0] == (0.3, -0.1, 0.6) and len(traced[0][1]) == W.TRACE_BATCH
    w.show_state("main/draw", "p.hila:3  run a.b()")  # the rest of the move's trace is drawn first
    traced = [c for c in sim.pb.calls if c[0] == "points" and c[2] == W.EXECUTED_RGB]
    assert len(traced) == 3 and len(traced[2][1]) == 1 + 4 // W.TRACE_EVERY
    w.show_state("end", "")
    texts = [c for c in sim.pb.calls if c[0] == "text" and c[1] != "left eye"]
    assert texts[0][1:] == ("main/draw   p.hila:3  run a.b()", -1)
    assert texts[1][1] == "end" and texts[1][2] != -1  # the same item, replaced
    w.show_eye(np.zeros((240, 320, 3), np.uint8))
    assert sim.quads[-1] == ("texture", 7, (240, 320, 3))
