"""Tic-tac-toe, the paper's Experiment B: the iCub plays circles on paper against an opponent.

- :mod:`.rules` -- rules and a minimax player that never loses (pure Python);
- :mod:`.opponents` -- seeded built-in opponents and a person typing at a prompt;
- :mod:`.marks` -- the opponent's hand-drawn crosses, measures of the robot's circles;
- :mod:`.vision` -- the robot reads the board through its eyes;
- :mod:`.demonstration` -- the seeded human-like demonstration behind ``primitives/circle.yaml``;
- :mod:`.world` -- the ``tictactoe`` world ``hila exec programs/game.hila`` runs in;
- :mod:`.report` -- the output folder of a game.

:data:`WORLD` declares it (entry point ``hila.worlds: tictactoe``).
"""

from ...plugins.registry import WorldInfo
from ...plugins.settings import Setting, boolean, choice

WORLD = WorldInfo(
    name="tictactoe",
    factory="hila_lang.worlds.tictactoe.world:make_world",
    doc="the paper's Experiment B: the iCub plays O on a rotated grid against an opponent",
    settings=(
        Setting("opponent", "who plays X", choice("random", "minimax", "human"), default="minimax",
                metavar="random|minimax|human", flag="--opponent"),
        Setting("first", "who starts", choice("robot", "opponent"), default="robot", metavar="robot|opponent"),
        Setting("report", "write the output folder (images, traces, report.json)", boolean, default=True,
                metavar="yes|no"),
    ),
    questions={
        "game_over": "true when someone has won or the board is full",
        "robot_to_move": "true when it is the robot's turn",
        "opponent_to_move": "true when it is the opponent's turn",
        "best_move": "the robot's next cell as a point group, e.g. \"board.cell5\" (minimax on the board it sees)",
        "best_cell": "the robot's next cell as a number 1..9",
        "last_move": "the point group of the robot's last circle",
        "winner": "\"robot\", \"opponent\", \"draw\" or none while the game goes on",
        "marks": "how many marks are on the board",
        "free": "free(N): true when cell N (1..9) is empty",
    },
    events={"opponent_moved": "the opponent plays a cell (its cross is inked); the value is the cell"},
    default_backend="pybullet",
    drawing_surface=True,
)
