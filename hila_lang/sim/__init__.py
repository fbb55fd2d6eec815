"""The simulated scene: what a world asks a back end to build, and the one PyBullet scene.

- :mod:`~hila_lang.sim.surface` -- :class:`Surface` (a flat drawing surface: pose, size, texture)
  and :class:`Scene` (what a world hands a back end); pure numpy
"""
