"""Benchmark: can the robot's eyes tell its own mark from the opponent's cross, whatever mark it was taught?

Run from the checkout::

    python bench/marks.py                       # 7 marks x 4 styles x 2 seeds, 3 conditions
    python bench/marks.py --marks triangle,tick --seeds 1 --conditions still

For every mark (circle, triangle, tick, square, star, the letter A, a scribble) and every
person's style of the seeded pointer model (:mod:`hila_lang.worlds.tictactoe.drawing`: careful,
quick, shaky, small), the drawn demonstration is learned as ``hila learn`` learns it (cut where
the pen touches and leaves the paper, tags reach, draw, retract), and on PyBullet's game sheet
the iCub draws it with its own arm in three cells (the reach and the draw warped by OSILA onto
each cell's corners, as ``programs/game.hila`` does), while the world inks crosses, neat and
sloppy, in three others.  With the arm beside the board, both eyes read the board
(:func:`hila_lang.worlds.tictactoe.reading.read_board`, with the robot's own mark from its
template: :class:`hila_lang.worlds.tictactoe.ownmark.OwnMark`) under three conditions:
``still`` (the game's light, no sensor noise), ``dim`` (light 0.5, noise 6 grey levels: the
game battery's) and ``harsh`` (light 0.35, noise 12: beyond it).

Per row: the distance of the robot's own marks from its reference (max) and of the crosses
(min), and the readings that were wrong (a mark read as the other side's) or unclear ("?").
Before each mark is drawn, :func:`~hila_lang.worlds.tictactoe.ownmark.too_alike` says whether
the world would refuse it.  The last line sums it up::

    marks rows=56 images=336 own_max=0.071 cross_min=0.351 wrong=0 unclear=0 refused=0 wall=...

These figures chose :data:`~hila_lang.worlds.tictactoe.ownmark.OWN_BELOW` and ``OTHER_ABOVE``.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

MARKS = ("circle", "triangle", "tick", "square", "star", "A", "scribble")
CONDITIONS = {"still": (1.0, 0.0), "dim": (0.5, 6.0), "harsh": (0.35, 12.0)}
OWN_CELLS, CROSS_CELLS = (1, 5, 9), (3, 6, 7)


def learned(mark: str, style: str, seed: int):
    """The template a person's drawing of ``mark`` becomes (as ``hila learn`` cuts it)."""
    from hila_lang.osila.segmentation import segment_template
    from hila_lang.osila.template import Template
    from hila_lang.worlds.tictactoe.drawing import draw_mark

    d = draw_mark(mark, style, seed=seed)
    whole = Template(f"{mark}_{style}", d.path, d.icps, times=d.times)
    return segment_template(whole, 3, ["reach", "draw", "retract"], method="contact", contact=["draw"], pen=d.pen)


def draw_in(backend, template, spec, cell: int, lift: np.ndarray) -> None:
    """The robot draws ``template``'s reach and draw in ``cell`` with its arm, as game.hila does."""
    from hila_lang.hierarchy.step import hila_step
    from hila_lang.worlds.tictactoe.board import cell_corners

    corners = {k: v - [0, 0, 0.0005] for k, v in cell_corners(spec, cell).items()}
    backend.reset_hand(lift)
    reach = hila_step(template.sub("reach"), {**corners, "hand": lift}, lift).path
    backend.move(reach)
    draw = hila_step(template.sub("draw"), {**corners, "hand": None, "start": None}, backend.hand_position()).path
    backend.move(draw, pen_down=True)


def row(mark: str, style: str, seed: int, conditions) -> dict:
    from hila_lang.robot.backend import PyBulletBackend
    from hila_lang.worlds.tictactoe.board import Grid
    from hila_lang.worlds.tictactoe.marks import cross_strokes
    from hila_lang.worlds.tictactoe.ownmark import OwnMark, too_alike
    from hila_lang.worlds.tictactoe.reading import read_board

    template = learned(mark, style, seed)
    own = OwnMark.from_templates({f"{template.name}.draw": template.sub("draw")})
    refused = too_alike(own)
    spec = Grid.game()
    out = {"own": [], "cross": [], "wrong": 0, "unclear": 0, "images": 0, "refused": refused}
    with PyBulletBackend(spec.paper()) as backend:
        lift = spec.grid_to_world(0.0, 0.0) + [0.0, 0.0, 0.10]
        for cell in OWN_CELLS:
            draw_in(backend, template, spec, cell, lift)
        rng = np.random.default_rng([seed, 7])
        for k, cell in enumerate(CROSS_CELLS):
            for stroke in cross_strokes(spec, cell, rng, sloppy=k % 2 == 1):
                backend.ink.ink_polyline(stroke)
        backend.reset_hand(spec.grid_to_world(0.16, -0.10) + [0.0, 0.0, 0.10])  # beside the board
        for name in conditions:
            light, noise = CONDITIONS[name]
            backend.lighting.set_light(light, (0.2, 0.5, 1.0))
            backend.eyes.noise = noise
            for eye in ("left", "right"):
                r = read_board(backend.eyes.camera_image(eye), spec.surface_z, body=backend.eyes.body_outline(),
                               own=own)
                out["images"] += 1
                for cell, want, bucket in [(c, "O", "own") for c in OWN_CELLS] + [(c, "X", "cross") for c in CROSS_CELLS]:
                    seen, d = r.marks[cell - 1], r.distance[cell - 1]
                    if d is not None:
                        out[bucket].append(d)
                    out["unclear"] += seen == "?"
                    out["wrong"] += seen not in (want, "?")
    return out


def main(argv: list[str] | None = None) -> int:
    from hila_lang.worlds.tictactoe.drawing import STYLES

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--marks", default=",".join(MARKS), help="comma-separated marks (default: all seven)")
    parser.add_argument("--styles", default=",".join(STYLES), help="comma-separated styles (default: all)")
    parser.add_argument("--seeds", type=int, default=2, help="seeds per mark and style (default 2)")
    parser.add_argument("--conditions", default=",".join(CONDITIONS), help="still, dim, harsh (default: all)")
    args = parser.parse_args(argv)
    conditions = args.conditions.split(",")
    t0 = time.perf_counter()
    rows = []
    for mark in args.marks.split(","):
        for style in args.styles.split(","):
            for seed in range(args.seeds):
                r = row(mark, style, seed, conditions)
                rows.append(r)
                print(f"{mark:9s} {style:8s} seed {seed}: own max {max(r['own'], default=float('nan')):.3f}  "
                      f"cross min {min(r['cross'], default=float('nan')):.3f}  wrong {r['wrong']}  "
                      f"unclear {r['unclear']}" + (f"  REFUSED: {r['refused']}" if r["refused"] else ""),
                      file=sys.stderr, flush=True)
    own = [d for r in rows for d in r["own"]]
    cross = [d for r in rows for d in r["cross"]]
    print(f"marks rows={len(rows)} images={sum(r['images'] for r in rows)} own_max={max(own):.3f} "
          f"own_p99={np.percentile(own, 99):.3f} cross_min={min(cross):.3f} cross_p1={np.percentile(cross, 1):.3f} "
          f"wrong={sum(r['wrong'] for r in rows)} unclear={sum(r['unclear'] for r in rows)} "
          f"refused={sum(bool(r['refused']) for r in rows)} wall={time.perf_counter() - t0:.1f}s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
