"""``hila studio``: a local browser app to demonstrate, imitate live, and run and watch programs.

Modules, one per stage:

- :mod:`.security`: the token, the Host/Origin check (DNS rebinding) and paths kept inside the
  studio's folder -- the rules of DESIGN.md §7 ("local first, like Jupyter");
- :mod:`.server`: the Starlette app (HTTP routes and websockets) and :func:`.server.serve`;
- :mod:`.frontend`: the ONE adapter through which the studio parses and checks programs;
- :mod:`.demonstrate`: scenes to draw on, pointer samples -> a timed path (3-D on a world's
  surface, lifted by a stated rule while the pen is up), saving through ``hila learn``'s code;
- :mod:`.imitate`: OSILA redrawn while the person drags ICPs, with ``hila explain``'s reason;
- :mod:`.session`: a program run (or a recording) driven through the REPL's own commands;
- :mod:`.view3d`: the 3-D view of a run (the iCub, the table, the paper and its ink).

Every script and style the page uses is in ``static/`` (no CDN); nothing is fetched at run time.
"""
