"""Perception through the iCub's stereo eye cameras (paper section III.C), with OpenCV.

- :mod:`~hila_lang.perception.camera`        pinhole model, poses, PyBullet view/projection matrices
- :mod:`~hila_lang.perception.distortion`    the simulated lens (radial, barrel) and undistortion
- :mod:`~hila_lang.perception.simworld`      table, sheet, hand marker, chessboard cards in PyBullet
- :mod:`~hila_lang.perception.rig`           the eyes' intrinsics and poses while watching
- :mod:`~hila_lang.perception.calibration`   chessboard calibration per eye, and of the eye pair
- :mod:`~hila_lang.perception.recording`     recording a demonstration to PNG folders; reading frames
- :mod:`~hila_lang.perception.extraction`    sub-pixel marker track, gap bridging, RBF smoothing
- :mod:`~hila_lang.perception.triangulation` two tracks -> a 3-D path
- :mod:`~hila_lang.perception.board`         the grid's cell corners and the O/X marks from an image
- :mod:`~hila_lang.perception.learn`         entry points: :func:`template_from_frames`,
  :func:`template_from_sim`

Importing this package imports numpy only; OpenCV, SciPy and PyBullet load when used.
"""

from __future__ import annotations

from .board import BoardReading, read_board
from .learn import Perception, perceive, template_from_frames, template_from_sim

__all__ = ["BoardReading", "read_board", "Perception", "perceive", "template_from_frames", "template_from_sim"]
