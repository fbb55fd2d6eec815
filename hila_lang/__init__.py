"""hila: a language for one-shot hierarchical imitation learning (HILA-OSILA).

Stages, one module or folder each:

- ``hila_lang.osila``        OSILA: TPS feature-distortion warping, minimum-energy route, plan adjustment
- ``hila_lang.osila.template``     templates (path + named ICPs + tagged sub-templates) and their YAML files
- ``hila_lang.osila.segmentation`` k-means and equal-N splitting of a demonstration into sub-templates
- ``hila_lang.hierarchy``    stitching sub-templates into one task path (HILA)
- ``hila_lang.metrics``      the paper's R (eq. 1), MSD (eq. 2) and cubic-spline resampling
- ``hila_lang.language``     grammar → AST → checker → FSM → interpreter, REPL
- ``hila_lang.robot``        the iCub in PyBullet: scene, pen, IK, cameras
- ``hila_lang.perception``   stereo recording, calibration, marker extraction, triangulation
- ``hila_lang.evaluation``   Experiment A (``hila eval``)
- ``hila_lang.worlds``       worlds: scripted (tests), tictactoe (Experiment B)
"""

__version__ = "0.1.0"
