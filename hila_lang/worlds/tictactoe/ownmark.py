"""The robot's own mark: what it was shown, and telling it from the opponent's.

The robot knows its mark by the template its program draws with, not by a shape written into
the code.  :meth:`OwnMark.from_templates` takes the program's pen-down sub-templates (the world
is told them before the run: ``notify("program", marks=...)``) and keeps, of each, the points
the pen inked: the samples of its contact segments on the paper -- within
:data:`~hila_lang.sim.surface.CONTACT_TOLERANCE` of the lowest of them for a 3-D template
(pen-up moves between strokes are lifted off the paper), all of them for a 2-D one -- as
strokes in the paper's plane seen from above (x, y; a 3-D template's plane is its ink's own,
its normal turned up, so a mark is never read mirrored).

Comparing.  A cell's ink (a mask in the board reader's top view, :mod:`.reading`) is compared
with a reference by :meth:`OwnMark.distance`: the reference's strokes are placed on the ink by
the similarity (turn, scale, shift) that fits them best -- OSILA may put the mark anywhere in the
cell, at any size and turn, and the opponent's crosses turn too -- and the distance is the
symmetric chamfer distance at that fit, beyond :data:`TOLERANCE` (blur and the pen's edge), as a
fraction of the ink's size (its RMS radius): the mean of how far the reference's strokes lie
from the ink (parts of the robot's mark not there) and of how far the ink lies from them (ink
the robot's mark does not explain).  The fit: turns every :data:`TURN_STEP` degrees at the
ink's own centre and size, then from the best three, :data:`ICP_ROUNDS` rounds of ICP (nearest
points both ways, then the best similarity for them); distances come from k-d trees, one query
of each tree for all the turns and one per round for the three ICP fits together, so a
comparison costs about ten milliseconds.  It never mirrors: a mark is read as drawn.

Deciding (:meth:`OwnMark.classify`): the robot's own mark when the distance is below
:data:`OWN_BELOW`, the opponent's when above :data:`OTHER_ABOVE`, and *unclear* (``"?"``) in
between: the reader says so, the robot looks again from other views (:mod:`.vision`), and the
report lists what stayed unclear; it is never guessed.  A mark too like the opponent's cross
(:func:`too_alike`: one of a seeded set of the world's own crosses, neat and sloppy, rendered as
the reader sees ink, lies closer than :data:`OTHER_ABOVE` plus :data:`MARGIN`) is refused
before the game (``hila check``: :func:`check_mark`), with the distance and what to do.

Remembering (:class:`KeptReadings`): the robot's looks read every cell's ink, and a mark once
read is the same mark at the next look.  A sure reading of a cell (confidence 1) is kept while
the ink there stays the same (:data:`SAME_INK`: the two masks' overlap with their centroids laid
on each other); other ink, or the same ink read unsure, is compared anew.  In a game (seed 0)
13 of 54 cell readings are comparisons, and the readings are those it made comparing all 54.

The thresholds were measured (``bench/marks.py``; docs/benchmarks.md): seven marks (circle,
triangle, tick, square, star, the letter A, a scribble), each drawn by four people's styles of
the seeded pointer model (:mod:`.drawing`), learned, drawn by the iCub's arm in three cells of
PyBullet's game sheet with OSILA, crosses neat and sloppy in three others, both eyes reading, in
the game's light, the battery's dim light with sensor noise (light 0.5, noise 6) and harsher
(0.35, noise 12).  In the game's light and the dim light the robot's own marks lie at most 0.003
from their reference and crosses at least 0.038 (the star is the shape closest to a cross; a
letter X lies 0.003 from one: refused).  With the harsh light as well (168 images, 1008 marks):
own marks at most 0.025 (99 % within 0.012), crosses at least 0.030 (99 % beyond 0.041); none
read as the other side's, 2 unclear.  So :data:`OWN_BELOW` 0.015 and :data:`OTHER_ABOVE` 0.03.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field

import numpy as np

from ...osila.fallback import fit_similarity
from ...sim.surface import CONTACT_TOLERANCE
from .board import Grid
from .marks import cross_strokes

#: below this distance a cell's ink is the robot's own mark (measured: see the module docstring)
OWN_BELOW = 0.015
#: above this distance it is the opponent's; between the two it is unclear
OTHER_ABOVE = 0.03
#: a mark whose distance from some cross is below OTHER_ABOVE + MARGIN is refused before the game
MARGIN = 0.005
#: how far beyond its threshold a reading is fully sure (confidence 1; 0.5 at half of it)
SURE_BY = 0.01
#: what the reader writes for a cell whose ink is neither clearly the robot's nor the opponent's
UNCLEAR = "?"
#: turns tried before refining, degrees
TURN_STEP = 15.0
#: rounds of refining (ICP: nearest points both ways, then the best similarity), from the best three turns
ICP_ROUNDS = 6
#: ink within this distance of where it should be costs nothing, metres (blur and the pen's edge)
TOLERANCE = 0.002
#: the pen's width the reader expects, metres (a stroke's spread, for the ink's size)
PEN_WIDTH = 0.003
#: spacing of a reference's points in its unit frame (units of its RMS radius)
_STEP = 0.03
#: at most this many of the ink's pixels are fitted to (an even subset; the distance uses all)
FIT_POINTS = 200
#: a cell's ink at least this alike (:func:`ink_overlap`) to the ink last compared there keeps
#: that comparison's reading when it was sure (:class:`KeptReadings`).  Measured on the game's
#: own looks (seeds 0-4, 5 games, 566 pairs of one cell's inks at least this alike): no pair read
#: as different marks, and their distances differ by at most 0.009, under :data:`SURE_BY`
SAME_INK = 0.7


@dataclass
class Reference:
    """One reference shape: strokes (list of (n, 2) arrays, metres, the paper's plane seen from
    above), and the same strokes densely sampled in their unit frame ((p - centre) / RMS radius)
    with a k-d tree over them, for comparing."""

    name: str
    strokes: list
    dense: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        # lazy: loads scipy, which importing this module does not
        from scipy.spatial import cKDTree

        strokes = [np.asarray(s, dtype=float)[:, :2] for s in self.strokes if len(s)]
        pts = np.vstack([_densify(s, 1e-4) for s in strokes])
        centre = pts.mean(axis=0)
        rms = float(max(np.sqrt(((pts - centre) ** 2).sum(1).mean()), 1e-6))
        self.dense = np.vstack([_densify((s - centre) / rms, _STEP) for s in strokes])
        self.tree = cKDTree(self.dense)


def _densify(points: np.ndarray, step: float) -> np.ndarray:
    """``points`` (n, 2) with points added along every leg, at most ``step`` apart."""
    points = np.asarray(points, dtype=float)
    if len(points) < 2:
        return points
    out = [points[:1]]
    for a, b in zip(points[:-1], points[1:]):
        k = max(int(math.ceil(np.linalg.norm(b - a) / step)), 1)
        out.append(a + np.linspace(0, 1, k + 1)[1:, None] * (b - a))
    return np.vstack(out)


def inked_strokes(template) -> list[np.ndarray]:
    """The strokes the pen inks when ``template`` is run (see the module docstring): a list of
    (n, 2) arrays in the paper's plane, metres; empty when it has no contact segment."""
    path = np.asarray(template.path, dtype=float)
    segments = [s for s in template.segments if s.contact] if template.segments else []
    if not segments:
        return []
    index = np.concatenate([np.arange(s.start, s.stop) for s in segments])
    if path.shape[1] == 3:
        low = float(path[index, 2].min())
        on = np.zeros(len(path), bool)
        on[index] = path[index, 2] <= low + 2 * CONTACT_TOLERANCE  # the robot presses its pen 0.5 mm in
        plane = _plane_axes(path[on])
        flat = (path - path[on].mean(axis=0)) @ plane.T
    else:
        on = np.zeros(len(path), bool)
        on[index] = True
        flat = path
    strokes, current = [], []
    for i in range(len(path)):
        if on[i]:
            current.append(flat[i])
        elif current:
            strokes.append(np.array(current))
            current = []
    if current:
        strokes.append(np.array(current))
    return [s for s in strokes if len(s) >= 2 or len(strokes) == 1]


def _plane_axes(points: np.ndarray) -> np.ndarray:
    """(2, 3): two axes of the plane the ``points`` (n, 3) lie in, right-handed about its normal
    turned up (+z): the plane seen from above, never mirrored."""
    if len(points) < 3:
        return np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    _, _, vt = np.linalg.svd(points - points.mean(axis=0))
    normal = vt[2] * (1.0 if vt[2][2] >= 0 else -1.0)
    if abs(normal[2]) > 0.9:  # a horizontal sheet: keep the world's x and y
        return np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    e1 = vt[0]
    return np.vstack([e1, np.cross(normal, e1)])


class OwnMark:
    """The robot's own mark(s): one :class:`Reference` per distinct pen-down sub-template of its
    program.  A cell's ink is the robot's when it is close to any of them."""

    def __init__(self, references: list[Reference]) -> None:
        self.references = list(references)

    @classmethod
    def from_templates(cls, templates: dict) -> OwnMark | None:
        """From ``{name: sub-template}`` (e.g. ``{"tri.draw": ...}``); None when none inks."""
        refs = []
        for name, t in templates.items():
            strokes = inked_strokes(t)
            if strokes and sum(len(s) for s in strokes) >= 3:
                refs.append(Reference(name, strokes))
        return cls(refs) if refs else None

    @property
    def names(self) -> list[str]:
        return [r.name for r in self.references]

    def distance(self, mask: np.ndarray, resolution: float) -> float:
        """The smallest distance of the ink ``mask`` (bool (h, w), a top view: column right = +x,
        row down = -y, ``resolution`` metres per pixel) from any reference."""
        ink = _Ink(mask, resolution)
        return min(ink.distance(ref) for ref in self.references) if ink.ok else 1.0

    def classify(self, mask: np.ndarray, resolution: float, own: str = "O", other: str = "X",
                 place=None) -> tuple[str, float, float]:
        """``(mark, confidence, distance)``: ``own``, ``other`` or :data:`UNCLEAR` (module
        docstring).  ``place`` (where the ink is, e.g. a cell) is for :class:`KeptReadings`."""
        d = self.distance(mask, resolution)
        if d < OWN_BELOW:
            return own, float(np.clip((OWN_BELOW - d) / SURE_BY, 0.0, 1.0)), d
        if d > OTHER_ABOVE:
            return other, float(np.clip((d - OTHER_ABOVE) / SURE_BY, 0.0, 1.0)), d
        return UNCLEAR, 0.0, d


class KeptReadings:
    """The robot's own mark (:class:`OwnMark`) with a memory of what it read where: a look at the
    board reads every cell's ink, and a mark once read is the same mark at the next look.  Per
    ``place`` it keeps the ink last compared there and that reading when it was sure (confidence
    1: its distance at least :data:`SURE_BY` beyond the threshold); ink at least
    :data:`SAME_INK` alike to it (:func:`ink_overlap`) is given that reading again instead of
    being compared anew.  Ink that differs (another mark, a part hidden by the arm, the same mark
    seen much blurred) is compared afresh; so is every unsure reading.  One per game: a new
    player, a new memory.

    Attributes
    ----------
    compared, kept : int
        How many readings were compared anew, and how many kept."""

    def __init__(self, mark: OwnMark) -> None:
        self.mark = mark
        self.compared = self.kept = 0
        self._last: dict = {}

    def classify(self, mask: np.ndarray, resolution: float, own: str = "O", other: str = "X",
                 place=None) -> tuple[str, float, float]:
        """As :meth:`OwnMark.classify`; with ``place``, a sure reading of nearly the same ink
        there is kept."""
        key = (place, float(resolution), own, other)
        last = None if place is None else self._last.get(key)
        if last is not None and ink_overlap(mask, last[0]) >= SAME_INK:
            self.kept += 1
            return last[1]
        self.compared += 1
        reading = self.mark.classify(mask, resolution, own, other)
        if place is not None:
            if reading[1] >= 1.0:
                self._last[key] = (np.array(mask, dtype=bool), reading)
            else:
                self._last.pop(key, None)
        return reading


def ink_overlap(a: np.ndarray, b: np.ndarray) -> float:
    """How alike two ink masks (bool (h, w), any sizes) are: their intersection over union with
    their centroids laid on each other (to the nearest pixel); 0 when either is empty."""
    ya, xa = np.nonzero(np.asarray(a, bool))
    yb, xb = np.nonzero(np.asarray(b, bool))
    if not len(ya) or not len(yb):
        return 0.0
    yb = yb + int(round(ya.mean() - yb.mean()))
    xb = xb + int(round(xa.mean() - xb.mean()))
    y0, x0 = min(ya.min(), yb.min()), min(xa.min(), xb.min())
    width = int(max(xa.max(), xb.max()) - x0 + 1)
    common = np.intersect1d((ya - y0) * width + (xa - x0), (yb - y0) * width + (xb - x0), assume_unique=True).size
    return common / (len(ya) + len(yb) - common)


class _Ink:
    """A cell's ink in the top view, ready to be compared (see :meth:`OwnMark.distance`).

    Points are the ink's pixels in a right-handed frame (x right, y up; a top view's row runs
    down, so y = -row), in pixels."""

    def __init__(self, mask: np.ndarray, resolution: float) -> None:
        # lazy: loads scipy, which importing this module does not
        from scipy.spatial import cKDTree

        rows, cols = np.nonzero(np.asarray(mask, bool))
        self.ok = len(rows) >= 3
        if not self.ok:
            return
        self.points = np.column_stack([cols, -rows]).astype(float)
        self.tree = cKDTree(self.points)
        self.tolerance = TOLERANCE / resolution
        self.centre = self.points.mean(axis=0)
        spread = float(((self.points - self.centre) ** 2).sum(1).mean())
        pen = PEN_WIDTH / resolution
        self.size = float(np.sqrt(max(spread, 1.0)))
        self.rms = float(np.sqrt(max(spread - pen ** 2 / 12.0, 0.25 * spread, 1.0)))  # of the strokes' middles

    def _gaps(self, ref: Reference, fits: list) -> list:
        """Per fit ``(scale, rot, shift)`` (the reference placed by ``scale`` pixels per unit,
        ``rot``, ``shift``): (distances of the reference's points from the ink, of the ink's
        points from the reference, pixels, and the nearest points both ways).  All the fits in
        one query of each k-d tree: a query's own cost is most of a small one's."""
        scales = np.array([float(f[0]) for f in fits])
        rots = np.stack([f[1] for f in fits])
        shifts = np.stack([np.asarray(f[2], float) for f in fits])
        placed = ref.dense @ rots.transpose(0, 2, 1) * scales[:, None, None] + shifts[:, None, :]
        to_ink, near_ink = self.tree.query(placed.reshape(-1, 2))
        back = (self.points - shifts[:, None, :]) @ rots / scales[:, None, None]
        to_ref, near_ref = ref.tree.query(back.reshape(-1, 2))
        n, m = len(ref.dense), len(self.points)
        return [(to_ink[i * n:(i + 1) * n], to_ref[i * m:(i + 1) * m] * scales[i],
                 near_ink[i * n:(i + 1) * n], near_ref[i * m:(i + 1) * m]) for i in range(len(fits))]

    def _cost(self, gaps) -> float:
        to_ink, to_ref = gaps[0], gaps[1]
        beyond = self.tolerance
        return float((np.maximum(to_ink - beyond, 0.0).mean() + np.maximum(to_ref - beyond, 0.0).mean())
                     / 2.0 / self.size)

    def distance(self, ref: Reference) -> float:
        full = (self.points, self.tree)
        if len(self.points) > FIT_POINTS:  # fit on an even subset of the ink; the cost on all of it
            # lazy: loads scipy, which importing this module does not
            from scipy.spatial import cKDTree

            some = self.points[:: int(np.ceil(len(self.points) / FIT_POINTS))]
            self.points, self.tree = some, cKDTree(some)
        try:
            turns = np.radians(np.arange(0.0, 360.0, TURN_STEP))
            tried = [(self.rms, np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]]), self.centre)
                     for t in turns]
            starts = [(self._cost(g),) + fit for g, fit in zip(self._gaps(ref, tried), tried)]
            starts.sort(key=lambda x: x[0])
            fits = [starts[0][1:]]
            chains = [start[1:] for start in starts[:3]]
            for _ in range(ICP_ROUNDS):  # both ways' nearest points, then the best similarity for them
                chains = [self._refit(ref, gaps) for gaps in self._gaps(ref, chains)]
            fits.extend(chains)
        finally:
            self.points, self.tree = full
        every = self._gaps(ref, fits)
        costs = [self._cost(gaps) for gaps in every]
        best = int(np.argmin(costs))
        # the best fit, finished on all the ink in two rounds (the first from its nearest points, already found)
        fit = self._refit(ref, every[best])
        fit = self._refit(ref, self._gaps(ref, [fit])[0])
        return min(costs[best], self._cost(self._gaps(ref, [fit])[0]))

    def _refit(self, ref: Reference, gaps) -> tuple:
        """The similarity that lays ``ref`` best on the ink for the nearest points ``gaps`` (both
        ways, :meth:`_gaps`): one ICP round."""
        return _similarity(np.vstack([ref.dense, ref.dense[gaps[3]]]), np.vstack([self.points[gaps[2]], self.points]))


def _similarity(source: np.ndarray, target: np.ndarray):
    """(scale, rotation (2, 2), shift (2,)) mapping ``source`` onto ``target`` (N, 2) best in the
    least-squares sense, reflections excluded (Umeyama)."""
    return fit_similarity(source, target, rank=2)


def render(strokes, resolution: float, width: float) -> np.ndarray:
    """Strokes (list of (n, 2) metres) inked into a top view (bool mask; column right = +x, row
    down = -y) at ``resolution`` metres per pixel with a pen ``width`` metres wide: the pixels
    whose centres lie within half the width of a stroke."""
    # lazy: loads scipy, which importing this module does not
    from scipy.spatial import cKDTree

    pts = np.vstack(strokes)
    lo = pts.min(axis=0) - 3 * width
    hi = pts.max(axis=0) + 3 * width
    w, h = (np.ceil((hi - lo) / resolution).astype(int) + 1)
    dense = np.vstack([_densify(np.asarray(s, float), resolution / 4) for s in strokes])
    cols, rows = np.meshgrid(np.arange(w), np.arange(h))
    centres = np.column_stack([lo[0] + cols.ravel() * resolution, hi[1] - rows.ravel() * resolution])
    near, _ = cKDTree(dense).query(centres, distance_upper_bound=width)
    return (near <= width / 2).reshape(h, w)


def cross_samples(count: int = 6, seed: int = 0) -> list[list[np.ndarray]]:
    """``count`` of the world's own crosses (:func:`.marks.cross_strokes`), half neat and half
    sloppy, in the game's cells, as strokes (n, 2) in the paper's plane, metres."""
    spec = Grid.game()
    rng = np.random.default_rng([seed, 30])
    out = []
    for k in range(count):
        strokes = cross_strokes(spec, 1 + k % 9, rng, sloppy=k % 2 == 1)
        out.append([np.asarray(s)[:, :2] for s in strokes])
    return out


def too_alike(mark: OwnMark, resolution: float = 0.001, width: float = 0.003) -> str | None:
    """Why the robot could not tell ``mark`` from the opponent's crosses, or None when it can.

    Every cross of :func:`cross_samples`, inked at ``width`` and seen at ``resolution`` (the
    board reader's top view), must lie farther than :data:`OTHER_ABOVE` + :data:`MARGIN` from
    each of the robot's references."""
    worst = None
    for strokes in cross_samples():
        ink = _Ink(render(strokes, resolution, width), resolution)
        for ref in mark.references:
            d = ink.distance(ref)
            if worst is None or d < worst[0]:
                worst = (d, ref.name)
    if worst is None or worst[0] >= OTHER_ABOVE + MARGIN:
        return None
    return (f"the robot's mark ({worst[1]}) is too like the opponent's cross to be told apart on the paper: "
            f"a cross lies {worst[0]:.2f} from it, and the robot needs more than {OTHER_ABOVE + MARGIN:.2f} "
            f"(its own marks read within {OWN_BELOW:.2f})")


_CHECKED: dict = {}


def check_mark(ref: str, template) -> str | None:
    """The world's ``mark_check`` (``hila check``): why the robot could not play ``template`` (a
    pen-down sub-template ``ref``) as its mark, or None (:func:`too_alike`).  Remembered per
    template's content, so a program checked again (an editor, at every keystroke) costs nothing."""
    key = ref, hashlib.sha1(np.ascontiguousarray(template.path, dtype=float).tobytes()
                       + repr([(s.start, s.stop, s.contact) for s in template.segments]).encode()).hexdigest()
    if key not in _CHECKED:
        mark = OwnMark.from_templates({ref: template})
        _CHECKED[key] = None if mark is None else too_alike(mark)
    return _CHECKED[key]
