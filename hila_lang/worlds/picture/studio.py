"""The picture world in ``hila studio`` (:class:`~hila_lang.plugins.studio.StudioView`, ``WORLD.studio``).

:func:`picture_scene` is the picture hook: a route a person drew on their own picture in the
Demonstrate page (an ``upload:FILE`` scene; a 2-D template, x right and y up from the picture's
bottom-left corner, 0.25 mm a pixel) becomes the picture world's template
(:func:`.demonstration.learn`: the picture printed on the demonstration sheet, the robot's eyes'
features of it as ICPs, the route's pen-down part traced on it) and a program that runs it with
its ICPs found by scene matching (``ask matched``, as ``programs/picture.hila``).  The run names
the picture with ``--set picture.image=FILE``: the world prints it on the task's sheet too.
"""

from __future__ import annotations

from pathlib import Path

from .demonstration import learn

#: the program the studio writes beside the world's template: ``{template}`` its import name,
#: ``{picture}`` the picture file, ``{route}`` the route drawn on it
PROGRAM = """\
# {route} -- a route drawn on {picture} in hila studio -- retraced by the robot on that picture
# printed on a sheet that lies moved, turned and bent (--seed); the ICPs are the picture's features
# as the robot's eyes saw them (the template {template}.yaml), found again by scene matching.
#
#   hila exec {template}.hila --set picture.image={picture} [--seed N] [--out DIR]
world picture
import {template}    # reach, draw (pen on the picture), lift

main {{
    let m = ask matched    # the robot looks and matches the picture's features
    run {template}(m.*)    # f000 = match.f000, ... (the unmatched ones: none)
}}
"""


def picture_scene(picture: Path, route: Path, template: Path) -> str:
    """Write the picture world's template for ``route`` (a 2-D template or CSV drawn on
    ``picture``) to ``template``; return the program that runs it (:data:`PROGRAM`).  An
    :class:`~hila_lang.core.errors.InputError` for a route that is not drawn on the picture
    (3-D, or leaving it) or a file that is not a picture."""
    learn(str(template), str(picture), str(route))
    return PROGRAM.format(template=Path(template).stem, picture=Path(picture).name, route=Path(route).name)
