"""Benchmark: learning the demonstration through the iCub's simulated stereo eye cameras.

For each seed, the whole seeded demonstration (reach, circle, retract; 20 Hz) is recorded in
PyBullet through both distorted eye cameras (320x240) with the default chessboard sessions
(40 views per eye, 16 stereo pairs), then learned from the frames exactly as
``hila learn --from-sim`` does.  Reports, headless on this machine:

- reconstruction error: every frame's triangulated pen tip against the ground-truth path, mm
  (median, 95th percentile, max), the same for the template's path (points near the paper put
  on it), and the ICPs (cell corners, hand start) against the truth, mm;
- calibration: RMS chessboard reprojection error per eye, px, and the calibrated focal length
  and principal point against the renderer's true intrinsics, px;
- triangulation: median reprojection error of the 3-D path into each eye, px;
- speed: pipeline frames per second (stereo frame pairs processed per second of wall time:
  loading PNGs, calibration, extraction, triangulation, ICPs), split by stage, and recording
  (rendering) time for information;
- segmentation: the k-means boundaries against the demonstration model's own phases.

The last line is ``reconstruction median=<mm> max=<mm> reprojection=<px> fps=<f>``
(targets: median <= 2 mm, max <= 5 mm, reprojection <= 0.5 px).  Not a test.

    python bench/perception.py [--seeds 0 1 2] [--keep DIR]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from hila_lang.core.fileio import load_yaml
from hila_lang.perception.learn import template_from_frames
from hila_lang.worlds.tictactoe.recording import record_demonstration
from hila_lang.worlds.tictactoe.vision import demonstration_icps


def run(seed: int, folder: Path) -> dict:
    t0 = time.perf_counter()
    record_demonstration(folder, seed, overwrite=True)
    t_record = time.perf_counter() - t0
    t0 = time.perf_counter()
    template, perc = template_from_frames(folder, read_icps=demonstration_icps, return_perception=True)
    t_pipe = time.perf_counter() - t0
    truth = load_yaml(folder / "truth.yaml")
    gt = np.array(truth["path"])
    err = np.linalg.norm(perc.path - gt, axis=1) * 1000
    err_tpl = np.linalg.norm(template.path - gt, axis=1) * 1000
    K = np.array(truth["K"])
    icp_err = {k: float(np.linalg.norm(template.icps[k] - np.array(truth["icps"][k])) * 1000) for k in template.icps}
    from hila_lang.worlds.tictactoe.demonstration import demonstrate

    phases = demonstrate(seed).phases
    return {
        "seed": seed, "frames": len(gt), "median": float(np.median(err)), "p95": float(np.percentile(err, 95)),
        "max": float(err.max()), "tpl": (float(np.median(err_tpl)), float(err_tpl.max())), "icp": icp_err, "cell": (perc.icp_reading.detail["cell"], truth["cell"]),
        "rms": {e: c.rms for e, c in perc.calibration.items()},
        "dK": {e: np.abs(np.array([c.K[0, 0], c.K[1, 1], c.K[0, 2], c.K[1, 2]])
                         - [K[0, 0], K[1, 1], K[0, 2], K[1, 2]]).max() for e, c in perc.calibration.items()},
        "stereo_rms": perc.stereo.rms if perc.stereo is not None else float("nan"),
        "reproj": perc.reprojection_px, "t_record": t_record, "t_pipe": t_pipe, "stages": perc.seconds,
        "segments": [(s.tag, s.start, s.stop) for s in template.segments], "phases": phases,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--keep", default=None, help="keep the recordings in this folder")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="hila_bench_perception_") as tmp:
        base = Path(args.keep) if args.keep else Path(tmp)
        for seed in args.seeds:
            r = run(seed, base / f"seed{seed}")
            rows.append(r)
            print(f"seed {seed}: {r['frames']} frames  path error median {r['median']:.2f} mm, "
                  f"p95 {r['p95']:.2f} mm, max {r['max']:.2f} mm; template path (contact snapped to the "
                  f"paper) median {r['tpl'][0]:.2f} mm, max {r['tpl'][1]:.2f} mm")
            print(f"  ICP error mm: " + ", ".join(f"{k} {v:.2f}" for k, v in r["icp"].items())
                  + f"; demonstrated cell {r['cell'][0]} (true {r['cell'][1]})")
            print(f"  calibration RMS px: left {r['rms']['left']:.3f}, right {r['rms']['right']:.3f}; "
                  f"max |K - K_true| px: left {r['dK']['left']:.3f}, right {r['dK']['right']:.3f}; "
                  f"stereo RMS {r['stereo_rms']:.3f}")
            print(f"  triangulation reprojection (median) px: left {r['reproj']['left']:.3f}, "
                  f"right {r['reproj']['right']:.3f}")
            stages = ", ".join(f"{k} {v:.2f} s" for k, v in r["stages"].items())
            print(f"  pipeline {r['t_pipe']:.1f} s = {r['frames'] / r['t_pipe']:.1f} frame pairs/s ({stages}); "
                  f"recording (rendering) {r['t_record']:.1f} s")
            print(f"  k-means segments {r['segments']}; model phases {r['phases']}")
    med = float(np.median([r["median"] for r in rows]))
    mx = float(max(r["max"] for r in rows))
    rep = float(max(max(r["rms"].values()) for r in rows))
    fps = float(sum(r["frames"] for r in rows) / sum(r["t_pipe"] for r in rows))
    print(f"reconstruction median={med:.2f} max={mx:.2f} reprojection={rep:.3f} fps={fps:.1f}")


if __name__ == "__main__":
    main()
