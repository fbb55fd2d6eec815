"""Marker extraction: sub-pixel centres, lost-frame bridging, bounded RBF smoothing; triangulation."""

from __future__ import annotations

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

from hila_lang.core.errors import InputError  # noqa: E402
from hila_lang.sim.camera import intrinsics, look_at, project  # noqa: E402
from hila_lang.perception.extraction import bridge, detect_marker, marker_track, rbf_smooth  # noqa: E402
from hila_lang.perception.triangulation import triangulate  # noqa: E402

PAPER = (245, 245, 240)


def disc_image(centre, radius=4.0, size=(240, 320), ss=8):
    """A green disc at a sub-pixel ``centre`` (u, v), drawn at ``ss`` x and area-averaged."""
    h, w = size
    big = np.zeros((h * ss, w * ss, 3), np.uint8)
    big[:] = PAPER
    c = ((centre[0] + 0.5) * ss - 0.5, (centre[1] + 0.5) * ss - 0.5)
    cv2.circle(big, (int(round(c[0] * 16)), int(round(c[1] * 16))), int(radius * ss * 16), (20, 200, 30), -1,
               cv2.LINE_AA, 4)
    return cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA)


@pytest.mark.parametrize("seed", range(4))
def test_detect_marker_is_sub_pixel(seed):
    rng = np.random.default_rng(seed)
    centre = rng.uniform([40, 40], [280, 200])
    found = detect_marker(disc_image(centre))
    assert np.linalg.norm(found - centre) < 0.05


def test_detect_marker_none_without_marker():
    blank = np.full((240, 320, 3), PAPER, np.uint8)
    assert detect_marker(blank) is None
    with pytest.raises(InputError, match=r"expected an RGB image of shape \(H, W, 3\)"):
        detect_marker(np.zeros((10, 10)))


def _track(n=30):
    t = np.arange(n)
    return np.column_stack([100 + 2.0 * t, 80 + 10 * np.sin(t / 5.0)])


def test_short_gaps_are_bridged():
    truth = _track()
    track = truth.copy()
    track[[7, 8, 20]] = np.nan
    out = bridge(track, max_gap=3)
    assert np.isfinite(out).all()
    assert np.abs(out - truth).max() < 0.1


def test_long_gap_names_the_frames():
    track = _track()
    track[10:16] = np.nan
    names = [f"frame_{i:05d}.png" for i in range(len(track))]
    with pytest.raises(InputError, match=r"marker lost in 6 of 30 left frames; cannot bridge "
                                         r"frames frame_00010.png..frame_00015.png \(6 frames\)"):
        bridge(track, max_gap=3, camera="left", names=names)


def test_lost_first_frame_cannot_be_bridged():
    track = _track()
    track[0] = np.nan
    with pytest.raises(InputError, match="cannot bridge frame 0"):
        bridge(track)


def test_marker_track_reports_bridged_frames():
    truth = _track(12)
    frames = [disc_image(c) for c in truth]
    frames[5] = np.full_like(frames[5], 245)
    track, lost = marker_track(frames, camera="right")
    assert lost == [5]
    assert np.abs(track - truth).max() < 0.3


@pytest.mark.parametrize("seed", range(3))
def test_rbf_smoothing_removes_jitter_and_moves_at_most_half_a_pixel(seed):
    rng = np.random.default_rng(seed)
    times = np.arange(80) / 20.0
    a = np.linspace(0, 2 * np.pi, 80)
    truth = np.column_stack([160 + 20 * np.cos(a), 120 + 20 * np.sin(a)])
    noisy = truth + rng.normal(scale=0.15, size=truth.shape)
    smooth = rbf_smooth(times, noisy)
    assert np.linalg.norm(smooth - noisy, axis=1).max() <= 0.5 + 1e-9
    rms = lambda d: np.sqrt((np.linalg.norm(d, axis=1) ** 2).mean())  # noqa: E731
    assert rms(smooth - truth) < 0.8 * rms(noisy - truth)


def test_triangulation_recovers_points():
    K = intrinsics(320, 240, 64)
    TL = look_at([0.05, 0.034, 0.95], [0.32, -0.07, 0.37])
    TR = look_at([0.05, -0.034, 0.95], [0.32, -0.07, 0.37])
    pts = np.random.default_rng(0).uniform([0.2, -0.2, 0.37], [0.45, 0.05, 0.6], (40, 3))
    out = triangulate(project(pts, K, TL), project(pts, K, TR), K, TL, K, TR)
    assert np.abs(out - pts).max() < 1e-6
    with pytest.raises(InputError, match="same shape"):
        triangulate(project(pts, K, TL), project(pts[:5], K, TR), K, TL, K, TR)
