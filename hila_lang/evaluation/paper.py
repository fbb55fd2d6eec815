"""The paper's own figures for Experiment A (Wu & Demiris, ICARCV 2010, Tables I–III).

Reference values only: printed BESIDE ours by :mod:`.tables`, never used as results.  Transcribed
from the paper's text (its OCR interleaves two columns; the second row block of Table II is
mislabelled "Exp 1" there and is Exp 2).  Array layout matches ours: ``[N - 1, output, input]``
with set-ups Exp 1..5 = Fig. 5 (a)..(e); columns are the input (template) experiment, rows the
output (task) experiment.
"""

from __future__ import annotations

import numpy as np

#: Table I: averaged R of the self-mapping cases, [N - 1, experiment]
TABLE_I = np.array([
    [0.996, 0.999, 0.991, 0.991, 0.994],
    [0.999, 1.000, 0.999, 1.000, 1.000],
    [0.999, 1.000, 0.999, 1.000, 1.000],
    [0.999, 1.000, 0.999, 1.000, 1.000],
])

# Table II as printed: per output experiment, 4 lines (N = 1..4) of 5 input experiments
_TABLE_II_ROWS = [
    [[0.961, 0.953, 0.817, 0.414, 0.380], [0.979, 0.941, 0.860, 0.800, 0.791],
     [0.987, 0.976, 0.948, 0.949, 0.934], [0.989, 0.984, 0.977, 0.978, 0.966]],
    [[0.993, 0.995, 0.941, 0.740, 0.711], [0.970, 0.998, 0.877, 0.972, 0.964],
     [0.989, 0.999, 0.970, 0.994, 0.990], [0.995, 0.999, 0.988, 0.997, 0.995]],
    [[0.861, 0.444, 0.891, 0.774, 0.747], [0.910, 0.896, 0.941, 0.877, 0.847],
     [0.952, 0.948, 0.967, 0.963, 0.954], [0.966, 0.968, 0.982, 0.980, 0.973]],
    [[0.757, 0.817, 0.871, 0.957, 0.938], [0.872, 0.845, 0.798, 0.977, 0.967],
     [0.929, 0.922, 0.938, 0.987, 0.981], [0.944, 0.954, 0.969, 0.992, 0.987]],
    [[0.835, 0.816, 0.872, 0.885, 0.962], [0.875, 0.879, 0.840, 0.966, 0.977],
     [0.937, 0.935, 0.935, 0.979, 0.987], [0.952, 0.960, 0.965, 0.984, 0.991]],
]
_TABLE_III_ROWS = [
    [[176, 298, 1222, 7388, 8390], [74, 177, 682, 538, 562], [31, 63, 133, 120, 156], [18, 30, 58, 55, 76]],
    [[117, 57, 1899, 2809, 5095], [436, 26, 2448, 378, 444], [152, 8, 356, 78, 136], [70, 4, 122, 28, 56]],
    [[799, 2832, 399, 962, 2869], [385, 316, 231, 619, 852], [143, 117, 122, 110, 140], [70, 55, 62, 57, 68]],
    [[1548, 667, 1164, 203, 343], [606, 551, 2317, 148, 176], [211, 219, 397, 69, 94], [115, 111, 175, 41, 59]],
    [[1139, 834, 1286, 459, 280], [758, 478, 1963, 222, 133], [255, 261, 428, 124, 75], [151, 172, 215, 92, 44]],
]

#: Table II: averaged R, [N - 1, output, input]
TABLE_II = np.array(_TABLE_II_ROWS, dtype=float).transpose(1, 0, 2)
#: Table III: averaged MSD (squared pixels), [N - 1, output, input]
TABLE_III = np.array(_TABLE_III_ROWS, dtype=float).transpose(1, 0, 2)

#: the paper's summary sentences (§IV.A), quoted
CLAIMS = {
    "unsegmented_below_0.8": "32% of the results have R < 0.8 (OSILA alone, no segmentation)",
    "segmented_at_least_0.8": "as soon as template segmentation is introduced 92% of R are greater than 0.8",
    "n4_above_0.95": "when the number of segments goes up to 4, nearly all R are greater than 0.95",
}
