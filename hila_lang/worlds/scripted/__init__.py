"""The ``scripted`` world: scene points, answers and events read from a YAML script.

See :mod:`hila_lang.worlds.scripted.world`.  Its questions and events are whatever the script
names, so they are not declared here (``dynamic_names``).
"""

from ...plugins.registry import WorldInfo
from ...plugins.settings import Setting, text

WORLD = WorldInfo(
    name="scripted",
    factory="hila_lang.worlds.scripted.world:make_world",
    doc="fixed scene points, answers and events from a YAML script (tests, examples)",
    settings=(Setting("script", "a YAML file with points, answers, events and home", text(), metavar="FILE.yaml"),),
    dynamic_names=True,
)
