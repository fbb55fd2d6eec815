"""A run wired, watched and kept: a program, its world and its back end put together for ``hila
exec`` and ``hila repl`` (and the studio), the interactive stepper over the engine
(:mod:`hila_lang.engine`), a run written to one file, and that file stepped through or verified.

One line each:

- ``runner``     wiring a program, a world and a back end into a run
- ``runopts``    options shared by ``hila exec`` and ``hila repl``
- ``runout``     ``--out DIR``: a run's picture and report for a world that writes none
- ``repl``       the interactive stepper
- ``recording``  a run written to one file
- ``replay``     stepping through a recording, or verifying it
- ``plot``       a generated path drawn with OpenCV (top and side views)
- ``view3d``     the 3-D view of a run the simulator renders (the studio's Run page)
"""
