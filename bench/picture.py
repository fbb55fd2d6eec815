"""Scene matching in the picture world: route error with matched ICPs against the controls.

For each seed (a map texture, a route, a task pose) the robot's eyes (the PyBullet back end's,
through their lens, with the robot's own calibration and kinematic eye poses) see the map sheet
flat at the demonstration pose, then at the seeded task pose -- flat, and bent -- with distractor
boxes beside it and the light at a seeded 60-100 %.  :mod:`hila_lang.perception.matching` gives
the ICP pairs; ``hila_lang.osila.imitate`` maps the demonstrated route (3-D, on the demonstration
sheet) with each set of pairs plus the hand (the same point in both scenes, which the robot
knows); the referee measures each planned route's distance to the true route on the task sheet.

Conditions (``hila_lang.worlds.picture.scenes.CONTROLS``): ``matched`` (pairs kept by the local
verification, OSILA's own rejection on: what the robot runs), ``no rejection`` (every pair that
passed the ratio test, and OSILA told to keep them all), ``OSILA's rejection only`` (every such
pair, screened by OSILA alone), ``true ICPs`` (the kept pairs' features at their true places in
both scenes: what perfect triangulation would give; kept whole), ``corners`` (the sheet's four
true corners only).  Precision: the share of pairs whose task-eye pixel is within 4 px of where the truth
puts the demonstration's feature, before and after rejection (pooled over scenes).

    python bench/picture.py [--scenes 20] [--method sift|orb] [--model local|homography]

Routes are scored as planned (OSILA's output); executing them on the arm adds ~0.02 mm
(docs/design.md §5).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))



def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=20)
    ap.add_argument("--first", type=int, default=0, help="the first seed (seeds first .. first + scenes - 1)")
    ap.add_argument("--no-3d-check", action="store_true", help="verify in 2-D only (matching.SPATIAL_CHECK off)")
    ap.add_argument("--method", default="sift")
    ap.add_argument("--model", default="local")
    ap.add_argument("--ratio", type=float, default=0.8, help="Lowe's ratio (matching.RATIO)")
    ap.add_argument("--contrast", type=float, default=0.02, help="SIFT's contrast threshold (matching.SIFT_CONTRAST)")
    args = ap.parse_args(argv)

    from hila_lang.perception import matching as M
    from hila_lang.robot.backend import PyBulletBackend
    from hila_lang.worlds.picture import scenes as S
    from hila_lang.worlds.picture.texture import map_texture

    M.RATIO, M.SIFT_CONTRAST, M.SPATIAL_CHECK = args.ratio, args.contrast, not args.no_3d_check
    mat = S.mat()
    b = PyBulletBackend(mat)
    b.reset_hand(S.HOME)
    hidden = S.own_body(b)

    def look(sheet, tex, boxes=(), light=1.0):
        bodies = S.show(b, sheet, tex, boxes)
        b.lighting.set_light(light)
        images, truth = S.look(b)
        for body in bodies:
            b.sim.remove(body)
        b.lighting.set_light(1.0)
        return images, truth

    rows = {bent: {c: [] for c in S.CONTROLS} for bent in (False, True)}
    prec = {bent: [0, 0, 0, 0] for bent in (False, True)}  # true, matched, true kept, kept
    counts = {bent: [] for bent in (False, True)}
    clock = time.perf_counter()
    for seed in range(args.first, args.first + args.scenes):
        tex = map_texture(S.SIZE, seed)
        demo = S.demo_sheet(mat.z)
        (dl, dr), d_truth = look(demo, tex)
        demo_f = M.scene_features(dl, dr, args.method, hidden=hidden)
        route = S.route_uv(seed)
        path = demo.to_world(route)
        rng = np.random.default_rng([seed, 2404])
        boxes = [(h, [p[0], p[1], mat.z + p[2]], c) for h, p, c in S.distractors(seed)]
        for bent in (False, True):
            task = S.task_sheet(seed, mat.z, bent)
            (tl, tr), t_truth = look(task, tex, boxes, light=float(rng.uniform(0.6, 1.0)))
            pairs = M.match_scenes(demo_f, M.scene_features(tl, tr, args.method, hidden=hidden), args.model)
            true_demo, true_task, true = S.referee_pairs(pairs, demo, task, d_truth, t_truth)
            k = pairs.kept
            p = prec[bent]
            p[0] += int(true.sum()); p[1] += len(true); p[2] += int((true & k).sum()); p[3] += int(k.sum())
            counts[bent].append((pairs.counts["matched"], pairs.counts["kept"]))
            errors = S.control_errors(path, slice(None), S.control_sets(pairs, demo, task, true_demo, true_task),
                                      task.to_world(route), S.HOME)
            for name, value in errors.items():
                rows[bent][name].append(value)
    b.close()
    seconds = time.perf_counter() - clock
    print(f"seeds {args.first}..{args.first + args.scenes - 1} x (flat, bent); {args.method}, verification "
          f"{args.model}{'' if M.SPATIAL_CHECK else ' (2-D only)'}, ratio {args.ratio}, "
          f"SIFT contrast {args.contrast}; "
          f"{seconds:.0f} s; load {os.getloadavg()[0]:.1f}")
    print("| sheet | ICPs | route error median, mm | p95, mm | pairs matched / kept (median) | precision before -> after |")
    print("|---|---|---|---|---|---|")
    for bent in (False, True):
        m = np.median(np.array(counts[bent]), axis=0)
        p = prec[bent]
        for name in S.CONTROLS:
            e = np.array(rows[bent][name])
            ok = np.isfinite(e[:, 0])
            extra = f"{m[0]:.0f} / {m[1]:.0f} | {p[0] / max(p[1], 1):.2f} -> {p[2] / max(p[3], 1):.2f}" \
                if name == "matched" else " | "
            print(f"| {'bent' if bent else 'flat'} | {name} | {np.median(e[ok, 0]):.1f} | {np.median(e[ok, 1]):.1f} | "
                  f"{extra} |" + ("" if ok.all() else f" ({(~ok).sum()} failed)"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
