"""OSILA's routes pinned across speed work: the same seeded calls give the same routes.

``tests/data/core/osila_pinned.npz`` holds the routes these calls returned at commit ea6b5f0,
before issue 38's work on the small call (the route kernel's shortcut, the TPS kernel without its
mask, the route by ``take``), made by running this file with that commit's package on the path:

    PYTHONPATH=<that commit's tree> python tests/test_core_osila_pinned.py tests/data/core/osila_pinned.npz

It is a pin, not a check of correctness (that is the other OSILA tests' work, against slow
references): a change meant to make OSILA faster without changing a result must pass it; a change
meant to change results regenerates the file and says so.  The calls cover what the speed work
touched: OSILA's default ball on clean and noisy paths (narrow: the route kernel's shortcut),
a wide ball, the distortion term, obstacles (plan adjustment, blocked candidates), pins, 2-D
and 3-D, with paths long enough for the compiled kernels (T = 300 >= MIN_STAMPS).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from hila_lang.osila import imitate_detailed

DATA = Path(__file__).parent / "data" / "core" / "osila_pinned.npz"


def cases():
    """(name, path, template ICPs, task ICPs, options) of the pinned calls, all seeded."""
    for dim in (2, 3):
        for seed in (0, 1):
            rng = np.random.default_rng(seed)
            t = np.linspace(0, 2 * np.pi, 300)
            cols = [np.cos(t) * (1 + 0.3 * np.sin(3 * t)), np.sin(t), 0.2 * np.sin(2 * t)][:dim]
            clean = np.column_stack(cols)
            noisy = clean + rng.normal(0, 0.003, clean.shape)
            src = rng.uniform(-1.2, 1.2, (8, dim))
            dst = 1.1 * src + rng.normal(0, 0.05, (8, dim)) + 0.3
            size = float(np.linalg.norm(np.ptp(1.1 * clean + 0.3, axis=0)))
            yield f"{dim}d{seed}_clean_default", clean, src, dst, {}
            yield f"{dim}d{seed}_noisy_default", noisy, src, dst, {}
            if seed:
                continue
            yield f"{dim}d{seed}_wide_ball", noisy, src, dst, {"threshold": 0.01 * size}
            yield f"{dim}d{seed}_distortion_pins", noisy, src, dst, {"distortion": 0.5, "pin": {150: dst[0]}}
            centre = 1.1 * clean[100] + 0.3
            yield (f"{dim}d{seed}_obstacle", noisy, src, dst,
                   {"obstacles": [np.append(centre, 0.05 * size)], "rounds": 20})


def routes() -> dict[str, np.ndarray]:
    return {name: imitate_detailed(path, src, dst, **opts).path for name, path, src, dst, opts in cases()}


def test_routes_equal_the_pinned_ones():
    pinned = np.load(DATA)
    got = routes()
    assert sorted(got) == sorted(pinned.files)
    for name, route in got.items():
        want = pinned[name]
        scale = float(np.abs(want).max())
        np.testing.assert_allclose(route, want, rtol=0, atol=1e-12 * scale, err_msg=name)


def test_the_pinned_calls_exercise_what_they_pin():
    # the default ball is narrow on the clean paths (where the route kernel takes its shortcut),
    # wide where given; the obstacle is met by plan adjustment (more than one round)
    got = {name: imitate_detailed(path, src, dst, **opts) for name, path, src, dst, opts in cases()}
    size = float(np.linalg.norm(np.ptp(got["2d0_clean_default"].mapped, axis=0)))
    assert got["2d0_clean_default"].threshold < 1e-4 * size
    assert got["2d0_wide_ball"].threshold > 1e-3 * size
    assert got["2d0_obstacle"].rounds > 1 and got["3d0_obstacle"].rounds > 1


if __name__ == "__main__":  # regenerate: python tests/test_core_osila_pinned.py OUT.npz
    if len(sys.argv) != 2:
        sys.exit("usage: python tests/test_core_osila_pinned.py OUT.npz")
    np.savez_compressed(sys.argv[1], **routes())
    print(f"wrote {sys.argv[1]}")
