"""The simulated scene: what a world asks a back end to build, and the one PyBullet scene.

- :mod:`~hila_lang.sim.surface` -- :class:`Surface` (a flat drawing surface: pose, size, texture)
  and :class:`Scene` (what a world hands a back end); pure numpy
- :mod:`~hila_lang.sim.sheet` -- a printed sheet that may be bent: its geometry and mesh
- :mod:`~hila_lang.sim.motion` -- a sheet that moves while the robot draws (slide, turn, jump; seeded)
- :mod:`~hila_lang.sim.canvas` -- a surface's texture as a raster strokes are drawn into
- :mod:`~hila_lang.sim.camera` -- the one camera model: intrinsics, poses, projection, rendering
- :mod:`~hila_lang.sim.client` -- silencing PyBullet's C-level output
- :mod:`~hila_lang.sim.culling` -- links a camera cannot see left out of its image (the same image, faster)
- :mod:`~hila_lang.sim.scene` -- the one PyBullet scene
"""
