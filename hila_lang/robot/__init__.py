"""The iCub in PyBullet: scene geometry, pen, IK, execution, ink and eye cameras.

- :mod:`hila_lang.robot.scene`    board geometry (pure numpy): :class:`SceneSpec`, cell corners
- :mod:`hila_lang.robot.model`    the iCub URDF generated at run time from ``icub-models``
- :mod:`hila_lang.robot.ik`       forward kinematics, Jacobian, damped least squares IK
- :mod:`hila_lang.robot.trajectory` densifying paths, trapezoidal speed profile
- :mod:`hila_lang.robot.console`  silencing PyBullet's C-level console output
- :mod:`hila_lang.robot.ink`      ink rasterisation into the paper texture
- :mod:`hila_lang.robot.cameras`  pinhole cameras (eye cameras, top view)
- :mod:`hila_lang.robot.backend`  :class:`PyBulletBackend`, the Backend the interpreter drives

Importing this package imports nothing heavy; pybullet is loaded by ``backend``.
"""
