"""The hand marker's image track: sub-pixel detection, lost-frame bridging, Gaussian RBF smoothing.

Detection.  The marker is the only saturated green thing in view.  Each pixel gets a weight
``clip(greenness / GREEN_FULL, 0, 1)`` with ``greenness = G - max(R, B)``: pixels fully inside
the marker weigh 1, pixels it partly covers (the camera averages light over a pixel) weigh
their coverage, so the weighted centroid of the largest green blob is sub-pixel.  Other
colours (:data:`COLOURS`, for a pen's ball before a webcam) use the same rule with their own
*colourness*; :func:`detect_blob` also measures the blob's area.

Bridging.  A frame where no blob of at least ``min_area`` pixels is found is *lost*.  Runs of at
most ``max_gap`` lost frames between two detections are filled by cubic interpolation in time;
a longer run, or a lost first or last frame, raises :class:`~hila_lang.core.errors.InputError` that
names the frames.

Smoothing (paper section III.C: "Gaussian RBF smoothing, 0.5 pixel").  The track u(t), v(t)
is smoothed by least squares with Gaussian radial weights in time (local quadratic regression,
``sigma_frames`` frame intervals wide), and the correction smoothing may make is bounded by
``tolerance`` = 0.5 pixel: the smoothed point never moves further than that from the
measurement.  This is our reading of the paper's figure: it removes detection jitter (a few
hundredths of a pixel here) and never reshapes the drawing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError

#: greenness (G - max(R, B), 0..255) of a pixel fully covered by the marker counts as 1
GREEN_FULL = 80.0
#: greenness below this is background
GREEN_MIN = 12.0


#: colours a marker may have: name -> (channels that must be high, channels that must be low),
#: RGB channel indices.  A pixel's *colourness* is its lowest high channel minus its highest low
#: one: green's is G - max(R, B), yellow's min(R, G) - B.  Skin is reddish (R - max(G, B) is
#: about 50), so a red marker near a hand is a poor choice; green and blue are the safe ones.
COLOURS = {"green": ((1,), (0, 2)), "blue": ((2,), (0, 1)), "red": ((0,), (1, 2)),
           "yellow": ((0, 1), (2,)), "cyan": ((1, 2), (0,)), "magenta": ((0, 2), (1,))}


@dataclass(frozen=True)
class Blob:
    """A coloured marker found in an image.

    Attributes
    ----------
    centre : ndarray (2,)
        Coverage-weighted centroid, pixels.
    area : float
        Its area, pixels: each pixel's colourness over the blob's own bright core (the 90th
        percentile of its colourness), clipped to 1 and summed -- a coverage that neither blur
        (which spreads colourness without adding any) nor the light's brightness changes.
    """

    centre: np.ndarray
    area: float


def colourness(image: np.ndarray, colour: str = "green") -> np.ndarray:
    """How much of ``colour`` each pixel of an RGB image (H, W, 3) holds, (H, W) int16 (see :data:`COLOURS`)."""
    if colour not in COLOURS:
        raise InputError(f"unknown marker colour {colour!r}; expected one of {', '.join(COLOURS)}")
    img = np.asarray(image)
    if img.ndim != 3 or img.shape[2] < 3:
        raise InputError(f"expected an RGB image of shape (H, W, 3), got {img.shape}")
    high, low = COLOURS[colour]
    f = img[:, :, :3].astype(np.int16)
    lo = f[:, :, low[0]] if len(low) == 1 else np.maximum(f[:, :, low[0]], f[:, :, low[1]])
    hi = f[:, :, high[0]] if len(high) == 1 else np.minimum(f[:, :, high[0]], f[:, :, high[1]])
    return hi - lo


def detect_blob(image: np.ndarray, min_area: float = 4.0, colour: str = "green") -> Blob | None:
    """The largest connected blob of ``colour`` in ``image`` (H, W, 3) RGB uint8, or None.

    Its centre is the coverage-weighted centroid (weights ``clip(colourness / GREEN_FULL, 0,
    1)``, the module docstring), so it is sub-pixel.
    """
    # lazy: loads cv2, which importing this module does not
    import cv2

    green = colourness(image, colour)
    mask = (green > GREEN_MIN).astype(np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    if n <= 1:
        return None
    best = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    x0, y0, w, h = (int(stats[best, k]) for k in (cv2.CC_STAT_LEFT, cv2.CC_STAT_TOP,
                                                    cv2.CC_STAT_WIDTH, cv2.CC_STAT_HEIGHT))
    # a one-pixel ring around the blob holds its partially covered edge pixels
    x0, y0 = max(x0 - 1, 0), max(y0 - 1, 0)
    x1, y1 = min(x0 + w + 2, green.shape[1]), min(y0 + h + 2, green.shape[0])
    g = green[y0:y1, x0:x1].astype(float)
    wgt = np.clip(g / GREEN_FULL, 0.0, 1.0)
    wgt[g <= GREEN_MIN / 2] = 0.0
    total = wgt.sum()
    if total < min_area:
        return None
    ys, xs = np.mgrid[y0:y1, x0:x1]
    core = float(np.percentile(g[labels[y0:y1, x0:x1] == best], 90))
    area = float(np.clip(np.where(wgt > 0, g, 0.0) / max(core, 1.0), 0.0, 1.0).sum())
    return Blob(np.array([(wgt * xs).sum() / total, (wgt * ys).sum() / total]), area)


def detect_marker(image: np.ndarray, min_area: float = 4.0, colour: str = "green") -> np.ndarray | None:
    """Sub-pixel centre (2,) of the marker in ``image`` (H, W, 3) RGB uint8, or None.

    The centre is the coverage-weighted centroid of the largest connected blob of ``colour``
    (green by default: the hand marker), pixels (:func:`detect_blob`).
    """
    blob = detect_blob(image, min_area, colour)
    return None if blob is None else blob.centre


def bridge(track: np.ndarray, max_gap: int = 3, *, camera: str = "camera", names=None, what: str = "marker") -> np.ndarray:
    """Fill lost frames (rows of NaN) of ``track`` (T, k) by cubic interpolation in frame index.

    Parameters
    ----------
    track : ndarray, shape (T, k)
        Pixel positions; a lost frame is a row of NaN.
    max_gap : int
        Longest run of consecutive lost frames that is bridged.
    camera : str
        Which camera, for the error message.
    names : sequence of str, optional
        Frame names (file names) for the error message; default frame indices.
    what : str
        What was lost, for the error message.

    Raises
    ------
    InputError
        A run of more than ``max_gap`` lost frames, a lost first or last frame, or fewer than 2
        detections; the message lists the lost frames.
    """
    # lazy: loads scipy, which importing this module does not
    from scipy.interpolate import CubicSpline

    track = np.array(track, dtype=float)
    lost = ~np.isfinite(track).all(axis=1)
    if not lost.any():
        return track
    names = list(names) if names is not None else [str(i) for i in range(len(track))]
    runs = _runs(np.flatnonzero(lost))
    bad = [r for r in runs if len(r) > max_gap or r[0] == 0 or r[-1] == len(track) - 1]
    if bad or (~lost).sum() < 2:
        shown = "; ".join(_fmt_run(r, names) for r in (bad or runs)[:6])
        raise InputError(
            f"{what} lost in {int(lost.sum())} of {len(track)} {camera} frames; cannot bridge {shown} "
            f"(gaps of up to {max_gap} frames between two detections are interpolated)",
            hint=f"check the {what} is in view and lit in those frames, or record again")
    good = np.flatnonzero(~lost)
    spline = CubicSpline(good, track[good], axis=0)
    track[lost] = spline(np.flatnonzero(lost))
    return track


def _runs(idx: np.ndarray) -> list[list[int]]:
    runs: list[list[int]] = []
    for i in idx.tolist():
        if runs and i == runs[-1][-1] + 1:
            runs[-1].append(i)
        else:
            runs.append([i])
    return runs


def _fmt_run(run: list[int], names) -> str:
    if len(run) == 1:
        return f"frame {names[run[0]]}"
    return f"frames {names[run[0]]}..{names[run[-1]]} ({len(run)} frames)"


def rbf_smooth(times: np.ndarray, track: np.ndarray, *, sigma_frames: float = 1.5,
               tolerance: float = 0.5) -> np.ndarray:
    """Gaussian RBF smoothing of an image track, the correction bounded by ``tolerance`` pixels.

    Each smoothed point is the value at its own time of a quadratic fitted to the track by least
    squares with Gaussian radial weights exp(-dt^2 / (2 sigma^2)) (local quadratic regression,
    so the smoother neither flattens curves nor drags the ends), then the correction is clipped
    so no point moves more than ``tolerance`` from its measurement.

    Parameters
    ----------
    times : ndarray, shape (T,)
        Frame times, seconds, strictly increasing.
    track : ndarray, shape (T, 2)
        Pixel positions.
    sigma_frames : float
        Width of the Gaussian weights, in median frame intervals.
    tolerance : float
        Largest distance, pixels, a smoothed point may move from its measurement.

    Returns
    -------
    ndarray, shape (T, 2)
    """
    times = np.asarray(times, dtype=float)
    track = np.asarray(track, dtype=float)
    if len(times) < 5:
        return track.copy()
    dt = float(np.median(np.diff(times)))
    t = (times - times[0]) / dt  # frame units
    d = t[None, :] - t[:, None]  # (T, T): d[i, j] = t_j - t_i
    w = np.exp(-0.5 * (d / sigma_frames) ** 2)
    w[np.abs(d) > 4 * sigma_frames] = 0.0
    powers = np.stack([np.ones_like(d), d, d * d], axis=-1)  # (T, T, 3)
    A = np.einsum("ij,ijk,ijl->ikl", w, powers, powers)  # (T, 3, 3)
    b = np.einsum("ij,ijk,jc->ikc", w, powers, track)  # (T, 3, 2)
    coef = np.linalg.solve(A, b)  # (T, 3, 2)
    smooth = coef[:, 0, :]
    delta = smooth - track
    norm = np.linalg.norm(delta, axis=1, keepdims=True)
    scale = np.minimum(1.0, tolerance / np.maximum(norm, 1e-12))
    return track + delta * scale


def marker_track(images, names=None, *, camera: str = "camera", max_gap: int = 3) -> tuple[np.ndarray, list[int]]:
    """Detect the marker in every image (sequence of (H, W, 3) uint8) and bridge short gaps.

    Returns the raw (distorted-image) track (T, 2), pixels, and the indices of the frames where
    the marker was lost and interpolated.
    """
    track = np.full((len(images), 2), np.nan)
    for i, img in enumerate(images):
        c = detect_marker(img)
        if c is not None:
            track[i] = c
    lost = np.flatnonzero(~np.isfinite(track).all(axis=1)).tolist()
    return bridge(track, max_gap, camera=camera, names=names), lost
