"""The picture world (issue 24): the iCub retraces a route on a map sheet it finds by scene matching.

- :mod:`.texture` -- the seeded map texture printed on the sheet, or the person's own picture
- :mod:`.scenes` -- the demonstration and task scenes (sheet poses, bends, distractors, light),
  the seeded route, what the robot's eyes see, and the referee's truth and route error
- :mod:`.demonstration` -- the demonstration and the template learned from it (``primitives/picture.yaml``)
- :mod:`.world` -- the ``picture`` world ``hila exec programs/picture.hila`` runs in

:data:`WORLD` declares it (entry point ``hila.worlds: picture``); ``bench/picture.py`` scores
the matching over seeded scenes (``docs/scene-matching.md``).
"""

from ...plugins.names import Name, Names
from ...plugins.registry import WorldInfo
from ...plugins.settings import Setting, boolean, choice, text

WORLD = WorldInfo(
    name="picture",
    factory="hila_lang.worlds.picture.world:make_world",
    doc="the iCub retraces a demonstrated route on a moved, turned, scaled and bent map it finds by scene matching",
    settings=(
        Setting("bent", "bend the task's sheet (2-4 cm high in the middle, seeded)", boolean, default=True,
                metavar="yes|no"),
        Setting("verify", "how matched pairs are verified: local (bent sheets), homography (flat), none (control)",
                choice("local", "homography", "none"), default="local", metavar="local|homography|none"),
        Setting("report", "write the output folder (report.json, route.png, eyes.png)", boolean, default=True,
                metavar="yes|no"),
        Setting("picture.image", "print your own picture (PNG or JPEG) on the sheet instead of the generated map; "
                                 "run a route learned on it (python -m hila_lang.worlds.picture.demonstration OUT.yaml "
                                 "--image FILE --route ROUTE.yaml)", text(what="a picture file"), default=None,
                metavar="FILE"),
    ),
    questions=Names("question", [
        Name("matched", "look, match the eyes' images against the demonstration's and answer the point group "
                        "\"match\": match.fNNN is the task point of demonstration feature fNNN, or none where "
                        "unmatched", answer="ask_matched"),
        Name("pairs", "how many matched pairs were kept (0 before 'matched')", answer="ask_pairs"),
    ]),
    default_backend="pybullet",  # its questions are all declared; its points (match.fNNN) are made as it runs
)
