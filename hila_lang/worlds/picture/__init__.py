"""The picture world's pieces (issue 24 item 4): a map-like sheet that the robot traces a route on.

- :mod:`.texture` -- the seeded map texture printed on the sheet
- :mod:`.scenes` -- the demonstration and task scenes (sheet poses, bends, distractors, light),
  the seeded route, what the robot's eyes see, and the referee's truth and route error

Not yet a registered world (no ``WORLD``, no program): ``bench/picture.py`` drives these pieces
directly; see ``docs/scene-matching.md``.
"""
