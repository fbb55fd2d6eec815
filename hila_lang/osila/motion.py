"""Human-like motion profiles shared by the demonstration generators.

The stand-in demonstrations (tic-tac-toe in :mod:`hila_lang.worlds.tictactoe.demonstration`, Experiment A in
:mod:`hila_lang.evaluation.dataset`, the A-B-C and reach templates in
:mod:`hila_lang.worlds.scripted.demos`) move along their curves with a human arm's speed profile.
"""

from __future__ import annotations

import numpy as np


def minimum_jerk(tau) -> np.ndarray:
    """Minimum-jerk progress s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ (Flash & Hogan 1985).

    Parameters
    ----------
    tau : array_like
        Normalised time; values outside [0, 1] are clipped (the movement has not started, or
        has ended).

    Returns
    -------
    ndarray, same shape as ``tau``
        Progress from 0 to 1, with zero velocity and acceleration at both ends.
    """
    t = np.clip(np.asarray(tau, dtype=float), 0.0, 1.0)
    return t**3 * (10.0 - 15.0 * t + 6.0 * t * t)


def minimum_jerk_samples(n: int) -> np.ndarray:
    """:func:`minimum_jerk` at ``n`` evenly spaced instants from start to end, shape (n,)."""
    return minimum_jerk(np.linspace(0.0, 1.0, n))
