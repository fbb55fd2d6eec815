"""Worlds: what a program's ``world NAME`` runs in.  Each is a package whose ``__init__`` declares
its :class:`~hila_lang.plugins.registry.WorldInfo` (``WORLD``, light: nothing heavy imported)
and names it in an entry point of the group ``hila.worlds``.

- :mod:`.scripted`  -- fixed points, answers and events from a script (tests, the examples)
- :mod:`.tictactoe` -- the paper's Experiment B: the iCub plays tic-tac-toe on paper
- :mod:`.letters`   -- the iCub writes a word, one learned template per letter
- :mod:`.picture`   -- the iCub retraces a route on a map sheet found by scene matching

Worlds sit above the language, the robot and perception: they may use them, nothing below
imports a world.
"""
