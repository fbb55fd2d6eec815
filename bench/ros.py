"""Benchmark: the ROS 2 path (``--backend ros`` against ``hila robot-sim`` in another process) beside
the in-process PyBullet back end, on the same program.

For every move of the program (default ``programs/reach_return.hila``: 10 run states), on each back end:

- command-to-motion latency: from the engine calling ``move`` to the first moment the caller can
  see the arm move (a joint more than 1 mrad from where it started), wall clock, ms; split into
  planning (IK along the path, timing, checks: until the trajectory is sent / the first
  simulation step) and the rest (ROS: transport, the sim's next physics step, the joint state
  back; PyBullet in process: the first steps of the control loop);
- tracking error: every executed point's distance to the planned path (from where the arm was),
  mm (the ROS path's points are its ``/joint_states`` through forward kinematics; PyBullet's its
  240 Hz steps), and how far the move ended from the planned end, mm.

The PyBullet back end runs headless as fast as it can; the ROS path runs in real time (the sim
paces its physics to the wall clock), so the runs' wall times differ by design and are printed
for information.  Prints the machine's load average beside the figures.  Needs the ros extra.

    python bench/ros.py [--program programs/reach_return.hila] [--robot icub|panda|kuka|PATH] [--rate 120]
"""

from __future__ import annotations

import argparse
import io
import os
import random
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
MOVED = 1e-3  # rad


def run_pybullet(program: str, robot: str) -> tuple[list[dict], float]:
    from hila_lang.plugins.options import RunOptions
    from hila_lang.ros.plan import off_path
    from hila_lang.session.runner import finish, prepare

    interp = prepare(program, RunOptions(seed=0, stdout=io.StringIO(), settings={"robot": robot}), "pybullet")
    backend, rows = interp.backend, []
    arm = backend.arm
    original = backend.move

    def move(path, *, pen_down=False, label=""):
        called = time.perf_counter()
        start_q = arm.joint_positions()
        seen = {}

        def observe(point):
            seen.setdefault("first_step", time.perf_counter())
            if "moved" not in seen and np.max(np.abs(arm.joint_positions() - start_q)) > MOVED:
                seen["moved"] = time.perf_counter()

        arm.observer = observe
        start = backend.hand_position()
        executed = original(path, pen_down=pen_down, label=label)
        arm.observer = None
        reference = np.vstack([start, path])
        rows.append({"latency": seen["moved"] - called, "planning": seen["first_step"] - called,
                     "deviation": off_path(executed, reference), "end": np.linalg.norm(executed[-1] - path[-1])})
        return executed

    backend.move = move
    clock = time.perf_counter()
    interp.run()
    wall = time.perf_counter() - clock
    finish(interp)
    return rows, wall


def run_ros(program: str, robot: str, rate: float) -> tuple[list[dict], float, tuple[float, float]]:
    domain = random.SystemRandom().randint(1, 100)
    env = {**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_DOMAIN_ID": str(domain)}
    os.environ.update({k: env[k] for k in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID")})
    sim = subprocess.Popen([sys.executable, "-m", "hila_lang", "robot-sim", "--robot", robot, "--rate", str(rate)], cwd=ROOT, env=env,
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        line = sim.stderr.readline()
        if "ready" not in line:
            raise SystemExit(f"robot-sim did not start: {line}{sim.stderr.read()}")
        from hila_lang.plugins.options import RunOptions
        from hila_lang.ros.plan import off_path
        from hila_lang.session.runner import finish, prepare

        interp = prepare(program, RunOptions(seed=0, stdout=io.StringIO(), settings={"robot": robot}), "ros")
        backend, rows = interp.backend, []
        original = backend.move

        def move(path, *, pen_down=False, label=""):
            called = time.monotonic()
            executed = original(path, pen_down=pen_down, label=label)
            m = backend.moves[-1]
            reference = np.vstack([executed[:1], path])
            rows.append({"latency": m.sent + m.latency(MOVED) - called, "planning": m.sent - called,
                         "deviation": off_path(executed, reference), "end": np.linalg.norm(executed[-1] - path[-1]),
                         "intervals": np.diff([s.received for s in m.states])})
            return executed

        backend.move = move
        clock = time.perf_counter()
        interp.run()
        wall = time.perf_counter() - clock
        intervals = np.concatenate([r["intervals"] for r in rows])
        finish(interp)
        return rows, wall, (float(np.percentile(intervals, 99)), float(intervals.max()))
    finally:
        sim.terminate()
        sim.wait(timeout=10)


def _ms(values) -> str:
    v = 1000 * np.asarray(values)
    return f"median {np.median(v):7.2f}, max {v.max():7.2f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--program", default="programs/reach_return.hila")
    ap.add_argument("--robot", default="icub", help="the robot on both back ends (default icub)")
    ap.add_argument("--rate", type=float, default=120.0, help="robot-sim's joint states per second")
    args = ap.parse_args()
    os.chdir(ROOT)
    load = os.getloadavg()
    py, py_wall = run_pybullet(args.program, args.robot)
    ros, ros_wall, gap99 = run_ros(args.program, args.robot, args.rate)
    print(f"{args.program} on the {args.robot}: {len(py)} moves; load average {load[0]:.2f} {load[1]:.2f} (1 and 5 min), 2 cores")
    print(f"{'':28}{'pybullet, in process':34}{'ros, robot-sim in another process'}")
    for name, key in (("command-to-motion (ms)", "latency"), ("  of which planning (ms)", "planning")):
        print(f"{name:28}{_ms([r[key] for r in py]):34}{_ms([r[key] for r in ros])}")
    after = "  after it (ms)"
    print(f"{after:28}{_ms([r['latency'] - r['planning'] for r in py]):34}"
          f"{_ms([r['latency'] - r['planning'] for r in ros])}")
    for name, pick in (("tracking error (mm)", lambda r: r["deviation"]), ("end error (mm)", lambda r: [r["end"]])):
        a = np.concatenate([pick(r) for r in py]) / 1000
        b = np.concatenate([pick(r) for r in ros]) / 1000
        print(f"{name:28}{_ms(a * 1000):34}{_ms(b * 1000)}")
    print(f"{'wall time of the run (s)':28}{py_wall:<34.1f}{ros_wall:.1f}  (the ROS path runs in real time)")
    print(f"joint states during the moves: interval 99th percentile {gap99[0] * 1000:.1f} ms, longest "
          f"{gap99[1] * 1000:.1f} ms at --rate {args.rate:g} (ros.silence gives up after 500 ms)")
    lat = np.median([r["latency"] for r in ros]) / np.median([r["latency"] for r in py])
    dev = np.median(np.concatenate([r["deviation"] for r in ros])) / np.median(np.concatenate([r["deviation"] for r in py]))
    print(f"ros / pybullet: latency {lat:.2f}x, tracking error {dev:.2f}x (medians)")


if __name__ == "__main__":
    main()
