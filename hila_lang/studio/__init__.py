"""``hila studio``: a local browser app to demonstrate, imitate live, and run and watch programs.

The app is its pages; a page is its Python module here (its routes and websocket, its
:class:`.page.Page`), its ES module in ``static/`` and its test (``tests/test_studio_NAME.py``).
Modules, one line each:

- ``app``          the Starlette app assembled from the pages (failures answered by its exception handlers); ``serve``
- ``page``         what every page shares: its declaration, the studio's folder, the door requests come in by
- ``files``        the folder's files: listed, read, written (one transaction per action, per-name locks), uploaded
- ``security``     the token, the Host/Origin check (DNS rebinding), files opened inside the folder without links (docs/design.md §6)
- ``schema``       the door: the shape of every request body, query and socket message, and the studio's limits
- ``worker``       heavy work in worker processes: a time budget, killed past it or by Ctrl-C
- ``save``         a demonstration saved as a template: learned as ``hila learn`` does, written as one transaction
- ``demonstrate``  page 1: scenes to draw on, pointer samples -> a timed path, saved as ``hila learn`` does
- ``photoscene``   page 1's uploaded picture made a world's scene: a route drawn on it, the world's template and program
- ``camera``       page 1's Camera scene: webcam frames (or an uploaded video) tracked as ``hila learn --sheet`` does
- ``imitate``      page 2: OSILA redrawn while the person drags ICPs, with ``hila explain``'s reason
- ``run``          page 3: a program checked as typed, run (or a recording replayed) and watched

Every script and style the page uses is in ``static/`` (``common.js`` shared by the pages' ES
modules; no build step, no CDN); nothing is fetched at run time.  What a world shows here (a scene
to draw on, its board, the settings offered) comes from its plug-in
(:class:`hila_lang.plugins.studio.StudioView`): the studio names no world.
"""
