"""Scene matching in the picture world: route error with matched ICPs against the controls.

For each seed (a map texture, a route, a task pose) the robot's eyes (the PyBullet back end's,
through their lens, with the robot's own calibration and kinematic eye poses) see the map sheet
flat at the demonstration pose, then at the seeded task pose -- flat, and bent -- with distractor
boxes beside it and the light at a seeded 60-100 %.  :mod:`hila_lang.perception.matching` gives
the ICP pairs; ``hila_lang.osila.imitate`` maps the demonstrated route (3-D, on the demonstration
sheet) with each set of pairs plus the hand (the same point in both scenes, which the robot
knows); the referee measures each planned route's distance to the true route on the task sheet.

Conditions: ``matched`` (pairs kept by the local verification), ``no rejection`` (every pair
that passed the ratio test), ``true ICPs`` (the kept pairs' features at their true places in
both scenes: what perfect triangulation would give), ``corners`` (the sheet's four true corners
only).  Precision: the share of pairs whose task-eye pixel is within 4 px of where the truth
puts the demonstration's feature, before and after rejection (pooled over scenes).

    python bench/picture.py [--scenes 20] [--method sift|orb] [--model local|homography]

Routes are scored as planned (OSILA's output); executing them on the arm adds ~0.02 mm
(DESIGN.md section 4).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

CONDITIONS = ("matched", "no rejection", "true ICPs", "corners")
HAND = np.array([0.20, -0.28, 0.75])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=20)
    ap.add_argument("--method", default="sift")
    ap.add_argument("--model", default="local")
    args = ap.parse_args(argv)

    from hila_lang.osila import imitate
    from hila_lang.perception import matching as M
    from hila_lang.robot import model
    from hila_lang.robot.backend import PyBulletBackend
    from hila_lang.robot.lens import ICUB_EYE_K
    from hila_lang.robot.workspace import PAPER_THICKNESS, TABLE_TOP_Z
    from hila_lang.sim.camera import intersect_plane_z, project
    from hila_lang.sim.surface import Surface
    from hila_lang.worlds.picture import scenes as S
    from hila_lang.worlds.picture.texture import map_texture

    mat = Surface((0.30, -0.08), 0.0, TABLE_TOP_Z + PAPER_THICKNESS, (0.44, 0.50),
                  texture=np.full((100, 88, 3), (120, 130, 120), np.uint8))
    b = PyBulletBackend(mat)
    b.reset_hand(HAND)  # out of the eyes' view of the sheet

    def look(sheet, tex, boxes=(), light=1.0):
        v, uv, idx = sheet.mesh()
        bodies = [b.sim.add_mesh(tex, v, uv, idx, lit=False)]
        bodies += [b.sim.add_box(*box) for box in boxes]
        b.lighting.set_light(light)
        images = [b.eyes.camera_image(e) for e in ("left", "right")]
        truth = b.body.link_pose(model.EYE_LINKS["left"])  # the rendering camera: referee only
        for body in bodies:
            b.sim.remove(body)
        b.lighting.set_light(1.0)
        return images, truth

    rows = {bent: {c: [] for c in CONDITIONS} for bent in (False, True)}
    prec = {bent: [0, 0, 0, 0] for bent in (False, True)}  # true, matched, true kept, kept
    counts = {bent: [] for bent in (False, True)}
    clock = time.perf_counter()
    for seed in range(args.scenes):
        tex = map_texture(S.SIZE, seed)
        demo = S.demo_sheet(mat.z)
        (dl, dr), d_truth = look(demo, tex)
        demo_f = M.scene_features(dl, dr, args.method)
        route = S.route_uv(seed)
        path = demo.to_world(route)
        rng = np.random.default_rng([seed, 2404])
        boxes = [(h, [p[0], p[1], mat.z + p[2]], c) for h, p, c in S.distractors(seed)]
        for bent in (False, True):
            task = S.task_sheet(seed, mat.z, bent)
            (tl, tr), t_truth = look(task, tex, boxes, light=float(rng.uniform(0.6, 1.0)))
            pairs = M.match_scenes(demo_f, M.scene_features(tl, tr, args.method), args.model)
            # the referee: where each pair's demonstration feature truly is, in both scenes
            true_demo = intersect_plane_z(pairs.template_uv, ICUB_EYE_K, d_truth, demo.z)
            true_task = task.to_world(S.sheet_uv(demo, true_demo))
            true = np.linalg.norm(project(true_task, ICUB_EYE_K, t_truth) - pairs.task_uv, axis=1) < 4.0
            k = pairs.kept
            p = prec[bent]
            p[0] += int(true.sum()); p[1] += len(true); p[2] += int((true & k).sum()); p[3] += int(k.sum())
            counts[bent].append((pairs.counts["matched"], pairs.counts["kept"]))
            sets = {"matched": (pairs.template_points[k], pairs.task_points[k]),
                    "no rejection": (pairs.template_points, pairs.task_points),
                    "true ICPs": (true_demo[k], true_task[k]),
                    "corners": (demo.corners(), task.corners())}
            goal = task.to_world(route)
            for name, (src, dst) in sets.items():
                src, dst = np.vstack([src, HAND]), np.vstack([dst, HAND])
                try:
                    out = imitate(path, src, dst)
                    err = S.route_error(out, goal) * 1000
                    rows[bent][name].append((np.median(err), np.percentile(err, 95)))
                except Exception as exc:  # noqa: BLE001 - a failed warp is a result of the bench
                    rows[bent][name].append((np.nan, np.nan))
                    print(f"seed {seed} {'bent' if bent else 'flat'} {name}: {exc}", file=sys.stderr)
    b.close()
    seconds = time.perf_counter() - clock
    print(f"{args.scenes} seeds x (flat, bent); {args.method}, verification {args.model}; "
          f"{seconds:.0f} s; load {os.getloadavg()[0]:.1f}")
    print("| sheet | ICPs | route error median, mm | p95, mm | pairs matched / kept (median) | precision before -> after |")
    print("|---|---|---|---|---|---|")
    for bent in (False, True):
        m = np.median(np.array(counts[bent]), axis=0)
        p = prec[bent]
        for name in CONDITIONS:
            e = np.array(rows[bent][name])
            ok = np.isfinite(e[:, 0])
            extra = f"{m[0]:.0f} / {m[1]:.0f} | {p[0] / max(p[1], 1):.2f} -> {p[2] / max(p[3], 1):.2f}" \
                if name == "matched" else " | "
            print(f"| {'bent' if bent else 'flat'} | {name} | {np.median(e[ok, 0]):.1f} | {np.median(e[ok, 1]):.1f} | "
                  f"{extra} |" + ("" if ok.all() else f" ({(~ok).sum()} failed)"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
