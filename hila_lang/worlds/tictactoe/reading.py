"""Reading the tic-tac-toe board from one camera image: the grid's cell corners and the marks.

Method.  An image taken through a lens (``image.dist``: the robot's eyes) is undistorted first
with the camera's own calibration.  The paper lies on a plane z = ``surface_z`` (the robot
estimates it from both eyes: :mod:`.vision`).  The image is warped into a top-down view of that
plane (``RESOLUTION`` metres per pixel) through the plane-to-image homography
``K [r1 r2 z r3 + t]``, so the grid is seen without perspective, at metric scale.  Every
brightness threshold is relative to the paper's own brightness in the image, so a lighting
change moves them with it:

1. the sheet is the largest bright, unsaturated region (closed over what is drawn on it); grid
   ink is dark and neutral (the printed grid), mark ink is anything coloured or a dark stroke
   off the grid lines (circles and crosses in any colour); the green hand marker is neither;
2. the grid's orientation is the one where the grid ink projects into the sharpest peaks, the
   two strongest peaks along each axis are the lines (so a hand hiding part of a line does not
   matter); each line is refitted (total least squares on the ink pixels on it) and the four
   crossings give the grid's centre, axes and spacing;
3. cell corners follow at 0.5 and 1.5 spacings from the centre; "far" is the grid axis closest
   to world +x (the robot faces +x), "right" is far rotated by -90 degrees about z, matching
   :mod:`hila_lang.worlds.tictactoe.board` (cell 1 far-left, ``tl`` far-left corner);
4. the mark ink is cut along the grid lines into pieces, each in the cell that holds its centre;
   a cell holds a mark when its largest piece of at least :data:`MIN_MARK_AREA` reaches
   :data:`MIN_MARK_DEPTH` into the cell (what a sloppy cross spills over a line is a stub that
   hugs the line, and never joins the next cell's mark); no such piece means empty ("");
5. the mark is every piece of the cell's ink of at least :data:`MIN_MARK_AREA` that is not such
   a stub (a letter's bar, a mark's strokes that do not touch; not the specks sensor noise makes
   in dim light), compared with the robot's own mark -- the strokes its program's
   template inks (:class:`.ownmark.OwnMark`, given as ``own``) -- whatever turn, size and place
   OSILA gave it: the robot's ("O", the robot's side of the board) when close, the opponent's
   ("X") when far, unclear ("?") in between (:meth:`.ownmark.OwnMark.classify`).  Without
   ``own`` (a robot that draws nothing) every mark is the opponent's.

Each cell also gets a confidence in [0, 1] (how far its measure is from the decision's
threshold: ink amount for an empty cell, the distance from the robot's mark for a mark), the
distance itself, and may be *occluded* (more than 20 % of it neither paper nor ink, e.g. the
arm in front): the robot's looking (:mod:`.vision`) uses these to decide whether to look again.

An image where no grid can be found raises :class:`~hila_lang.core.errors.InputError` saying why.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...core.errors import InputError
from ...perception.distortion import undistorted
from ...sim.camera import intersect_plane_z, world_to_camera
from .board import cell_number

#: size of a top-down pixel, metres
RESOLUTION = 0.001
#: the smallest blob of ink that is a mark, square metres (a pen stroke 3 mm wide and 8 mm long;
#: a circle or a cross is about 300 mm2)
MIN_MARK_AREA = 25e-6
#: a mark reaches at least this far from every grid line into its cell (its convex hull: the
#: inside of a circle counts), in cell sizes.  Measured over 24 seeded games (seeds 0-5: sloppy
#: crosses, all perturbations at the battery's sizes, and harsher ones: bump 0.05, eye noise 12,
#: light 0.35), on the pieces the reader cut: the spills of sloppy crosses over a line (20-29 mm2,
#: as large as MIN_MARK_AREA in dim, noisy images) reach at most 0.19 of a cell; marks at least
#: 0.29 (one faint cross; 1 % of crosses below 0.49, circles 0.48 and more): a quarter of a cell
#: lies in that gap
MIN_MARK_DEPTH = 0.25
#: a cell is occluded when more than this fraction of it is neither paper nor ink
OCCLUDED_FRACTION = 0.2
#: the grid's whole degree is looked for on every this many of its pixels, and the best this
#: many degrees judged again on all of them (:func:`_grid_axes`)
COARSE_EVERY = 4
COARSE_KEPT = 5
_CORNER_STEPS = {"tl": (-0.5, 0.5), "tr": (0.5, 0.5), "br": (0.5, -0.5), "bl": (-0.5, -0.5)}


@dataclass
class BoardReading:
    """What one image says about the board.

    Attributes
    ----------
    corners : dict[int, dict[str, ndarray]]
        Cell (1..9) -> ``{"tl", "tr", "br", "bl"}`` -> point (3,), world frame, metres, on the
        plane z = ``surface_z``.
    marks : list[str]
        Nine entries in {"", "O", "X", "?"}, cells 1..9: empty, the robot's own mark, the
        opponent's, unclear.
    center : ndarray, shape (3,)
        The grid's centre, world, metres.
    far, right : ndarray, shape (3,)
        Unit axes of the grid (away from the robot, the robot's right), world.
    cell_size : float
        Grid spacing, metres.
    ink : list[float]
        Per cell, the inked fraction of its inner area (diagnostics).
    occluded : list[int]
        Cells more than 20 % hidden (neither paper nor ink seen there, e.g. the arm in front):
        their marks are not trustworthy; look again from another view or move the arm away.
    confidence : list[float]
        Per cell (1..9), in [0, 1]: how far its measure is from the threshold that decided its
        mark (ink amount for empty cells, the distance from the robot's own mark for marks); 0 for an
        occluded cell.
    contrast : float
        How much darker the grid lines are than the paper, as a fraction of the paper's
        brightness (about 0.6 in good light; low contrast makes every reading less sure).
    distance : list[float or None]
        Per cell, the mark's distance from the robot's own mark (:mod:`.ownmark`); None for an
        empty cell or without ``own``.
    """

    corners: dict[int, dict[str, np.ndarray]]
    marks: list[str]
    center: np.ndarray
    far: np.ndarray
    right: np.ndarray
    cell_size: float
    ink: list[float] = field(default_factory=list)
    occluded: list[int] = field(default_factory=list)
    confidence: list[float] = field(default_factory=list)
    contrast: float = 1.0
    distance: list = field(default_factory=list)


def plane_to_image_homography(K: np.ndarray, world_T_camera: np.ndarray, z: float) -> np.ndarray:
    """H (3, 3) mapping plane points (x, y, 1) on z = ``z`` (world, metres) to pixels."""
    camera_T_world = np.linalg.inv(np.asarray(world_T_camera, dtype=float))
    R, t = camera_T_world[:3, :3], camera_T_world[:3, 3]
    return np.asarray(K, dtype=float) @ np.column_stack([R[:, 0], R[:, 1], R[:, 2] * z + t])


def _planes(rgb: np.ndarray):
    """The red, green and blue planes of an RGB image and its darkest and brightest channel per
    pixel, uint8 (H, W) each (OpenCV's per-element operations: 3x numpy's on int16 copies)."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    r, g, b = cv2.split(np.ascontiguousarray(rgb))
    return r, g, b, cv2.min(cv2.min(r, g), b), cv2.max(cv2.max(r, g), b)


def _channels(rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(darkest channel, brightest channel, mean) per pixel of an RGB image, int16/float32."""
    r, g, b, lo, hi = _planes(rgb)
    return lo.astype(np.int16), hi.astype(np.int16), _total(r, g, b).astype(np.float32) / 3


def _total(r: np.ndarray, g: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The sum of three uint8 planes, uint16 (OpenCV's saturating adds never saturate here)."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    return cv2.add(cv2.add(r, g, dtype=cv2.CV_16U), b, dtype=cv2.CV_16U)


def _over(x: np.ndarray, t: float) -> np.ndarray:
    """``x > t`` for an array of integers: numpy compares them with a float in float64, this in
    the array's own type, the same answer (an integer exceeds ``t`` when it exceeds ``floor(t)``)."""
    return x > math.floor(t)


def _under(x: np.ndarray, t: float) -> np.ndarray:
    """``x < t`` for an array of integers, in its own type (see :func:`_over`)."""
    return x < math.ceil(t)


def median_level(values: np.ndarray, divisor: int = 1) -> float:
    """``np.median(values / divisor)`` of small non-negative integers (N,), bit for bit as numpy
    gives it (the middle value, or the mean of the middle two, each divided first), found by
    counting instead of sorting: a view's paper brightness over 100,000 pixels in a few tenths of
    a millisecond (sorting took 4 ms; the tracker takes one at every glance)."""
    counts = np.cumsum(np.bincount(np.asarray(values).ravel()))
    n = int(counts[-1])
    upper = int(np.searchsorted(counts, n // 2, side="right"))  # the value at sorted index n // 2
    if n % 2:
        return upper / divisor
    lower = int(np.searchsorted(counts, n // 2 - 1, side="right"))
    return (lower / divisor + upper / divisor) / 2


def sheet_level(top: np.ndarray, sheet: np.ndarray) -> float:
    """The paper's brightness in a rectified view: the median over ``sheet``'s pixels (bool
    (h, w)) of their mean channel, ``np.median(top[sheet].mean(axis=1))`` exactly."""
    r, g, b, _, _ = _planes(top)  # the channels' sum in 16 bits: 3x numpy's sum(axis=2)
    return median_level(_total(r, g, b)[sheet], 3)


def _paper_mask(rgb: np.ndarray, level: float | None = None) -> np.ndarray:
    """Bright, unsaturated pixels (the paper), bool (H, W).

    "Bright" is relative to ``level``, the paper's brightness if known, else the brightest
    neutral things in view (their 95th percentile): in good light, darkest channel above 150 and
    spread below 40 (of 255), as measured on the game's sheet; both scale with the light.
    """
    # lazy: loads cv2, which importing this module does not
    import cv2

    _, _, _, lo, hi = _planes(rgb)
    spread = cv2.subtract(hi, lo)
    if level is None:
        neutral = spread < np.maximum(25, hi // 5)
        level = float(np.percentile(hi[neutral].astype(np.int16), 95)) if neutral.any() else 255.0
    level = max(float(level), 20.0)
    return _over(lo, 0.62 * level) & _under(spread, 0.16 * level + 2)


def _ink_masks(rgb: np.ndarray, paper_level: float, resolution: float) -> tuple[np.ndarray, np.ndarray]:
    """(grid ink, mark ink), bool (H, W).

    Strokes are thin: a pixel is a dark stroke when it is darker than its neighbourhood's
    closing (a black-hat over ~9 mm) by a quarter of the paper's brightness, which ignores large
    dark areas (table, a shaded arm).  Grid lines are printed in neutral grey (dark, unsaturated
    strokes); marks may be in any ink (dark strokes, or coloured pixels: a spread between the
    channels of more than 0.3 of the paper's brightness).  The green hand marker is neither.
    """
    # lazy: loads cv2, which importing this module does not
    import cv2

    r, g, b, lo, hi = _planes(rgb)
    gray = _total(r, g, b).astype(np.float32) / 3
    k = _stroke_kernel(resolution)
    blackhat = cv2.morphologyEx(gray, cv2.MORPH_BLACKHAT, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)))
    stroke = blackhat > 0.25 * paper_level
    sat = cv2.subtract(hi, lo)
    green = cv2.subtract(g, cv2.max(r, b), dtype=cv2.CV_16S)
    not_marker = _under(green, max(12.0, 0.06 * paper_level))
    return stroke & _under(sat, 0.22 * paper_level) & not_marker, (stroke | _over(sat, 0.3 * paper_level)) & not_marker


def own_body_mask(image, body, shape=None) -> np.ndarray:
    """Pixels (bool, ``shape`` = (H, W), default the image's) of a pinhole ``image`` covered by
    the camera's own robot: ``body`` is a list of capsules ``(points (2, 3), radius)``, world
    frame, metres (:meth:`hila_lang.robot.eyes.Eyes.body_outline`)."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    h, w = shape or np.asarray(image.rgb).shape[:2]
    mask = np.zeros((h, w), np.uint8)
    K, T = np.asarray(image.K, float), np.asarray(image.world_T_camera, float)
    for ends, radius in body or ():
        a, b = np.asarray(ends, float)
        n = max(2, int(np.ceil(np.linalg.norm(b - a) / (radius / 2))) + 1)
        pts = world_to_camera(a + np.linspace(0, 1, n)[:, None] * (b - a), T)
        for x, y, z in pts:
            if z > 0.01:
                u, v = K[0, 0] * x / z + K[0, 2], K[1, 1] * y / z + K[1, 2]
                r = K[0, 0] * radius / z
                if -r < u < w + r and -r < v < h + r:
                    cv2.circle(mask, (int(round(u * 4)), int(round(v * 4))), int(round(r * 4)), 1, -1, cv2.LINE_8, 2)
    return mask.astype(bool)


def rectify(image, surface_z: float, resolution: float = RESOLUTION, max_extent: float = 0.8, body=None):
    """Top-down view of the sheet on the plane z = ``surface_z`` (``image`` undistorted first).

    Returns
    -------
    top : ndarray (h, w, 3) uint8
        Row i, column j shows the plane point ``origin + (j * res, -i * res)`` (x right, y up).
    origin : ndarray, shape (2,)
        World (x, y) of pixel (0, 0), metres.
    sheet : ndarray (h, w) bool
        Paper-like regions in the top view, closed over what is drawn on them (holes up to
        ~9 mm); a white hand may be among them: :func:`read_board` keeps the region holding
        the most grid ink.
    own : ndarray (h, w) bool
        What the camera's own robot hides in the top view (``body``, see :func:`own_body_mask`).
    """
    # lazy: loads cv2, which importing this module does not
    import cv2

    image = undistorted(image)
    rgb = np.ascontiguousarray(np.asarray(image.rgb)[:, :, :3])
    K, T = np.asarray(image.K, float), np.asarray(image.world_T_camera, float)
    mask = _paper_mask(rgb).astype(np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    if n <= 1 or stats[1:, cv2.CC_STAT_AREA].max() < 200:
        raise InputError("no sheet of paper found in the image (no large bright region)",
                         hint="is the board in the camera's view?")
    best = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    ys, xs = np.nonzero(labels == best)
    step = max(1, len(xs) // 4000)
    uv = np.column_stack([xs[::step], ys[::step]]).astype(float)
    ground = intersect_plane_z(uv, K, T, surface_z)
    below = (ground - T[:3, 3]) @ T[:3, 2] > 0  # in front of the camera
    ground = ground[below, :2]
    if len(ground) == 0:
        raise InputError(f"the paper seen does not lie on the plane z = {surface_z}: is surface_z right?")
    med = np.median(ground, axis=0)
    lo = np.maximum(ground.min(axis=0), med - max_extent / 2) - 0.01
    hi = np.minimum(ground.max(axis=0), med + max_extent / 2) + 0.01
    top, H = _warp_top(rgb, K, T, surface_z, lo, hi, resolution)
    h, w = top.shape[:2]
    level = median_level(_planes(rgb)[4][ys, xs])  # np.median(rgb[labels == best].max(axis=1)), by counting
    own = np.zeros((h, w), bool)
    if body:
        own = cv2.warpPerspective(own_body_mask(image, body).astype(np.uint8), H, (w, h),
                                  flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP).astype(bool)
    sheet = _closed(_paper_mask(top, level) & ~own, resolution)
    return top, np.array([lo[0], hi[1]]), sheet, own


def _warp_top(rgb: np.ndarray, K: np.ndarray, T: np.ndarray, surface_z: float, lo, hi, resolution: float):
    """The top view (h, w, 3) of the plane z = ``surface_z`` from ``lo`` to ``hi`` (world x, y,
    metres; row 0 at ``hi``'s y, column 0 at ``lo``'s x) in the pinhole image ``rgb`` (K, pose
    ``T``), and the homography (3, 3) from its pixels to the image's."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    w, h = int(np.ceil((hi[0] - lo[0]) / resolution)), int(np.ceil((hi[1] - lo[1]) / resolution))
    top_to_plane = np.array([[resolution, 0, lo[0]], [0, -resolution, hi[1]], [0, 0, 1]])
    H = plane_to_image_homography(K, T, surface_z) @ top_to_plane
    top = cv2.warpPerspective(rgb, H, (w, h), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                              borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0))
    return top, H


def rectify_square(image, surface_z: float, square: np.ndarray, resolution: float = RESOLUTION):
    """Top-down view of the part ``square`` (corners (n, 2+), world x, y, metres) of the plane
    z = ``surface_z`` (``image`` undistorted first): what :func:`rectify` gives when where to look
    is known -- no search for the sheet in the image.  The view spans the corners' bounding box
    on a lattice of ``resolution`` fixed to the world (its origin a multiple of it).

    Returns ``(top, origin, sheet)`` as :func:`rectify`'s first three; ``sheet`` (the paper,
    closed over what is drawn on it) is judged by the view's own brightest neutral pixels."""
    image = undistorted(image)
    rgb = np.ascontiguousarray(np.asarray(image.rgb)[:, :, :3])
    xy = np.asarray(square, dtype=float)[:, :2]
    lo = np.floor(xy.min(axis=0) / resolution) * resolution
    hi = np.ceil(xy.max(axis=0) / resolution) * resolution
    top, _ = _warp_top(rgb, np.asarray(image.K, float), np.asarray(image.world_T_camera, float),
                       float(surface_z), lo, hi, resolution)
    return top, np.array([lo[0], hi[1]]), _closed(_paper_mask(top), resolution)


def _stroke_kernel(resolution: float) -> int:
    """The side (pixels, odd, at least 3) of the ~9 mm neighbourhood that tells a stroke from
    its paper: the ink masks' black-hat, and the sheet closed over what is drawn on it."""
    return max(3, int(round(0.009 / resolution)) | 1)


def _closed(paper: np.ndarray, resolution: float) -> np.ndarray:
    """The paper (bool (h, w)) closed over what is drawn on it (holes up to ~9 mm), bool."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    k = _stroke_kernel(resolution)
    return cv2.morphologyEx(paper.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((k, k), np.uint8)).astype(bool)


def _fill_holes(mask: np.ndarray) -> np.ndarray:
    """``mask`` (bool) with every region it encloses (not connected to the image's border) filled."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    outside = np.pad(~mask, 1, constant_values=True).astype(np.uint8)
    cv2.floodFill(outside, None, (0, 0), 2)
    return (outside[1:-1, 1:-1] != 2)


def _grid_axes(pts: np.ndarray, min_sep: float = 10.0) -> tuple[np.ndarray, np.ndarray, tuple, tuple]:
    """Orientation and line positions of a "#" shape from its pixels (N, 2).

    The grid's lines project onto their normal as two sharp peaks: the orientation maximising
    the peakedness (sum of squared histogram counts) of both projections wins (coarse 1 degree,
    then 0.05 degree).  The second line is the strongest peak at least ``min_sep`` pixels from
    the first.  Returns the two unit normals and, along each, the two line positions.
    """
    c = pts.mean(axis=0)
    q = pts - c

    def scores(alphas, points=q):
        """Peakedness of both projections of ``points``, for every angle at once (in place: no
        temporaries of (P, A); the squared counts summed as integers, which float64 held exactly too)."""
        total = np.zeros(len(alphas))
        for shift in (0.0, np.pi / 2):
            proj = points @ np.array([np.cos(alphas + shift), np.sin(alphas + shift)])  # (P, A)
            proj -= proj.min(axis=0)
            bins = np.rint(proj, out=proj).astype(np.int64)  # np.round's own rounding (half to even)
            width = int(bins.max()) + 1
            bins += width * np.arange(len(alphas))
            counts = np.bincount(bins.ravel(), minlength=width * len(alphas)).reshape(len(alphas), width)
            total += (counts * counts).sum(axis=1)
        return total

    coarse = np.radians(np.arange(0.0, 90.0, 1.0))
    # the whole degree on every 4th pixel first, then its best few on all of them: the same degree
    # as all the pixels at every one (on 184 looks of games seeds 0-3, still and moving, it was the
    # subsample's first or second), at a third of the time
    few = np.sort(np.argsort(-scores(coarse, q[::COARSE_EVERY]), kind="stable")[:COARSE_KEPT])
    a0 = coarse[few[int(np.argmax(scores(coarse[few])))]]
    fine = a0 + np.radians(np.arange(-1.0, 1.0001, 0.05))
    alpha = fine[int(np.argmax(scores(fine)))]
    n1 = np.array([np.cos(alpha), np.sin(alpha)])
    n2 = np.array([-n1[1], n1[0]])
    positions = []
    for n in (n1, n2):
        proj = q @ n
        lo = proj.min()
        h = np.bincount(np.round(proj - lo).astype(int)).astype(float)
        h = np.convolve(h, np.ones(3), mode="same")
        i1 = int(np.argmax(h))
        h2 = h.copy()
        sep = max(3, int(min_sep))
        h2[max(0, i1 - sep): i1 + sep + 1] = 0
        i2 = int(np.argmax(h2))
        positions.append(tuple(sorted((i1 + lo + float(c @ n), i2 + lo + float(c @ n)))))
    return n1, n2, positions[0], positions[1]


def _fit_line(points: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted total least squares line: (point (2,), unit direction (2,))."""
    c = (points * weights[:, None]).sum(0) / weights.sum()
    d = points - c
    cov = (d * weights[:, None]).T @ d
    vals, vecs = np.linalg.eigh(cov)
    return c, vecs[:, 1]


def _intersect(l1, l2) -> np.ndarray:
    (p, d), (q, e) = l1, l2
    A = np.column_stack([d, -e])
    s = np.linalg.solve(A, q - p)
    return p + s[0] * d


def read_board(image, surface_z: float, *, resolution: float = RESOLUTION, min_cell: float = 0.02,
               max_cell: float = 0.15, body=None, own=None) -> BoardReading:
    """Find the grid and the marks in one camera image.

    Parameters
    ----------
    image : CameraImage
        Anything with ``rgb`` (H, W, 3) uint8, ``K`` (3, 3), ``world_T_camera`` (4, 4) and
        ``dist`` (the lens, or None for a pinhole image).
    surface_z : float
        World z of the paper, metres.
    resolution : float
        Top-down pixel size, metres.
    min_cell, max_cell : float
        Plausible grid spacing, metres.
    body : list of (ndarray (2, 3), float), optional
        The camera's own robot as capsules (points, radius), world frame, metres: what they
        cover is hidden, neither paper nor ink (:meth:`hila_lang.robot.eyes.Eyes.body_outline`).
    own : OwnMark, optional
        The robot's own mark (:class:`.ownmark.OwnMark`, or :class:`.ownmark.KeptReadings`,
        which keeps a cell's sure reading from one read to the next while its ink stays the
        same); None: every mark is the opponent's.

    Returns
    -------
    BoardReading

    Raises
    ------
    InputError
        No sheet, no grid, or a grid of implausible size in the image.
    """
    # lazy: loads cv2, which importing this module does not
    import cv2

    top, origin, regions, hidden = rectify(image, float(surface_z), resolution, body=body)
    paper_level = sheet_level(top, regions) if regions.any() else 240.0  # np.median(top[regions].mean(axis=1)), by counting
    grid_ink, ink = _ink_masks(top, paper_level, resolution)
    n, labels = cv2.connectedComponents(regions.astype(np.uint8), connectivity=8)
    counts = np.bincount(labels[grid_ink & regions], minlength=n)
    counts[0] = 0
    sheet = _fill_holes(labels == int(np.argmax(counts)))  # marks of any size are on the sheet
    grid_ink &= sheet & ~hidden
    ink &= sheet & ~hidden
    ys, xs = np.nonzero(grid_ink)
    if len(xs) < 50:
        raise InputError("no grid found on the sheet: no dark grid lines seen",
                         hint="is the grid drawn and in view, not hidden by the arm?")
    pts = np.column_stack([xs, ys]).astype(float)
    ax1, ax2, pos1, pos2 = _grid_axes(pts, 0.6 * min_cell / resolution)
    spacing = (abs(pos1[1] - pos1[0]) + abs(pos2[1] - pos2[0])) / 2
    if not (min_cell / resolution <= spacing <= max_cell / resolution) or \
            abs(abs(pos1[1] - pos1[0]) - abs(pos2[1] - pos2[0])) > 0.25 * spacing:
        raise InputError(f"no grid found on the sheet: the strongest dark lines have spacings "
                         f"{abs(pos1[1] - pos1[0]) * resolution * 1000:.0f} and "
                         f"{abs(pos2[1] - pos2[0]) * resolution * 1000:.0f} mm, expected a square grid with "
                         f"cells of {min_cell * 1000:.0f}-{max_cell * 1000:.0f} mm")
    centre = ax1 * np.mean(pos1) + ax2 * np.mean(pos2)
    # refit the four lines from the ink pixels near each nominal line
    ys_i, xs_i = np.nonzero(grid_ink)
    ink_pts = np.column_stack([xs_i, ys_i]).astype(float)
    lines = {}
    for name, normal, along in (("a", ax1, ax2), ("b", ax2, ax1)):
        for k in (-0.5, 0.5):
            off = (ink_pts - centre) @ normal - k * spacing
            alo = (ink_pts - centre) @ along
            sel = (np.abs(off) < 0.12 * spacing) & (np.abs(alo) < 1.4 * spacing)
            if sel.sum() < 10:
                raise InputError("no grid found on the sheet: a grid line is missing or hidden")
            p, d = _fit_line(ink_pts[sel], np.ones(int(sel.sum())))
            # second pass: only the pixels on the line itself, so marks near it do not pull it
            nrm = np.array([-d[1], d[0]])
            sel = (np.abs((ink_pts - p) @ nrm) < max(2.5, 0.004 / resolution)) & (np.abs(alo) < 1.4 * spacing)
            lines[(name, k)] = _fit_line(ink_pts[sel], np.ones(int(sel.sum()))) if sel.sum() >= 10 else (p, d)
    cross = np.array([_intersect(lines[("a", i)], lines[("b", j)]) for i in (-0.5, 0.5) for j in (-0.5, 0.5)])
    centre = cross.mean(axis=0)
    # spacing and axes from the crossings: (a-, b-), (a-, b+), (a+, b-), (a+, b+)
    d1 = ((cross[2] - cross[0]) + (cross[3] - cross[1])) / 2   # along ax1 (line family a offsets)
    d2 = ((cross[1] - cross[0]) + (cross[3] - cross[2])) / 2   # along ax2
    # to world (x, y): top pixel (j, i) -> (x0 + j res, y1 - i res)
    def to_world_vec(v):
        return np.array([v[0] * resolution, -v[1] * resolution])

    w1, w2 = to_world_vec(d1), to_world_vec(d2)
    centre_w = origin + to_world_vec(centre)
    # "far" = the grid axis (either sign) closest to world +x
    cands = [w1, -w1, w2, -w2]
    far_vec = max(cands, key=lambda v: v[0] / np.linalg.norm(v))
    right_vec = next((v for v in cands if abs(np.dot(v, far_vec)) < 0.5 * np.dot(far_vec, far_vec)
                      and (far_vec[0] * v[1] - far_vec[1] * v[0]) < 0), None)
    if right_vec is None:
        raise InputError("no grid found on the sheet: its lines are far from perpendicular")
    cell = float((np.linalg.norm(w1) + np.linalg.norm(w2)) / 2)
    if not (min_cell <= cell <= max_cell):
        raise InputError(f"grid found but its cells are {cell * 1000:.0f} mm, expected "
                         f"{min_cell * 1000:.0f}-{max_cell * 1000:.0f} mm")
    far_u = np.append(far_vec / np.linalg.norm(far_vec), 0.0)
    right_u = np.append(right_vec / np.linalg.norm(right_vec), 0.0)
    c3 = np.array([centre_w[0], centre_w[1], surface_z])
    corners: dict[int, dict[str, np.ndarray]] = {}
    for idx in range(9):
        row, col = divmod(idx, 3)
        cc = c3 + (col - 1) * _vec3(right_vec) + (1 - row) * _vec3(far_vec)
        corners[idx + 1] = {name: cc + dr * _vec3(right_vec) + df * _vec3(far_vec)
                            for name, (dr, df) in _CORNER_STEPS.items()}
    frame = (origin, resolution, c3, right_u, far_u, cell)
    box = _box(frame, ink | grid_ink)  # all that is read from here on lies in it
    lo, hi, gray = _channels(top[box])
    paperlike = (np.abs(gray - paper_level) < 0.175 * paper_level) & ((hi - lo) < 0.2 * paper_level)
    seen = (paperlike | ink[box] | grid_ink[box]) & ~hidden[box]
    contrast = float((paper_level - np.median(gray[grid_ink[box]])) / paper_level) if grid_ink.sum() > 20 else 0.0
    marks, fractions, occluded, confidence, distance = _read_marks(ink & ~grid_ink, seen, frame, lines, own, box)
    return BoardReading(corners, marks, c3, far_u, right_u, cell, fractions, occluded, confidence, contrast,
                        distance)


def _vec3(v2: np.ndarray) -> np.ndarray:
    """A plane vector (2,) as a world vector (3,) with z = 0."""
    return np.array([v2[0], v2[1], 0.0])


def _box(frame, ink: np.ndarray) -> tuple[slice, slice]:
    """The part of the top view (rows, columns) that holds the grid's cells and every pixel of
    ``ink`` (bool (h, w)): what the marks are read from.  The top view spans all the bright
    region the camera saw, often twice the grid; the pixels outside this box hold neither a
    cell nor ink, so every per-pixel measure of :func:`_read_marks` is the same without them."""
    origin, res, centre, right, far, cell = frame
    h, w = ink.shape
    # the grid's outer corners (u, v in {0, 3}, see _read_marks) in top-view pixels, grown by 2 px
    # (the corners are solved for here, the cells tested pixel by pixel there: rounding differs)
    M = np.array([[right[0], right[1]], [far[0], far[1]]])
    corners = np.array([[(u - 1.5) * cell, (1.5 - v) * cell] for u in (0, 3) for v in (0, 3)])
    wxy = np.linalg.solve(M, corners.T).T  # (4, 2): the world offsets from the grid's centre
    cols = (wxy[:, 0] + centre[0] - origin[0]) / res
    rows = (origin[1] - centre[1] - wxy[:, 1]) / res
    r0, r1 = math.floor(rows.min()) - 2, math.ceil(rows.max()) + 3
    c0, c1 = math.floor(cols.min()) - 2, math.ceil(cols.max()) + 3
    inked_rows, inked_cols = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
    if len(inked_rows):
        r0, r1 = min(r0, inked_rows[0]), max(r1, inked_rows[-1] + 1)
        c0, c1 = min(c0, inked_cols[0]), max(c1, inked_cols[-1] + 1)
    return slice(max(int(r0), 0), min(int(r1), h)), slice(max(int(c0), 0), min(int(c1), w))


def _depth(k: int, labels: np.ndarray, stats: np.ndarray, near: np.ndarray, at=(0, 0)) -> float:
    """How far piece ``k`` reaches from the grid lines (``near``: each pixel's distance from the
    nearest line, its pixel (0, 0) at ``labels``' pixel ``at`` (row, column)), its convex hull
    included, so the inside of a circle counts."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    x0, y0, bw, bh = stats[k, :4]
    piece = (labels[y0:y0 + bh, x0:x0 + bw] == k).astype(np.uint8)
    cv2.fillConvexPoly(piece, cv2.convexHull(cv2.findNonZero(piece)), 1)
    y0, x0 = y0 - at[0], x0 - at[1]
    return float(near[y0:y0 + bh, x0:x0 + bw][piece.astype(bool)].max())


def _read_marks(mark, seen, frame, lines, own=None, box=None):
    """Each cell's mark ("", "O", "X" or "?"), inked fraction, whether it is occluded, confidence
    and distance from the robot's own mark.

    ``mark`` is the ink that may be a mark (not the grid's own ink), ``seen`` what is paper or
    ink (top view, bool); ``frame`` = (origin (2,), resolution, centre (3,), right (3,), far (3,),
    cell size); ``lines`` the grid lines (point, direction) in top-view pixels.  A cell's mark is
    its largest piece of ink (the ink cut along the grid lines) whose centre is in the cell;
    what the mark is, all its pieces that are not spills over a line, compared with ``own``.
    With ``box`` (rows, columns: :func:`_box`) ``seen`` is that part of the top view only, and
    the per-pixel measures are taken there.
    """
    # lazy: loads cv2, which importing this module does not
    import cv2

    origin, res, centre, right, far, cell = frame
    rows, cols = box or (slice(0, mark.shape[0]), slice(0, mark.shape[1]))
    xs = np.arange(cols.start, cols.stop, dtype=float)[None, :]  # the top view's own pixel numbers
    ys = np.arange(rows.start, rows.stop, dtype=float)[:, None]
    wx, wy = origin[0] + xs * res - centre[0], origin[1] - ys * res - centre[1]
    u = (wx * right[0] + wy * right[1]) / cell + 1.5   # column coordinate, 0..3 over the grid
    v = 1.5 - (wx * far[0] + wy * far[1]) / cell       # row coordinate, 0..3 over the grid
    cell_of = cell_number(u, v)
    in_grid = cell_of > 0
    inner = in_grid & ((u - np.floor(u) - 0.5) ** 2 + (v - np.floor(v) - 0.5) ** 2 < 0.46 ** 2)
    area = np.maximum(np.bincount(cell_of[inner], minlength=10), 1)
    hidden = np.bincount(cell_of[inner & ~seen], minlength=10) / area
    inked = np.bincount(cell_of[inner & mark[rows, cols]], minlength=10)  # diagnostics
    # cut the ink along the grid's lines, so a mark over a line (a sloppy cross) and a mark in the
    # next cell that it touches stay apart; what spills over a line is a stub that hugs the line
    near = np.full(cell_of.shape, np.inf)  # distance from the nearest grid line, pixels
    for (p, d) in lines.values():
        n = np.array([-d[1], d[0]])
        near = np.minimum(near, np.abs((xs - p[0]) * n[0] + (ys - p[1]) * n[1]))
    band = near < max(0.002 / res, 1.5)
    cut = np.zeros(mark.shape, np.uint8)  # the pieces are found in the whole view: labels as ever
    cut[rows, cols] = mark[rows, cols] & ~band
    count, labels, stats, cents = cv2.connectedComponentsWithStats(cut, connectivity=8)
    h, w = mark.shape
    at = (rows.start, cols.start)
    min_area, min_depth = MIN_MARK_AREA / res ** 2, MIN_MARK_DEPTH * cell / res
    biggest = np.zeros(10, dtype=int)  # cell -> its largest piece of ink that may be a mark (0: none)
    pieces: dict[int, list[int]] = {}  # cell -> the pieces of its mark (not spills, not specks)
    for k in range(1, count):
        cx, cy = (int(round(c)) for c in cents[k])
        home = cell_of[min(max(cy, 0), h - 1) - at[0], min(max(cx, 0), w - 1) - at[1]]
        if not home:
            continue
        size = stats[k, cv2.CC_STAT_AREA]
        if size >= min_area and _depth(k, labels, stats, near, at) < min_depth:
            continue  # a spill over a line from the next cell
        if size >= min_area:  # a piece of the mark; smaller specks (sensor noise in dim light) are not
            pieces.setdefault(int(home), []).append(k)
        if not biggest[home] or size > stats[biggest[home], cv2.CC_STAT_AREA]:
            biggest[home] = k
    marks, fractions, occluded, confidence, distances = [], [], [], [], []
    for cellno in range(1, 10):
        fractions.append(float(inked[cellno] / area[cellno]))
        if hidden[cellno] > OCCLUDED_FRACTION:
            occluded.append(cellno)
        largest = stats[biggest[cellno], cv2.CC_STAT_AREA] if biggest[cellno] else 0
        distance = None
        if largest < min_area:  # sure it is empty while its largest piece is under 3/4 of a mark's size
            marks.append("")
            conf = float(np.clip(2.0 * (1.0 - largest / min_area), 0.0, 1.0))
        elif own is None:  # a robot that draws nothing: any mark is the opponent's
            marks.append("X")
            conf = 1.0
        else:
            ks = pieces.get(cellno) or [biggest[cellno]]
            x0, y0 = stats[ks, 0].min(), stats[ks, 1].min()
            x1, y1 = (stats[ks, 0] + stats[ks, 2]).max(), (stats[ks, 1] + stats[ks, 3]).max()
            ink = np.isin(labels[y0:y1, x0:x1], ks)
            seen_as, conf, distance = own.classify(ink, res, place=cellno)
            marks.append(seen_as)
        distances.append(distance)
        h_frac = float(hidden[cellno])
        confidence.append(0.0 if h_frac > OCCLUDED_FRACTION else conf * (1.0 - h_frac / OCCLUDED_FRACTION / 2))
    return marks, fractions, occluded, confidence, distances
