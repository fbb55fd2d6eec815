"""The ``scripted`` world: scene points, answers and events read from a YAML script.

See :mod:`hila_lang.worlds.scripted.world`.  Its questions, events and points are whatever the
script names, so ``hila check --set script=FILE.yaml`` checks a program against the script
(``declare``); without a script the world is empty.

- ``world``  the world itself
- ``motion`` its points moving while the robot moves (the ``tracking`` capability)
- ``demos``  seeded stand-in demonstrations behind ``primitives/abc.yaml`` and ``reach.yaml``
"""

from ...plugins.registry import WorldInfo
from ...plugins.settings import Setting, text

WORLD = WorldInfo(
    name="scripted",
    factory="hila_lang.worlds.scripted.world:make_world",
    doc="fixed scene points, answers and events from a YAML script (tests, examples)",
    settings=(Setting("script", "a YAML file: points (name: [x, y, z]), answers (question: value or "
                      "[values in turn]), events (event: [values in turn]), home ([x, y, z]), motion (moves of the "
                      "points while the robot moves)", text(),
                      metavar="FILE.yaml"),),
    dynamic_names=True,
    declare="hila_lang.worlds.scripted.world:declared",
    tracking=True,  # a script's points may move while the robot moves (``motion``)
)
