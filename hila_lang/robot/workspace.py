"""hila's table, where every robot works (measured for the iCub first, docs/design.md §5).

World frame: metres, z up, origin on the floor.  The table top is at z = 0.57 with its front
edge at x = 0.12; a robot stands on its -x side facing +x, its right side towards -y (the
iCub's root (waist) at (0, 0, 0.62); the Panda's and KUKA's bases on a pedestal behind the
front edge: their specs, :mod:`.spec`).  A sheet of paper on it has its surface
:data:`PAPER_THICKNESS` higher.  The worlds lay their sheets out on this table whatever the robot.
"""

from __future__ import annotations

import math

#: world z of the table's top, metres
TABLE_TOP_Z = 0.57
#: world x of the table's front edge (the edge nearest the robot), metres
TABLE_FRONT_X = 0.12
#: table size (depth along x, width along y, thickness), metres
TABLE_SIZE = (0.60, 1.00, 0.03)
#: paper thickness, metres: the drawing surface is this far above the table top
PAPER_THICKNESS = 0.001
#: the hand's ready point above the paper's centre, metres (where a back end starts the pen when
#: the world does not say)
READY_HEIGHT = 0.10


def ready_point(surface):
    """The pen's start when the world names none: :data:`READY_HEIGHT` above ``surface``'s centre, (3,)."""
    # lazy: loads numpy, which importing this module does not
    import numpy as np

    return surface.to_world(0.0, 0.0) + np.array([0.0, 0.0, READY_HEIGHT])


def default_surface(center=(0.31, -0.09), rotation: float = math.radians(15.0)):
    """A blank A4 sheet on the table where the robot reaches it well: by default centred at
    (0.31, -0.09), turned 15 degrees (where the tic-tac-toe game's sheet lies; a world that says
    nothing gets it; a robot's spec may say otherwise: ``sheet``)."""
    # lazy: loads numpy, which importing this module does not
    from ..sim.surface import Surface

    return Surface(center=tuple(center), rotation=rotation, z=TABLE_TOP_Z + PAPER_THICKNESS)
