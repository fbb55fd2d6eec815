"""Perception through the iCub's stereo eye cameras (paper section III.C), and of a pen before one
camera, with OpenCV.

Perception knows no world: what the ICPs of a demonstration are is read by the world's own
reader (:func:`~hila_lang.perception.learn.perceive` takes it as an argument).

- :mod:`~hila_lang.perception.distortion`    the simulated lens (radial, barrel) and undistortion
- :mod:`~hila_lang.perception.rig`           the eyes' true intrinsics and a pair of eye cameras
- :mod:`~hila_lang.perception.calibration`   chessboard calibration per eye, and of the eye pair
- :mod:`~hila_lang.perception.recording`     recording folders: writing a simulated one, reading frames
- :mod:`~hila_lang.perception.extraction`    sub-pixel marker track, gap bridging, RBF smoothing
- :mod:`~hila_lang.perception.triangulation` two tracks -> a 3-D path
- :mod:`~hila_lang.perception.matching`      scene matching: ICP pairs between a demonstration and a task scene
- :mod:`~hila_lang.perception.learn`         entry points: :func:`perceive`, :func:`template_from_frames`
- :mod:`~hila_lang.perception.sheet`         the printable pen sheet: ArUco markers, grid, PNG and PDF
- :mod:`~hila_lang.perception.pen`           one camera: a pen with a coloured ball tracked on the sheet
- :mod:`~hila_lang.perception.penvideo`      seeded synthetic videos of a pen on the sheet, with truth; .y4m files

The camera model is :mod:`hila_lang.sim.camera`.  Importing this package imports numpy only;
OpenCV, SciPy and PyBullet load when used.
"""

from __future__ import annotations

from .learn import IcpReading, Perception, perceive, template_from_frames

__all__ = ["IcpReading", "Perception", "perceive", "template_from_frames"]
