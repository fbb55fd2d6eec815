"""The plug-in seam: what a world or a back end is, how hila finds them, what they are told.

- :mod:`~hila_lang.plugins.protocols`: :class:`World` and :class:`Backend` with their lifecycle
  hooks, and the capabilities only some back ends have (:class:`Eyes`, :class:`Ink`,
  :class:`Overview`), each an attribute of the back end that is None when it lacks it;
- :mod:`~hila_lang.plugins.settings`: :class:`Setting` (a ``--set KEY=VALUE`` a plug-in
  declares, with its parser, default and one-line doc) and ready-made parsers;
- :mod:`~hila_lang.plugins.registry`: :class:`WorldInfo` and :class:`BackendInfo` (what a plug-in
  declares, readable without building it) found through the entry-point groups ``hila.worlds``
  and ``hila.backends``;
- :mod:`~hila_lang.plugins.options`: :class:`RunOptions`, what ``hila exec``/``hila repl`` pass;
- :mod:`~hila_lang.plugins.names`: a world's points, questions and events, declared once;
- :mod:`~hila_lang.plugins.snapshots`: a ``Snapshots`` capability for state held in attributes;
- :mod:`~hila_lang.plugins.studio`: what a world shows in ``hila studio`` (a scene to draw on, its
  board during a run, the settings the Run page offers).

A third-party package adds a world with one entry point in its own ``pyproject.toml``::

    [project.entry-points."hila.worlds"]
    mine = "my_package.world:WORLD"      # a WorldInfo

Importing this package imports nothing heavy (no numpy), so ``hila --help`` stays instant.
"""
