"""A seeded, human-like stand-in for the paper's Experiment A trials (5 set-ups × 15 paths).

The paper's 75 human trials (its reference [14]) are not public.  This module generates paths
with the same structure, following the sketches of the paper's Fig. 5: planar reaches, seen by a
320 × 240 camera, from where the hand rests to an object that must be approached orthogonally to
one of its sides (the "blue strip"); set-up (c) approaches from the top, set-up (e) passes through
a waypoint area.  Everything is in image pixels, y pointing down, like the paper's data.

The human-like model of one trial
---------------------------------
- *Scene*: the set-up's nominal object (a 40 × 24 px rectangle), jittered per trial (σ = 4 px,
  σ = 4°); the resting hand position jittered (σ = 8 px); the waypoint area (e) jittered (σ = 3 px).
- *Geometry*: a cubic Hermite curve from the hand through the set-up's via points (a point
  above the object for (c), a point past the object's far side for (d), a point inside the
  waypoint area for (e)) to the approach point, a few pixels in front of the strip; via points
  jitter by σ = 6 px.  Its start heading, the tangent lengths (how round the curve is) and the side the
  curve bulges to vary per trial; the end tangent is the required approach direction.
- *Timing*: a minimum-jerk speed profile per stroke (one stroke per via point, overlapping like
  human sub-movements), skewed per trial (peak speed earlier or later); duration 1.6–3.2 s
  sampled at the paper's 20 Hz, so trials have different lengths (32–64 points).
- *Noise*: slow corrections (two sinusoids of 0.4–1.8 px, vanishing at both ends) plus marker
  noise (σ = 0.3–0.8 px, as the paper's 0.5 px uncertainty).  The hand ICP is the first path
  point seen through the same marker noise.

Why these amounts of variability
--------------------------------
Each number below models one source of trial-to-trial difference that is known to exist in
human reaching; none was tuned to any evaluation outcome (the generator predates the controls
and has not been changed for them).  Where the literature gives a size, the stand-in follows it;
where it does not (the paper gives no scale for its image), the value is a stated assumption,
and the README says what that limits.

- *Timing* — minimum-jerk strokes (Flash & Hogan 1985: bell-shaped speed, smooth starts and
  stops); strokes through a via point overlap, as human movements blend sub-movements (Morasso
  & Mussa-Ivaldi 1982; Flash & Hogan's via-point movements); the speed peak shifts earlier or
  later (time to peak speed 42–57 % of the movement, skew γ in 0.8–1.25: precision at the end
  lengthens the deceleration, MacKenzie et al. 1987).  Duration 1.6–3.2 s: an assumption for
  a demonstrator moving deliberately in front of a camera (unconstrained reaches are faster).
- *Path curvature* — hand paths of planar reaches are nearly straight but gently curved, with
  a curvature that depends on direction and workspace (Morasso 1981; Abend, Bizzi & Morasso
  1982; Atkeson & Hollerbach 1985): each set-up has its preferred side (``bulge``) and each
  trial varies the start heading (σ 18°) and the roundness of the curve (tangent length 0.6–1.7
  × the chord).  Initial direction errors of several degrees (Gordon, Ghilardi & Ghez 1994) are the part
  of this that is noise; the rest is style, i.e. different people — an assumption, since the
  paper's demonstrators are not described.
- *Scene* — the object is placed by hand between trials (σ 4 px, σ 4°), the resting hand
  varies more (σ 8 px); the waypoint area (σ 3 px) and the via points (σ 6 px) likewise.  In
  pixels of an image whose scale the paper does not give: assumptions.
- *Corrections* — two slow sinusoids (1–3 Hz, 0.4–1.8 px, vanishing at both ends) stand for
  the small corrective sub-movements of human reaching (Meyer et al. 1988), not physiological
  tremor (8–12 Hz, below the 20 Hz camera's reach and far smaller than a pixel here).
- *Measurement* — marker noise σ 0.3–0.8 px, the paper's own 0.5 px localisation uncertainty.

What the stand-in can and cannot show: it has the paper's structure (5 set-ups × 15 trials,
the same ICPs, 20 Hz, pixels), so it exercises every method on the paper's protocol and says
whether a reproduction behaves alike.  It cannot show how good OSILA is on human data: its
variability is a model with assumed sizes, and whatever structure the model lacks (or adds) is
lacking (or added) in every result.  Human data (``hila eval --dataset lasa``, or your own
``--dataset FOLDER``) is the test of that.

The five set-ups (:data:`SETUPS`; the paper's Exp 1–5 = Fig. 5 (a)–(e)) start from different
places and approach from different sides, so mapping one onto another changes the path's shape,
not only its placement.

ICPs per trial, paired by name across trials: ``hand`` (the resting hand), ``object.1`` ..
``object.4`` (corners: the two ends of the approach side, then the far side, so the TPS carries the
approach side onto the approach side) and, in set-up (e) only, ``waypoint`` (centre of the area).
A template and a task are paired on the ICP names they share.

The ``--dataset FOLDER`` format (also what :func:`save_dataset` writes)::

    FOLDER/
      <set-up>/                  one sub-folder per set-up (experiment), in name order
        <trial>.csv              the path, in the demonstration format of ``hila learn``:
                                 header "t,x,y", "t,x,y,z", "x,y" or "x,y,z", one row per
                                 sample (equal time steps assumed), at least 8 rows
        <trial>.icps.yaml        its ICPs, as for ``hila learn --icps``: "name: [x, y]"

Every trial needs both files, every trial the same dimension D, and every two trials at least
one ICP name in common (templates and tasks are paired by ICP name).  Anything else raises
:class:`~hila_lang.core.errors.InputError` naming the file (and the line).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..osila.demofile import load_icps, read_demo_csv, write_demo_csv, write_icps
from ..osila.motion import minimum_jerk

#: image size of the stand-in, pixels (the iCub cameras, paper §III.C)
IMAGE_SIZE = (320, 240)
#: camera rate, Hz (paper §III.C)
RATE_HZ = 20.0
#: minimum rows of a path (N = 4 segments need a few points each)
MIN_POINTS = 8
OBJECT_SIZE = (40.0, 24.0)  # along the approach side, across it (px)


@dataclass(frozen=True)
class SetUp:
    """One experiment of Fig. 5, in image pixels (y down).

    Attributes
    ----------
    name : str
        ``exp1`` .. ``exp5`` (the paper's Exp 1–5 = Fig. 5 (a)–(e)).
    sketch : str
        What the demonstrator does.
    hand : tuple of float
        Nominal resting hand position.
    obj : tuple of float
        Nominal centre of the object.
    approach : float
        Required approach heading, degrees in the image (0 = +x, 90 = +y, i.e. downwards).
    vias : tuple
        Nominal via points the path passes near, before the approach.
    waypoint : tuple of float or None
        Centre of the waypoint area (an ICP) or None.
    bulge : float
        Typical sideways start heading offset, degrees (the curve's preferred side).
    """

    name: str
    sketch: str
    hand: tuple[float, float]
    obj: tuple[float, float]
    approach: float
    vias: tuple[tuple[float, float], ...] = ()
    waypoint: tuple[float, float] | None = None
    bulge: float = 0.0


SETUPS: tuple[SetUp, ...] = (
    SetUp("exp1", "(a) reach to the right, approach from the left", (50, 190), (250, 145), 0.0, bulge=-15),
    SetUp("exp2", "(b) reach up and to the left, approach from below", (270, 210), (90, 70), -90.0, bulge=10),
    SetUp("exp3", "(c) approach from the top", (55, 195), (200, 190), 90.0, vias=((190, 85),), bulge=-30),
    SetUp("exp4", "(d) reach around the object, approach from its far (left) side", (270, 205), (175, 85),
          0.0, vias=((95, 110),), bulge=10),
    SetUp("exp5", "(e) through a waypoint area, approach from the right", (285, 110), (50, 95), 180.0,
          vias=((165, 200),), waypoint=(165, 200), bulge=15),
)


@dataclass(frozen=True)
class Trial:
    """One demonstration: a path with its scene ICPs.

    Attributes
    ----------
    setup : str
        Set-up (experiment) name; trials are grouped by it.
    name : str
        Trial name, unique within its set-up.
    path : ndarray, shape (T, D)
        The demonstrated path (pixels for the stand-in).
    icp_names : tuple of str
        ICP names, one per row of ``icps``.
    icps : ndarray, shape (K, D)
        ICP positions.
    """

    setup: str
    name: str
    path: np.ndarray
    icp_names: tuple[str, ...]
    icps: np.ndarray

    @property
    def label(self) -> str:
        """``setup/name``."""
        return f"{self.setup}/{self.name}"


# ----------------------------------------------------------------------------- generator


def _rot(deg: float) -> np.ndarray:
    a = np.deg2rad(deg)
    return np.array([np.cos(a), np.sin(a)])


def _hermite(p0, p1, m0, m1, n: int) -> np.ndarray:
    s = np.linspace(0.0, 1.0, n)[:, None]
    h00 = 2 * s**3 - 3 * s**2 + 1
    h10 = s**3 - 2 * s**2 + s
    h01 = -2 * s**3 + 3 * s**2
    h11 = s**3 - s**2
    return h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1


def _object_corners(centre: np.ndarray, approach_deg: float) -> np.ndarray:
    """Corners (4, 2): approach side (left, right as seen moving in), then far side (right, left)."""
    d = _rot(approach_deg)  # direction of motion into the object
    side = np.array([-d[1], d[0]])
    half_w, half_d = OBJECT_SIZE[0] / 2, OBJECT_SIZE[1] / 2
    near = centre - d * half_d
    far = centre + d * half_d
    return np.array([near - side * half_w, near + side * half_w, far + side * half_w, far - side * half_w])


def _geometry(setup: SetUp, hand, goal, vias, approach, rng) -> tuple[np.ndarray, list[float]]:
    """Dense curve (M, 2) from hand through vias to goal, and the arc length of each stroke."""
    knots = [np.asarray(hand, float)] + [np.asarray(v, float) for v in vias] + [np.asarray(goal, float)]
    # tangents: start heading bends off the chord; at a via the chord direction of its neighbours;
    # at the goal the approach direction.  Lengths scale with the chord (roundness per trial).
    first_chord = knots[1] - knots[0]
    heading = np.degrees(np.arctan2(first_chord[1], first_chord[0])) + setup.bulge + rng.normal(0, 18)
    round_start, round_end = rng.uniform(0.6, 1.7), rng.uniform(0.7, 1.8)
    tangents = [_rot(heading) * np.linalg.norm(first_chord) * round_start]
    for k in range(1, len(knots) - 1):
        chord = knots[k + 1] - knots[k - 1]
        tangents.append(chord / 2 * rng.uniform(0.8, 1.2))
    last_chord = knots[-1] - knots[-2]
    tangents.append(approach * np.linalg.norm(last_chord) * round_end)
    pieces, lengths = [], []
    for k in range(len(knots) - 1):
        seg = _hermite(knots[k], knots[k + 1], tangents[k], tangents[k + 1], 400)
        if pieces:
            seg = seg[1:]
        pieces.append(seg)
        lengths.append(float(np.linalg.norm(np.diff(seg, axis=0), axis=1).sum()))
    return np.vstack(pieces), lengths


def _time_law(lengths: list[float], n: int, rng) -> np.ndarray:
    """Arc length travelled at n equal time steps: overlapping minimum-jerk strokes, skewed."""
    total = sum(lengths)
    tau = np.linspace(0.0, 1.0, n)
    gamma = rng.uniform(0.8, 1.25)  # < 1: peak speed early (as often in reaching), > 1: late
    tau = tau**gamma
    share = np.cumsum([0.0] + lengths) / total  # stroke boundaries in arc length share
    overlap = 0.12
    s = np.zeros(n)
    for k, length in enumerate(lengths):
        t0 = max(share[k] - overlap * (k > 0), 0.0)
        t1 = min(share[k + 1] + overlap * (k < len(lengths) - 1), 1.0)
        s += length * minimum_jerk((tau - t0) / (t1 - t0))
    return s


def _along(curve: np.ndarray, s: np.ndarray) -> np.ndarray:
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(curve, axis=0), axis=1))])
    s = np.clip(s, 0.0, arc[-1])
    return np.column_stack([np.interp(s, arc, curve[:, 0]), np.interp(s, arc, curve[:, 1])])


def generate_trial(setup: SetUp, index: int, rng: np.random.Generator) -> Trial:
    """One human-like trial of ``setup`` (see the module docstring for the model)."""
    obj = np.asarray(setup.obj, float) + rng.normal(0, 4.0, 2)
    approach_deg = setup.approach + rng.normal(0, 4.0)
    corners = _object_corners(obj, approach_deg)
    d = _rot(approach_deg)
    side = np.array([-d[1], d[0]])
    near_mid = corners[:2].mean(0)
    goal = near_mid - d * rng.uniform(2.0, 6.0) + side * rng.uniform(-4.0, 4.0)
    hand = np.asarray(setup.hand, float) + rng.normal(0, 8.0, 2)
    shift = obj - np.asarray(setup.obj, float)
    waypoint = None
    if setup.waypoint is not None:
        waypoint = np.asarray(setup.waypoint, float) + rng.normal(0, 3.0, 2)
    vias = []
    for v in setup.vias:
        v = np.asarray(v, float)
        if setup.waypoint is not None and np.allclose(v, setup.waypoint):
            vias.append(waypoint + rng.uniform(-6.0, 6.0, 2))  # anywhere inside the area
        else:
            vias.append(v + shift + rng.normal(0, 6.0, 2))
    curve, lengths = _geometry(setup, hand, goal, vias, d, rng)
    n = int(round(rng.uniform(1.6, 3.2) * RATE_HZ))
    path = _along(curve, _time_law(lengths, n, rng))
    tau = np.linspace(0.0, 1.0, n)[:, None]
    window = np.sin(np.pi * tau)
    for _ in range(2):
        amp = rng.uniform(0.4, 1.8, 2)
        freq = rng.uniform(1.0, 3.0)
        phase = rng.uniform(0, 2 * np.pi, 2)
        path = path + window * amp * np.sin(2 * np.pi * freq * tau + phase)
    sigma = rng.uniform(0.3, 0.8)
    path = path + rng.normal(0, sigma, path.shape)
    names = ["hand", "object.1", "object.2", "object.3", "object.4"]
    icps = [path[0] + rng.normal(0, sigma, 2), *corners]
    if waypoint is not None:
        names.append("waypoint")
        icps.append(waypoint)
    return Trial(setup.name, f"trial{index + 1:02d}", path, tuple(names), np.array(icps))


def generate(seed: int = 0, trials_per_setup: int = 15, setups: tuple[SetUp, ...] = SETUPS) -> list[Trial]:
    """The stand-in dataset: ``trials_per_setup`` trials of each set-up, set-up by set-up.

    Parameters
    ----------
    seed : int
        Seed of the whole dataset; the same seed gives the same trials, bit for bit.  Each set-up
        draws from its own child stream, so adding trials to one set-up leaves the others alone.
    trials_per_setup : int
        15 in the paper.

    Returns
    -------
    list of Trial
        ``len(setups) * trials_per_setup`` trials, grouped by set-up.
    """
    if isinstance(trials_per_setup, bool) or not isinstance(trials_per_setup, (int, np.integer)) or trials_per_setup < 1:
        raise InputError(f"expected trials per set-up as an integer >= 1, got {trials_per_setup!r}")
    streams = np.random.SeedSequence(int(seed)).spawn(len(setups))
    trials = []
    for setup, stream in zip(setups, streams):
        rng = np.random.default_rng(stream)
        trials.extend(generate_trial(setup, i, rng) for i in range(int(trials_per_setup)))
    return trials


def setups_of(trials: list[Trial]) -> list[str]:
    """Set-up names in order of first appearance."""
    return list(dict.fromkeys(t.setup for t in trials))


# ----------------------------------------------------------------------------- folder format


def save_dataset(trials: list[Trial], folder: str | os.PathLike) -> Path:
    """Write ``trials`` in the ``--dataset FOLDER`` format (atomic files; lossless floats).

    Paths get a ``t`` column at :data:`RATE_HZ` (the stand-in's camera rate).
    """
    folder = Path(folder)
    for t in trials:
        write_demo_csv(folder / t.setup / f"{t.name}.csv", t.path, np.arange(len(t.path)) / RATE_HZ)
        write_icps(folder / t.setup / f"{t.name}.icps.yaml", dict(zip(t.icp_names, t.icps)),
                   header=f"ICPs of trial {t.label} (pixels)")
    return folder


def read_trial(path: Path, setup: str) -> Trial:
    """One trial: ``path`` (the demonstration CSV) and the ``.icps.yaml`` beside it.

    Both files use the formats of ``hila learn`` (:mod:`hila_lang.osila.demofile`), so
    a trial folder doubles as input to ``hila learn DEMO.csv --icps DEMO.icps.yaml``.
    """
    icp_path = path.with_name(path.stem + ".icps.yaml")
    if not icp_path.is_file():
        raise InputError(f"trial has no ICP file (expected {icp_path.name} beside it)", file=str(path))
    points, _ = read_demo_csv(path)
    if len(points) < MIN_POINTS:
        raise InputError(f"expected at least {MIN_POINTS} path points (N = 4 segments need a few each), "
                         f"got {len(points)}", file=str(path))
    icps = load_icps(icp_path, points.shape[1])
    return Trial(setup, path.stem, points, tuple(icps), np.array(list(icps.values()), dtype=float))


def load_dataset(folder: str | os.PathLike) -> list[Trial]:
    """Read a ``--dataset FOLDER`` (format in the module docstring), set-ups in name order."""
    folder = Path(folder)
    if not folder.exists():
        raise InputError("dataset folder not found", file=str(folder))
    if not folder.is_dir():
        raise InputError("expected a dataset folder, got a file", file=str(folder))
    setup_dirs = sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith("."))
    if not setup_dirs:
        raise InputError("expected one sub-folder per set-up holding <trial>.csv and <trial>.icps.yaml "
                         "files, found no sub-folders", file=str(folder))
    trials: list[Trial] = []
    for sdir in setup_dirs:
        paths = sorted(sdir.glob("*.csv"))
        if not paths:
            raise InputError("set-up folder has no trial files <trial>.csv", file=str(sdir))
        for stray in sorted(sdir.glob("*.icps.yaml")):
            if not stray.with_name(stray.name[: -len(".icps.yaml")] + ".csv").is_file():
                raise InputError("ICP file without its path file "
                                 f"{stray.name[: -len('.icps.yaml')]}.csv", file=str(stray))
        trials.extend(read_trial(p, sdir.name) for p in paths)
    dims = {t.path.shape[1] for t in trials}
    if len(dims) > 1:
        raise InputError("expected every trial in the same dimension, got both 2-D and 3-D paths", file=str(folder))
    _check_shared_names(trials, folder)
    return trials


def _check_shared_names(trials: list[Trial], folder: Path) -> None:
    """Every two trials must share an ICP name (checked once per distinct name set)."""
    kinds: dict[frozenset, Trial] = {}
    for t in trials:
        kinds.setdefault(frozenset(t.icp_names), t)
    for a, ta in kinds.items():
        for b, tb in kinds.items():
            if not a & b:
                raise InputError(
                    f"trials {ta.label} ({', '.join(ta.icp_names)}) and {tb.label} ({', '.join(tb.icp_names)}) "
                    "share no ICP name; templates and tasks are paired by ICP name", file=str(folder))
