"""Benchmark: the sheet moves while the pen draws -- four controllers in one run (issue 34).

A small simulation on hila's own engine: the tic-tac-toe circle (``primitives/circle.yaml``,
``reach`` then ``draw``) warped onto cell 5 of the game's grid, run by the interpreter on the dry
back end (its ``streaming`` clock: 240 Hz, the pen at 5 cm/s down, exactly on its path).  While
the pen is down the sheet moves (the truth, kept by this script's world):

- ``slide``: 3 cm in a seeded direction and turned 10 degrees (seeded sign) over 1.5 s
  (minimum jerk), starting at a seeded 20-60 % of the stroke;
- ``jump``: 1 cm in a seeded direction at once, at a seeded 20-60 % of the stroke.

The robot perceives the sheet late and noisily: what it sees at a look is the sheet as it was
100 ms before, shifted by a seeded Gaussian error of 1 mm per axis (the ``--latency`` and
``--noise`` options).  Four controllers, each on the same seeds:

- ``none``: the plan made when the pen went down, no re-plan (the program without ``track``);
- ``dmp``: a DMP (``movement_primitives.dmp.DMP``, 50 weights per axis) learned from that same
  plan, rolled out at 240 Hz, its goal moved every 100 ms with the perceived sheet (the online goal
  change of ``DMP.step``, which reads ``goal_y`` each step);
- ``rewarp100`` / ``rewarp50``: the program with ``track board.cell5 every 100 ms blend 5 mm`` (50 ms),
  and ``lift above 5 mm`` in the jump case -- hila's re-warp (:mod:`hila_lang.engine.tracking`).

Measured on the ink in the sheet's frame (the pen's samples where it touches the paper, each
taken into the sheet's frame as the sheet lay at that instant), against the plan made when the
pen went down (the circle as it should be on the sheet): the closure gap (where the ink ends
from where the circle should end), the largest and the rms distance of the ink from that circle,
the share of the ink more than 2 mm off, and the ink outside the cell.  Medians over the seeds.
The last line is
``replan closure_mm median=... max_dev_mm median=... rms_mm median=... dmp_closure_mm median=...``
(re-warp at 100 ms and the DMP control, slide case).

    python bench/replan.py [--seeds 10] [--latency 0.1] [--noise 0.001] [--blend 0.005]
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from hila_lang.engine.interpreter import Interpreter
from hila_lang.engine.tracking import motion
from hila_lang.language import load_program
from hila_lang.osila.motion import minimum_jerk
from hila_lang.robot.dry import DryBackend
from hila_lang.robot.streaming import DryStream
from hila_lang.worlds.tictactoe.board import CORNER_NAMES, Grid, cell_corners

ROOT = Path(__file__).resolve().parents[1]
CELL = 5
#: the sheet's moves
SLIDE, SLIDE_TURN, SLIDE_SECONDS, JUMP = 0.03, 10.0, 1.5, 0.01
#: the pen touches the paper when its tip is at most this above it, metres
CONTACT = 0.0005
OFF = 0.002  # "more than 2 mm off"
DMP_WEIGHTS = 50

PROGRAM = """world scripted
import "{primitives}/circle.yaml" as circle
main {{
    run circle.reach(board.cell5.*, hand = hand)
    run circle.draw(board.cell5.*, hand = none){track}
}}
"""


class SheetWorld:
    """The bench's world: a sheet whose truth moves during the pen-down step, and the robot's
    late, noisy view of it (its ``tracking`` capability is itself)."""

    scene = None
    snapshots = None

    def __init__(self, case: str, seed: int, latency: float, noise: float, slide: float = SLIDE,
                 turn: float = SLIDE_TURN, seconds: float = SLIDE_SECONDS) -> None:
        self.grid = Grid.game()
        self.slide, self.seconds = slide, seconds
        self.rng = np.random.default_rng([seed, 34])
        self.case, self.latency, self.noise = case, latency, noise
        self.angle = self.rng.uniform(0.0, 2.0 * math.pi)
        self.turn = math.radians(turn) * (1.0 if self.rng.uniform() < 0.5 else -1.0)
        self.fraction = self.rng.uniform(0.2, 0.6)
        self.noise_rng = np.random.default_rng([seed, 34, 1])
        local = cell_corners(self.grid, CELL)
        self.corners = np.array([local[n] for n in CORNER_NAMES])
        self.centre = self.corners.mean(0)
        self.moving = True
        self.pen = None  # () -> (3,): the pen tip, set by the controller
        self.samples: list[tuple[float, np.ndarray, tuple]] = []  # (t, pen, pose) while the pen is down
        self.history: list[tuple[float, tuple]] = []
        self.pose = (0.0, 0.0, 0.0)  # (dx, dy, dtheta) of the sheet from where it was laid
        self.seen: dict | None = None
        self.down = False
        self.start_at = 0.0
        self.tracking = self

    # -- the truth -------------------------------------------------------------------------
    def pose_at(self, t: float) -> tuple:
        if not self.down or t < self.start_at:
            return (0.0, 0.0, 0.0)
        if self.case == "jump":
            return (JUMP * math.cos(self.angle), JUMP * math.sin(self.angle), 0.0)
        w = float(minimum_jerk((t - self.start_at) / self.seconds))
        return (w * self.slide * math.cos(self.angle), w * self.slide * math.sin(self.angle), w * self.turn)

    def place(self, points: np.ndarray, pose: tuple) -> np.ndarray:
        """Sheet points as laid out, moved by ``pose`` (rotation about the cell's centre)."""
        dx, dy, a = pose
        c, s = math.cos(a), math.sin(a)
        rel = points - self.centre
        out = points.copy()
        out[..., 0] = self.centre[0] + c * rel[..., 0] - s * rel[..., 1] + dx
        out[..., 1] = self.centre[1] + s * rel[..., 0] + c * rel[..., 1] + dy
        return out

    def unplace(self, points: np.ndarray, pose: tuple) -> np.ndarray:
        """World points into the sheet as laid out (the inverse of :meth:`place`)."""
        dx, dy, a = pose
        c, s = math.cos(a), math.sin(a)
        rel = points[..., :2] - self.centre[:2] - np.array([dx, dy])
        out = np.array(points, dtype=float)
        out[..., 0] = self.centre[0] + c * rel[..., 0] + s * rel[..., 1]
        out[..., 1] = self.centre[1] - s * rel[..., 0] + c * rel[..., 1]
        return out

    # -- the World protocol ------------------------------------------------------------------
    def attach(self, backend) -> None:
        pass

    def points(self) -> dict:
        if self.seen is not None:
            return dict(self.seen)
        placed = self.place(self.corners, self.pose)
        return {f"board.cell5.{n}": placed[i] for i, n in enumerate(CORNER_NAMES)}

    def query(self, name, *args):
        raise KeyError(name)

    def wait(self, event, *args):
        raise KeyError(event)

    def notify(self, event, **data) -> None:
        pass

    def finish(self, trace, *, fsm=None):
        return None

    # -- the Tracking protocol ---------------------------------------------------------------
    def begin(self, state: str, pen_down: bool, seconds: float) -> None:
        self.down = bool(pen_down)
        self.start_at = self.fraction * seconds
        self.history = [(0.0, self.pose)]
        self.seen = self.points()

    def elapse(self, t: float) -> None:
        self.pose = self.pose_at(t)
        self.history.append((t, self.pose))
        if self.down:
            self.samples.append((t, np.asarray(self.pen(), dtype=float).copy(), self.pose))

    def look(self) -> None:
        t_now = self.history[-1][0]
        pose = next(p for t, p in reversed(self.history) if t <= t_now - self.latency + 1e-9) \
            if t_now >= self.latency else self.history[0][1]
        err = self.noise_rng.normal(0.0, self.noise, size=2)
        placed = self.place(self.corners, (pose[0] + err[0], pose[1] + err[1], pose[2]))
        self.seen = {f"board.cell5.{n}": placed[i] for i, n in enumerate(CORNER_NAMES)}

    def end(self) -> None:
        self.seen = None
        self.down = False


def run_program(case: str, seed: int, track: str, args, folder: Path):
    """One run of the program with ``track`` (a clause, or "" for none): (world, the draw's trace entry)."""
    file = folder / f"bench{abs(hash(track)) % 10**8}.hila"
    file.write_text(PROGRAM.format(primitives=(ROOT / "primitives").as_posix(), track=track), encoding="utf-8")
    checked, fsm = load_program(file)
    world = SheetWorld(case, seed, args.latency, args.noise, args.slide, args.turn, args.seconds)
    grid = world.grid
    backend = DryBackend(cell_corners(grid, CELL)["tl"] + np.array([-0.03, -0.08, 0.12]), surface_z=grid.surface_z)
    world.pen = backend.hand_position
    interp = Interpreter(checked, fsm, world, backend)
    entries = interp.run()
    return world, next(e for e in entries if e.state.endswith("draw"))


def first_plan(case: str, seed: int, args, folder: Path) -> np.ndarray:
    """The draw's plan when the pen goes down (the controllers' common start)."""
    return run_program(case, seed, "", args, folder)[1].path


def run_dmp(case: str, seed: int, plan: np.ndarray, args) -> SheetWorld:
    """The DMP control: learned from ``plan``, its goal moved every 100 ms with the perceived sheet."""
    from movement_primitives.dmp import DMP

    world = SheetWorld(case, seed, args.latency, args.noise, args.slide, args.turn, args.seconds)
    dt = DryStream(None).dt  # the dry clock's control step
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(plan, axis=0), axis=1))])
    duration = arc[-1] / 0.05  # the dry pen's speed with the pen down
    times = arc / 0.05
    dmp = DMP(3, execution_time=duration, dt=dt, n_weights_per_dim=DMP_WEIGHTS)
    dmp.imitate(times, plan)
    dmp.configure(start_y=plan[0], goal_y=plan[-1])
    y, yd = plan[0].copy(), np.zeros(3)
    world.pen = lambda: y
    world.begin("draw", True, duration)
    seen0 = np.array(list(world.points().values()))
    steps = int(round(duration / dt))
    every = int(round(0.1 / dt))
    for k in range(1, steps + 1):
        y, yd = dmp.step(y, yd)
        world.elapse(k * dt)
        if k % every == 0:
            world.look()
            move = motion(seen0, np.array(list(world.points().values())))
            dmp.configure(goal_y=move(plan[-1]))
    world.end()
    return world


def score(world: SheetWorld, plan: np.ndarray) -> dict:
    """The ink in the sheet's frame against ``plan`` (the circle as it should be on the sheet)."""
    pens = np.array([p for _, p, _ in world.samples])
    poses = [pose for _, _, pose in world.samples]
    on_sheet = np.array([world.unplace(p, pose) for p, pose in zip(pens, poses)])
    ink = on_sheet[pens[:, 2] <= world.grid.surface_z + CONTACT]
    a, b = plan[:-1, :2], plan[1:, :2]
    ab = b - a
    q = ink[:, None, :2] - a[None]
    u = np.clip((q * ab[None]).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-18), 0.0, 1.0)
    dev = np.linalg.norm(q - u[..., None] * ab[None], axis=-1).min(axis=1)
    local = world.grid.world_to_grid(ink)  # the cell in the sheet as laid out
    half = world.grid.grid_size / 6
    centre = world.grid.world_to_grid(world.centre)
    outside = np.maximum(np.abs(local - centre).max(axis=1) - half, 0.0)
    return {"closure": float(np.linalg.norm(ink[-1, :2] - plan[-1, :2])), "max": float(dev.max()),
            "rms": float(np.sqrt((dev ** 2).mean())), "share": float((dev > OFF).mean()),
            "outside": float(outside.max()), "outside_n": int((outside > 0).sum())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10, help="seeds per case (0..N-1)")
    ap.add_argument("--latency", type=float, default=0.1, help="how old what the robot sees is, seconds")
    ap.add_argument("--noise", type=float, default=0.001, help="error of the perceived sheet pose, metres per axis")
    ap.add_argument("--slide", type=float, default=SLIDE, help="how far the sheet slides, metres (slide case)")
    ap.add_argument("--turn", type=float, default=SLIDE_TURN, help="how far it turns meanwhile, degrees (slide case)")
    ap.add_argument("--seconds", type=float, default=SLIDE_SECONDS, help="how long the slide takes, seconds")
    ap.add_argument("--blend", type=float, default=0.005, help="the re-warp's blend, metres (the language's default)")
    args = ap.parse_args()
    clock = time.perf_counter()
    controllers = ("none", "dmp", "rewarp100", "rewarp50")
    results = {(case, c): [] for case in ("slide", "jump") for c in controllers}
    with tempfile.TemporaryDirectory(prefix="hila-replan-") as tmp:
        folder = Path(tmp)
        for case in ("slide", "jump"):
            lift = " lift above 5 mm" if case == "jump" else ""
            for seed in range(args.seeds):
                plan = first_plan(case, seed, args, folder)
                results[(case, "none")].append(score(run_program(case, seed, "", args, folder)[0], plan))
                results[(case, "dmp")].append(score(run_dmp(case, seed, plan, args), plan))
                for every, name in ((100, "rewarp100"), (50, "rewarp50")):
                    track = f" track board.cell5 every {every} ms blend {args.blend * 1000:g} mm{lift}"
                    results[(case, name)].append(score(run_program(case, seed, track, args, folder)[0], plan))
    print(f"sheet moved while the pen draws: {args.seeds} seeds per case (slide {args.slide * 1000:g} mm and "
          f"{args.turn:g} degrees in {args.seconds:g} s; jump {JUMP * 1000:g} mm), latency {args.latency * 1000:g} ms, "
          f"pose noise {args.noise * 1000:g} mm per axis, blend {args.blend * 1000:g} mm (medians over the seeds; "
          f"{time.perf_counter() - clock:.0f} s)")
    print(f"{'case':6} {'controller':10} {'closure mm':>10} {'max mm':>8} {'rms mm':>8} {'> 2 mm':>7} "
          f"{'outside mm':>10} {'runs with ink outside':>22}")
    med = {}
    for (case, c), rows in results.items():
        m = {k: float(np.median([r[k] for r in rows])) for k in ("closure", "max", "rms", "share", "outside")}
        med[(case, c)] = m
        bad = sum(r["outside_n"] > 0 for r in rows)
        print(f"{case:6} {c:10} {m['closure'] * 1000:10.2f} {m['max'] * 1000:8.2f} {m['rms'] * 1000:8.2f} "
              f"{m['share'] * 100:6.0f}% {max(r['outside'] for r in rows) * 1000:10.2f} {bad:>15} of {len(rows)}")
    r, d = med[("slide", "rewarp100")], med[("slide", "dmp")]
    print(f"replan closure_mm median={r['closure'] * 1000:.2f} max_dev_mm median={r['max'] * 1000:.2f} "
          f"rms_mm median={r['rms'] * 1000:.2f} dmp_closure_mm median={d['closure'] * 1000:.2f}")


if __name__ == "__main__":
    main()
