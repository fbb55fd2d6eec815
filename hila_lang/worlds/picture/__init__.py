"""The picture world (issue 24): the iCub retraces a route on a map sheet it finds by scene matching.

- :mod:`.texture` -- the seeded map texture printed on the sheet, or the person's own picture
- :mod:`.scenes` -- the demonstration and task scenes (sheet poses, bends, distractors, light),
  the seeded route, what the robot's eyes see, and the referee's truth and route error
- :mod:`.demonstration` -- the demonstration and the template learned from it (``primitives/picture.yaml``)
- :mod:`.tracking` -- the map moving while the robot draws, and the robot following it (``track``)
- :mod:`.world` -- the ``picture`` world ``hila exec programs/picture.hila`` runs in
- :mod:`.studio` -- in ``hila studio``: a route drawn on a person's uploaded picture made its scene

:data:`WORLD` declares it (entry point ``hila.worlds: picture``); ``bench/picture.py`` scores
the matching over seeded scenes (``docs/scene-matching.md``).
"""

from ...plugins.names import Name, Names
from ...plugins.registry import WorldInfo
from ...plugins.settings import Setting, boolean, choice, number, text
from ...plugins.studio import StudioView

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
        Setting("map.slide", "while the robot draws, the map slides D metres in a seeded direction over 1.5 s, from "
                             "a seeded 20-60 % of the stroke", number(0.0, 0.05), default=0.0, metavar="D"),
        Setting("map.turn", "while the robot draws, the map turns DEG degrees (seeded sign) over 1.5 s",
                number(0.0, 30.0), default=0.0, metavar="DEG"),
        Setting("map.jump", "while the robot draws, the map jumps D metres at once (seeded direction)",
                number(0.0, 0.04), default=0.0, metavar="D"),
    ),
    questions=Names("question", [
        Name("matched", "look, match the eyes' images against the demonstration's and answer the point group "
                        "\"match\": match.fNNN is the task point of demonstration feature fNNN, or none where "
                        "unmatched", answer="ask_matched"),
        Name("pairs", "how many matched pairs were kept (0 before 'matched')", answer="ask_pairs"),
    ]),
    default_backend="pybullet",  # its questions are all declared; its points (match.fNNN) are made as it runs
    tracking=True,  # the robot matches again while it draws (``track m``; :mod:`.tracking`)
    studio=StudioView(picture_hook="hila_lang.worlds.picture.studio:picture_scene", picture_setting="picture.image",
                      hint="the picture the route was drawn on: choose it as picture.image"),
)
