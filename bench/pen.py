"""Benchmark: a pen tracked on the printed sheet by one webcam, against the truth.

Seeded synthetic videos (:mod:`hila_lang.perception.penvideo`: the sheet in perspective, a pen
with a 12 mm green ball on its tip drawing a loop in a grid cell with pauses, 640x480 at 30
fps, the camera's principal point 7 px off the centre the tracker assumes), each row one
perturbation turned up, fed frame by frame to :class:`hila_lang.perception.pen.PenTracker`
exactly as ``hila learn VIDEO --sheet`` feeds it.  Per row:

- ``tip_mm``: the tracked tip against the true tip on the frames where the pen is on the paper
  (the drawn stroke, what the template inks), millimetres on the paper: median, 95th percentile;
- ``air_mm``: the same in 3-D for the frames where the pen is in the air (its height is
  measured from the ball's apparent size), median;
- ``lost``: frames where the sheet or the ball was not seen and was interpolated, and every
  frame of a video the tracker refused (said as ``+N failed``);
- ``cut_s``: the tracked pen-down and pen-up times against the true ones, seconds: median and
  max over the videos' changes; ``spurious``: changes the tracker found that did not happen.

The last line is ``pen tip_mm median=... p95=... lost_frames=... cut_error_s median=...`` over
every video (goal: median <= 1 mm, p95 <= 3 mm).  Not a test.

    python bench/pen.py [--seeds 0 1 2] [--rows base,tilt,...] [--pictures DIR]

``--pictures DIR`` also draws what docs/camera.md shows: the sheet, a frame of the occlusion
video with what the tracker saw drawn over it, and a tracked path against the truth.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from hila_lang.core.errors import InputError
from hila_lang.perception.pen import PenTracker
from hila_lang.perception.penvideo import PenVideo, PenVideoSpec

#: the rows: name -> (what it changes, the spec's changes)
ROWS = {
    "base": ("defaults: 38 deg from vertical, blur 0.6 px, noise 1.5, light +-5 %", {}),
    "tilt": ("steep and turned: 55 deg from vertical, 25 deg round", {"tilt_deg": 55.0, "yaw_deg": 25.0}),
    "blur": ("optical blur 1.5 px, shutter open the whole frame", {"blur_px": 1.5, "exposure": 1.0}),
    "noise": ("sensor noise 6 grey levels", {"noise": 6.0}),
    "light": ("light +-25 %, its gradient turning", {"light": 0.25}),
    "occlusion": ("a hand over a marker for 1 s, over the ball 2 frames", {"occluder": True}),
    "letter": ("a Letter sheet without grid", {"paper": "letter", "grid": False}),
    "face-on": ("seen from 8 deg: focal length assumed", {"tilt_deg": 8.0}),
}


def changes(contact: np.ndarray, times: np.ndarray) -> list[tuple[float, bool]]:
    """(time, pen down after it) of every change of ``contact``."""
    idx = np.flatnonzero(np.diff(contact.astype(int))) + 1
    return [(float(times[i]), bool(contact[i])) for i in idx]


def one(spec: PenVideoSpec) -> dict:
    video = PenVideo(spec)
    truth = video.truth
    tracker = PenTracker(ball_mm=spec.ball_mm)
    t0 = time.perf_counter()
    for t, rgb in video:
        tracker.feed(rgb, t)
    try:
        track = tracker.finish()
    except InputError as exc:
        return {"failed": str(exc), "frames": len(video)}
    seconds = time.perf_counter() - t0
    down = truth.contact
    flat = np.linalg.norm(track.tip[down, :2] - truth.tip[down, :2], axis=1)
    air = np.linalg.norm(track.tip[~down] - truth.tip[~down], axis=1)
    found = changes(track.contact, track.times)
    cuts, used = [], set()
    for when, to_down in ((truth.touch, True), (truth.lift, False)):
        same = [(abs(t - when), k) for k, (t, d) in enumerate(found) if d == to_down and k not in used]
        if same:
            err, k = min(same)
            used.add(k)
            cuts.append(err)
        else:
            cuts.append(float("inf"))
    return {"flat": flat, "air": air, "cuts": cuts, "spurious": len(found) - len(used),
            "lost": len(set(track.sheet_bridged) | set(track.ball_bridged)), "frames": len(video),
            "fps": len(video) / seconds, "focal": (track.focal_px, track.focal_measured, truth.K[0, 0])}


def pictures(folder) -> None:
    """``camera-sheet.png``, ``camera-frame.jpg`` and ``camera-path.png`` in ``folder``."""
    from pathlib import Path

    import cv2

    from hila_lang.core.fileio import write_png
    from hila_lang.perception.sheet import SheetLayout, raster

    folder = Path(folder)
    sheet = raster(SheetLayout("a4", True), 2.0)
    write_png(folder / "camera-sheet.png", np.pad(sheet, 2, constant_values=120))
    video = PenVideo(PenVideoSpec(seed=2, cell=5, occluder=True))
    tracker = PenTracker()
    frames = [tracker.feed(rgb, t) for t, rgb in video]
    track = tracker.finish()
    hidden = video.truth.marker_hidden
    shown = frames[hidden[len(hidden) // 2]]  # the hand over the marker, halfway through
    scale = 2
    img = cv2.resize(video.frame(shown.index), None, fx=scale, fy=scale, interpolation=cv2.INTER_CUBIC)

    def px(p):
        return tuple(int(round((v + 0.5) * scale - 0.5)) for v in p)

    printed = tracker.layout.marker_corners()
    for marker_id, corners in printed.items():
        if marker_id in shown.markers:
            colour, pts = (30, 170, 60), shown.markers[marker_id]
        else:  # remembered: where the sheet's fit puts it
            q = np.column_stack([corners, np.ones(4)]) @ shown.H.T
            colour, pts = (255, 140, 0), q[:, :2] / q[:, 2:]
        cv2.polylines(img, [np.array([px(p) for p in pts], np.int32)], True, colour, 2, cv2.LINE_AA)
    cv2.circle(img, px(shown.ball), int(round(shown.ball_radius * scale)), (220, 0, 220), 2, cv2.LINE_AA)
    cv2.rectangle(img, (0, img.shape[0] - 56), (img.shape[1], img.shape[0]), (255, 255, 255), -1)
    cv2.putText(img, "markers seen (green); hidden now, taken from the last frame with all four (orange)",
                (10, img.shape[0] - 34), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(img, "the ball's outline (magenta): brightness edges, the pen's body left out",
                (10, img.shape[0] - 10), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 0, 0), 1, cv2.LINE_AA)
    from hila_lang.core.fileio import atomic_write_bytes

    ok, jpg = cv2.imencode(".jpg", cv2.cvtColor(img[150:], cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 88])
    atomic_write_bytes(folder / "camera-frame.jpg", jpg.tobytes())
    # the path from above (the sheet as the person sees it) and the height over time
    W, H, pad, s = 520, 520, 30, 3.2  # px, px, px, px per mm
    truth = video.truth
    centre = truth.tip[truth.contact, :2].mean(axis=0)
    top = np.full((H, W, 3), 255, np.uint8)

    def at(p):
        return (int(round(W / 2 + (p[0] - centre[0]) * s)), int(round(H / 2 - (p[1] - centre[1]) * s)))

    feats = tracker.layout.features()
    for name in ("tl", "tr", "br", "bl"):
        cv2.drawMarker(top, at(feats[f"cell5.{name}"]), (0, 0, 0), cv2.MARKER_CROSS, 14, 1)
    for k in range(len(truth.tip) - 1):
        cv2.line(top, at(truth.tip[k]), at(truth.tip[k + 1]), (170, 170, 170), 5, cv2.LINE_AA)
    for k in range(len(track.tip) - 1):
        down = track.contact[k] and track.contact[k + 1]
        cv2.line(top, at(track.tip[k]), at(track.tip[k + 1]), (20, 60, 200) if down else (230, 120, 20),
                 2 if down else 1, cv2.LINE_AA)
    cv2.putText(top, "from above, mm: true tip (grey), tracked pen down (blue), up (orange);",
                (8, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(top, "+ the printed cell's corners (the ICPs of --cell 5)", (8, 36), cv2.FONT_HERSHEY_SIMPLEX,
                0.45, (0, 0, 0), 1, cv2.LINE_AA)
    side = np.full((H, W, 3), 255, np.uint8)
    t_end = float(track.times[-1])

    def th(t, z):
        return (int(round(pad + t / t_end * (W - 2 * pad))), int(round(H - pad - z * 5.0)))

    for k in range(len(track.times)):
        if track.contact[k]:
            cv2.line(side, th(track.times[k], 0)[:1] + (H - pad,), th(track.times[k], 0)[:1] + (pad + 40,),
                     (225, 240, 225), 4)
    cv2.line(side, th(0, 0), th(t_end, 0), (0, 0, 0), 1)
    for k in range(len(truth.times) - 1):
        cv2.line(side, th(truth.times[k], truth.tip[k, 2]), th(truth.times[k + 1], truth.tip[k + 1, 2]),
                 (170, 170, 170), 5, cv2.LINE_AA)
    for k in range(len(track.times) - 1):
        cv2.line(side, th(track.times[k], track.height[k]), th(track.times[k + 1], track.height[k + 1]),
                 (20, 60, 200), 2, cv2.LINE_AA)
    cv2.putText(side, "height over time (5 px per mm, 0 to 6.5 s): true (grey),", (8, 18), cv2.FONT_HERSHEY_SIMPLEX,
                0.45, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(side, "measured from the ball's size (blue); green: tracked pen down", (8, 36),
                cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    write_png(folder / "camera-path.png", np.hstack([top, np.full((H, 6, 3), 200, np.uint8), side]))
    print(f"pictures -> {folder}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--rows", default=",".join(ROWS), help="comma-separated rows (default all)")
    parser.add_argument("--pictures", metavar="DIR", help="also draw docs/camera.md's pictures into DIR")
    args = parser.parse_args(argv)
    if args.pictures:
        pictures(args.pictures)
    rows = [r.strip() for r in args.rows.split(",")]
    unknown = [r for r in rows if r not in ROWS]
    if unknown:
        parser.error(f"unknown rows {unknown}; expected some of {', '.join(ROWS)}")
    print(f"{'row':<10} {'videos':>6} {'tip_mm med':>10} {'p95':>6} {'air_mm med':>10} {'lost':>5} "
          f"{'cut_s med':>9} {'max':>6} {'spurious':>8}  focal px (true)      what")
    flat_all, cuts_all, lost_all = [], [], 0
    for name in rows:
        what, change = ROWS[name]
        results = [one(PenVideoSpec(seed=s, **change)) for s in args.seeds]
        ok = [r for r in results if "failed" not in r]
        failed = len(results) - len(ok)
        lost_all += sum(r["frames"] for r in results if "failed" in r)  # a refused video loses every frame
        for r in results:
            if "failed" in r:
                print(f"  {name} failed: {r['failed']}")
        if not ok:
            print(f"{name:<10} {len(results):>6}  all failed")
            continue
        flat = np.concatenate([r["flat"] for r in ok])
        air = np.concatenate([r["air"] for r in ok])
        cuts = np.array([c for r in ok for c in r["cuts"]])
        lost = sum(r["lost"] for r in ok)
        flat_all.append(flat)
        cuts_all.append(cuts)
        lost_all += lost
        focal = ok[0]["focal"]
        focal_text = f"{focal[0]:.0f}{'' if focal[1] else ' assumed'} ({focal[2]:.0f})"
        print(f"{name:<10} {len(results):>6} {np.median(flat):>10.2f} {np.percentile(flat, 95):>6.2f} "
              f"{np.median(air):>10.2f} {lost:>5}{'' if not failed else f'+{failed} failed':<0} "
              f"{np.median(cuts):>9.3f} {cuts.max():>6.3f} {sum(r['spurious'] for r in ok):>8}  "
              f"{focal_text:<20} {what}", flush=True)
    flat = np.concatenate(flat_all) if flat_all else np.array([np.nan])
    cuts = np.concatenate(cuts_all) if cuts_all else np.array([np.nan])
    print(f"pen tip_mm median={np.median(flat):.2f} p95={np.percentile(flat, 95):.2f} "
          f"lost_frames={lost_all} "
          f"cut_error_s median={np.median(cuts):.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
