"""``--gui`` fit for people (issue 23 item 6), what can be tested without a display: ``--speed N``
is parsed and reaches the arm's pacing; the window is framed (panels off, camera set) right
after it opens, before the robot is loaded or the simulation steps (a DIRECT-mode stand-in for
the window); the framing the window keeps is the one it opened with."""

from __future__ import annotations

import numpy as np
import pytest

from hila_lang import cli


def test_speed_is_a_back_end_setting_with_a_flag(tmp_path, capsys):
    from hila_lang.plugins import registry

    info = registry.backend("pybullet")
    assert info.parse({"speed": "4"})["speed"] == 4.0 and info.parse({})["speed"] == 1.0
    prog = tmp_path / "p.hila"
    prog.write_text("main { }\n")
    assert cli.main(["exec", str(prog), "--backend", "pybullet", "--speed", "0"]) == 2
    err = capsys.readouterr().err
    assert "bad value for --set speed=0 (back end pybullet): expected a number in [0.1, 100.0], got 0" in err


def test_make_backend_passes_the_speed(monkeypatch):
    from hila_lang.plugins.options import RunOptions
    from hila_lang.robot import backend

    got = {}
    monkeypatch.setattr(backend, "PyBulletBackend", lambda surface, **kw: got.update(kw) or "built")
    assert backend.make_backend(None, RunOptions(gui=True), {"speed": 4.0, "eyes.noise": 0.0}) == "built"
    assert got["speed"] == 4.0 and got["gui"] is True


class _Recorder:
    """pybullet, every call recorded by name (a DIRECT client standing in for the window)."""

    def __init__(self, pb) -> None:
        self._pb, self.calls = pb, []

    def __getattr__(self, name):
        value = getattr(self._pb, name)
        if not callable(value):
            return value

        def call(*args, **kwargs):
            self.calls.append((name, args))
            if name == "connect":
                return self._pb.connect(self._pb.DIRECT)
            return value(*args, **kwargs)

        return call


def test_the_window_is_framed_before_the_robot_loads_and_the_simulation_steps(monkeypatch):
    import pybullet

    from hila_lang.robot import backend, window
    from hila_lang.sim import scene

    recorder = _Recorder(pybullet)
    monkeypatch.setattr(scene, "import_pybullet", lambda: recorder)
    monkeypatch.setenv("DISPLAY", ":stand-in")
    windows = []

    class StandIn:  # the window itself needs a real one (its projection); here only when it is made
        def __init__(self, sim, surface, robot=None):  # robot: what it frames of the arm (window.robot_points)
            windows.append(surface)

        def executed_point(self, point):
            pass

    monkeypatch.setattr(backend, "Window", StandIn)  # where the back end reads it
    robot = backend.PyBulletBackend(gui=True, speed=4.0)
    try:
        names = [n for n, _ in recorder.calls]
        camera = names.index("resetDebugVisualizerCamera")
        panels = [i for i, (n, a) in enumerate(recorder.calls) if n == "configureDebugVisualizer"
                  and a[:2] == (pybullet.COV_ENABLE_GUI, 0)]
        assert names[0] == "connect" and panels and panels[0] < camera
        drawing = [(i, a[1]) for i, (n, a) in enumerate(recorder.calls) if n == "configureDebugVisualizer"
                   and a[0] == pybullet.COV_ENABLE_RENDERING]
        assert drawing[0][1] == 0 and drawing[0][0] < names.index("loadURDF")  # not drawn while it loads
        assert camera < names.index("loadURDF") and ("stepSimulation" not in names or camera < names.index("stepSimulation"))
        target = recorder.calls[camera][1][3]
        np.testing.assert_allclose(target, window.frame(robot.sim, robot.surface))  # the window keeps this framing
        assert windows == [robot.surface] and robot.arm.realtime == 4.0
    finally:
        robot.close()


def test_the_arm_paces_at_speed_n(monkeypatch):
    """With a fake clock that only sleeping advances, a move paced at N sleeps its simulated
    duration over N (and not at all unpaced)."""
    from hila_lang.robot import arm as arm_module
    from hila_lang.robot.backend import PyBulletBackend

    class Clock:
        now = 0.0

        def perf_counter(self):
            return self.now

        def sleep(self, seconds):
            self.now += seconds

    robot = PyBulletBackend()
    try:
        start = robot.hand_position()
        path = start + np.linspace(0, 1, 10)[:, None] * np.array([0.05, 0.0, 0.0])
        slept = {}
        for speed in (0.0, 1.0, 4.0):
            clock = Clock()
            monkeypatch.setattr(arm_module, "time", clock)
            robot.arm.realtime = speed
            trace = robot.move(path if speed != 1.0 else path[::-1])
            slept[speed] = (clock.now, len(trace) / arm_module.SIM_RATE)
        assert slept[0.0][0] == 0.0
        assert slept[1.0][0] == pytest.approx(slept[1.0][1], rel=0.05)
        assert slept[4.0][0] == pytest.approx(slept[4.0][1] / 4, rel=0.05)
    finally:
        robot.close()


@pytest.mark.slow
def test_under_xvfb_the_window_never_shows_the_robot_unframed():
    """A screenshot every second while the back end loads and after: each shows either nothing (the
    window does not draw while the robot loads) or the robot exactly where the framing puts it."""
    import os
    import subprocess
    import sys
    import threading
    import time
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from xscreen import VirtualDisplay, xvfb_missing

    if xvfb_missing() is not None:
        pytest.skip(xvfb_missing())
    code = ("from hila_lang.robot.backend import PyBulletBackend\nimport time\n"
            "b = PyBulletBackend(gui=True)\nprint('built', flush=True)\ntime.sleep(5)\nb.close()\n")
    with VirtualDisplay(1280, 800) as display:
        env = dict(os.environ, DISPLAY=display.name)
        proc = subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, text=True)
        printed: list[str] = []
        threading.Thread(target=lambda: printed.extend(proc.stdout), daemon=True).start()
        before, after = [], []
        start = time.time()
        while proc.poll() is None and time.time() - start < 400:
            time.sleep(1.0)
            (after if any(line.startswith("built") for line in printed) else before).append(display.screenshot())
        proc.wait(timeout=60)
    red = [((s[:, :, 0] > 110) & (s[:, :, 1] < 70) & (s[:, :, 2] < 70)).sum() for s in before + after]
    framed = max(red)
    assert after and framed > 5000  # the robot's red shell, framed, fills a good part of the window
    # every screenshot shows nothing (loading, or closed) or the robot as framed, never elsewhere: the
    # same red area within 2 % (the held arm settles by a few dozen pixels: 6748 vs 6794 seen in CI;
    # PyBullet's default view of an unframed robot shows a fraction of that area)
    assert all(r == 0 or abs(r - framed) <= 0.02 * framed for r in red), red
    assert red[0] == 0  # the first screenshot is taken while it loads
