"""Shared helpers of the ROS 2 tests: ``hila robot-sim`` in its own process, ``hila exec`` beside it,
and a joint-state listener in the test's own process -- all on a random ``ROS_DOMAIN_ID`` with
localhost discovery, so nothing reaches beyond this machine or another test's graph."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def ros_env(domain: int) -> dict:
    return {**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_DOMAIN_ID": str(domain),
            "PYTHONUNBUFFERED": "1"}


def new_domain() -> int:
    """A random ROS_DOMAIN_ID in 1-100; under pytest-xdist (``-n N``) each worker draws from its own
    share of that range, so two tests running at once never share a ROS graph."""
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    worker = int(os.environ.get("PYTEST_XDIST_WORKER", "gw0")[2:] or 0)
    share = 100 // max(workers, 1)
    first = 1 + (worker % max(workers, 1)) * share
    return random.SystemRandom().randint(first, first + share - 1)


class RobotSim:
    """``hila robot-sim ARGS`` in a child process; its stderr lines collected as they come."""

    def __init__(self, domain: int, *args: str) -> None:
        self.domain = domain
        self.proc = subprocess.Popen([sys.executable, "-m", "hila_lang", "robot-sim", *args], cwd=ROOT,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=ros_env(domain))
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        if not self.wait_for("ready:", 90):
            self.stop()
            raise AssertionError(f"robot-sim did not start: {self.lines}")

    def _read(self) -> None:
        for line in self.proc.stderr:
            self.lines.append(line.rstrip("\n"))

    def wait_for(self, text: str, timeout: float, count: int = 1) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if sum(text in line for line in list(self.lines)) >= count:
                return True
            if self.proc.poll() is not None:
                time.sleep(0.2)
                return sum(text in line for line in list(self.lines)) >= count
            time.sleep(0.02)
        return False

    def trajectories(self) -> list[str]:
        return [line for line in self.lines if "trajectory " in line]

    def stop(self) -> None:
        """Kill it (the fixtures' finalizer: also on failure)."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._reader.join(timeout=5)


#: every ``hila`` process :func:`hila` started (:func:`kill_leftovers` ends those still running)
STARTED: list[subprocess.Popen] = []


def hila(domain: int, *args, stdin=None) -> subprocess.Popen:
    """``hila ARGS`` beside the sim (same domain), output captured."""
    proc = subprocess.Popen([sys.executable, "-m", "hila_lang", *map(str, args)], cwd=ROOT, env=ros_env(domain),
                            stdin=subprocess.PIPE if stdin is not None else subprocess.DEVNULL,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    STARTED.append(proc)
    return proc


def kill_leftovers() -> None:
    """Kill the ``hila`` processes a failed test left running."""
    while STARTED:
        proc = STARTED.pop()
        if proc.poll() is None:
            proc.kill()
            proc.communicate()


def finish(proc: subprocess.Popen, stdin: str | None = None, timeout: float = 240) -> tuple[int, str, str]:
    out, err = proc.communicate(stdin, timeout=timeout)
    return proc.returncode, out, err


class Listener:
    """The arm's ``/joint_states`` as a test hears them, in the test's own process."""

    def __init__(self, domain: int, monkeypatch) -> None:
        from sensor_msgs.msg import JointState

        from hila_lang.ros.link import RosNode

        monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
        monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        self.samples: list[tuple[float, np.ndarray]] = []
        self.node = RosNode("hila_test_listener")
        self.node.subscribe(JointState, "/joint_states", self._on, sensor=True)

    def _on(self, msg) -> None:
        self.samples.append((time.monotonic(), np.array(msg.position)))

    def heard(self, timeout: float = 20.0) -> bool:
        """Wait until the first joint state comes (discovery between two processes takes longer
        than a second when the machine is busy); False after ``timeout`` seconds without one."""
        deadline = time.monotonic() + timeout
        while not self.samples and time.monotonic() < deadline:
            time.sleep(0.02)
        return bool(self.samples)

    def over(self, seconds: float) -> np.ndarray:
        """The positions (K, n) heard during the next ``seconds``."""
        start = time.monotonic()
        time.sleep(seconds)
        return np.array([q for t, q in list(self.samples) if t >= start])

    def close(self) -> None:
        self.node.close()
