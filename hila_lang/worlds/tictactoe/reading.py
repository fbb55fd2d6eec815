"""Reading the tic-tac-toe board from one camera image: the grid's cell corners and the marks.

Method.  The paper lies on a known plane z = ``surface_z``.  The image is warped into a
top-down view of that plane (``RESOLUTION`` metres per pixel) through the plane-to-image
homography ``K [r1 r2 z r3 + t]``, so the grid is seen without perspective, at metric scale:

1. the sheet is the largest bright, unsaturated region (closed over what is drawn on it); grid
   ink is dark and neutral (the printed grid), mark ink is anything clearly darker or more
   saturated than paper (circles and crosses in any colour); the green hand marker is neither;
2. the grid's orientation is the one where the grid ink projects into the sharpest peaks, the
   two strongest peaks along each axis are the lines (so a hand hiding part of a line does not
   matter); each line is refitted (total least squares on the ink pixels on it) and the four
   crossings give the grid's centre, axes and spacing;
3. cell corners follow at 0.5 and 1.5 spacings from the centre; "far" is the grid axis closest
   to world +x (the robot faces +x), "right" is far rotated by -90 degrees about z, matching
   :mod:`hila_lang.worlds.tictactoe.board` (cell 1 far-left, ``tl`` far-left corner);
4. each cell's ink, away from the grid lines, is a circle ("O") when it rings an empty middle
   and a cross ("X") when it crosses it; little ink means empty ("").

An image where no grid can be found raises :class:`~hila_lang.errors.InputError` saying why.
The image must be undistorted (a pinhole ``K``); use
:func:`hila_lang.perception.distortion.undistort_image` first for a distorted camera.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...errors import InputError

#: size of a top-down pixel, metres
RESOLUTION = 0.001
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
        Nine entries in {"", "O", "X"}, cells 1..9.
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
    """

    corners: dict[int, dict[str, np.ndarray]]
    marks: list[str]
    center: np.ndarray
    far: np.ndarray
    right: np.ndarray
    cell_size: float
    ink: list[float] = field(default_factory=list)
    occluded: list[int] = field(default_factory=list)


def plane_to_image_homography(K: np.ndarray, world_T_camera: np.ndarray, z: float) -> np.ndarray:
    """H (3, 3) mapping plane points (x, y, 1) on z = ``z`` (world, metres) to pixels."""
    camera_T_world = np.linalg.inv(np.asarray(world_T_camera, dtype=float))
    R, t = camera_T_world[:3, :3], camera_T_world[:3, 3]
    return np.asarray(K, dtype=float) @ np.column_stack([R[:, 0], R[:, 1], R[:, 2] * z + t])


def _paper_mask(rgb: np.ndarray) -> np.ndarray:
    """Bright, unsaturated pixels (the paper), bool (H, W)."""
    f = rgb.astype(np.int16)
    return (f.min(axis=2) > 150) & ((f.max(axis=2) - f.min(axis=2)) < 40)


def _ink_masks(rgb: np.ndarray, paper_level: float, resolution: float) -> tuple[np.ndarray, np.ndarray]:
    """(grid ink, any ink), bool (H, W).

    Strokes are thin: a pixel is a dark stroke when it is darker than its neighbourhood's
    closing (a black-hat over ~9 mm) by a quarter of the paper's brightness, which ignores large
    dark areas (table, a shaded arm).  Grid lines are printed in neutral grey (dark, unsaturated
    strokes); marks may be in any ink (dark strokes, or saturated pixels).  The green hand
    marker is neither.
    """
    import cv2

    f = rgb.astype(np.int16)
    gray = rgb.mean(axis=2).astype(np.float32)
    k = max(3, int(round(0.009 / resolution)) | 1)
    blackhat = cv2.morphologyEx(gray, cv2.MORPH_BLACKHAT, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)))
    stroke = blackhat > 0.25 * paper_level
    sat = f.max(axis=2) - f.min(axis=2)
    green = f[:, :, 1] - np.maximum(f[:, :, 0], f[:, :, 2])
    not_marker = green < 12
    return stroke & (sat < 45) & not_marker, (stroke | (sat > 60)) & not_marker


def rectify(image, surface_z: float, resolution: float = RESOLUTION, max_extent: float = 0.8):
    """Top-down view of the sheet on the plane z = ``surface_z``.

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
    """
    import cv2

    from ...sim.camera import intersect_plane_z

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
    w, h = int(np.ceil((hi[0] - lo[0]) / resolution)), int(np.ceil((hi[1] - lo[1]) / resolution))
    top_to_plane = np.array([[resolution, 0, lo[0]], [0, -resolution, hi[1]], [0, 0, 1]])
    H = plane_to_image_homography(K, T, surface_z) @ top_to_plane
    top = cv2.warpPerspective(rgb, H, (w, h), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                              borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0))
    paper = _paper_mask(top).astype(np.uint8)
    k = max(3, int(round(0.009 / resolution)) | 1)
    sheet = cv2.morphologyEx(paper, cv2.MORPH_CLOSE, np.ones((k, k), np.uint8))
    return top, np.array([lo[0], hi[1]]), sheet.astype(bool)


def _grid_axes(pts: np.ndarray, min_sep: float = 10.0) -> tuple[np.ndarray, np.ndarray, tuple, tuple]:
    """Orientation and line positions of a "#" shape from its pixels (N, 2).

    The grid's lines project onto their normal as two sharp peaks: the orientation maximising
    the peakedness (sum of squared histogram counts) of both projections wins (coarse 1 degree,
    then 0.05 degree).  The second line is the strongest peak at least ``min_sep`` pixels from
    the first.  Returns the two unit normals and, along each, the two line positions.
    """
    c = pts.mean(axis=0)
    q = pts - c

    def score(alpha):
        n1 = np.array([np.cos(alpha), np.sin(alpha)])
        n2 = np.array([-n1[1], n1[0]])
        tot = 0.0
        for n in (n1, n2):
            proj = q @ n
            h = np.bincount(np.round(proj - proj.min()).astype(int))
            tot += float((h.astype(float) ** 2).sum())
        return tot

    coarse = np.radians(np.arange(0.0, 90.0, 1.0))
    a0 = coarse[int(np.argmax([score(a) for a in coarse]))]
    fine = a0 + np.radians(np.arange(-1.0, 1.0001, 0.05))
    alpha = fine[int(np.argmax([score(a) for a in fine]))]
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
               max_cell: float = 0.15) -> BoardReading:
    """Find the grid and the marks in one (undistorted) camera image.

    Parameters
    ----------
    image : CameraImage
        Anything with ``rgb`` (H, W, 3) uint8, ``K`` (3, 3) and ``world_T_camera`` (4, 4).
    surface_z : float
        World z of the paper, metres.
    resolution : float
        Top-down pixel size, metres.
    min_cell, max_cell : float
        Plausible grid spacing, metres.

    Returns
    -------
    BoardReading

    Raises
    ------
    InputError
        No sheet, no grid, or a grid of implausible size in the image.
    """
    import cv2

    top, origin, regions = rectify(image, float(surface_z), resolution)
    paper_level = float(np.median(top[regions].mean(axis=1))) if regions.any() else 240.0
    grid_ink, ink = _ink_masks(top, paper_level, resolution)
    n, labels = cv2.connectedComponents(regions.astype(np.uint8), connectivity=8)
    counts = np.bincount(labels[grid_ink & regions], minlength=n)
    counts[0] = 0
    sheet = labels == int(np.argmax(counts))
    grid_ink &= sheet
    ink &= sheet
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
    f = top.astype(np.int16)
    seen = (np.abs(f.mean(axis=2) - paper_level) < 35) & ((f.max(axis=2) - f.min(axis=2)) < 40) | ink
    marks, fractions, occluded = _read_marks(ink, seen, corners, origin, resolution, lines, cell)
    return BoardReading(corners, marks, c3, far_u, right_u, cell, fractions, occluded)


def _vec3(v2: np.ndarray) -> np.ndarray:
    """A plane vector (2,) as a world vector (3,) with z = 0."""
    return np.array([v2[0], v2[1], 0.0])


def _read_marks(ink, seen, corners, origin, res, lines, cell) -> tuple[list[str], list[float], list[int]]:
    """Classify each cell's ink (away from the grid lines) as "", "O" or "X".

    Also returns the cells more than 20 % of whose inner area is neither paper nor ink (hidden,
    e.g. by the arm).
    """
    h, w = ink.shape
    ys, xs = np.mgrid[0:h, 0:w]
    pix = np.stack([xs, ys], axis=-1).astype(float)
    near_line = np.zeros_like(ink)
    band = max(0.004 / res, 2.0)
    for (p, d) in lines.values():
        n = np.array([-d[1], d[0]])
        near_line |= np.abs((pix - p) @ n) < band
    marks, fractions, occluded = [], [], []
    for cellno in range(1, 10):
        c = corners[cellno]
        centre_w = np.mean([c[k][:2] for k in c], axis=0)
        centre_px = (centre_w - origin) / [res, -res]
        half_px = cell / res / 2
        r_px = np.linalg.norm(pix - centre_px, axis=-1)
        inner = r_px < 0.92 * half_px
        m = ink & inner & ~near_line
        area = inner.sum()
        if (inner & ~seen).sum() > 0.2 * area:
            occluded.append(cellno)
        frac = float(m.sum() / max(area, 1))
        fractions.append(frac)
        if m.sum() < max(12, 0.01 * area):
            marks.append("")
            continue
        ink_xy = pix[m]
        r = np.linalg.norm(ink_xy - ink_xy.mean(axis=0), axis=1)
        mid = (r < 0.35 * np.mean(r)).sum() / max(m.sum(), 1)
        ring = np.std(r) / max(np.mean(r), 1e-9)
        marks.append("O" if mid < 0.05 and ring < 0.35 else "X")
    return marks, fractions, occluded
