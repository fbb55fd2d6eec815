"""Tic-tac-toe, the paper's Experiment B: the iCub plays circles on paper against an opponent.

- :mod:`.rules` -- rules and a minimax player that never loses (pure Python);
- :mod:`.opponents` -- seeded built-in opponents and a person typing at a prompt;
- :mod:`.marks` -- the opponent's hand-drawn crosses (neat or sloppy), measures of the robot's circles;
- :mod:`.reading` -- the grid and the marks in one camera image;
- :mod:`.vision` -- the robot reads the board through its eyes and decides when to look again;
- :mod:`.player` -- the robot's side: what it saw and did, and what it decides from that;
- :mod:`.referee` -- the game's record, the opponent's moves, the perturbations, the scores;
- :mod:`.tracking` -- the robot following the sheet through its eyes while it draws (``track``);
- :mod:`.recording` -- the circle demonstration seen by the iCub's eyes: scene, recording, learning;
- :mod:`.demonstration` -- the seeded human-like demonstration behind ``primitives/circle.yaml``;
- :mod:`.world` -- the ``tictactoe`` world ``hila exec programs/game.hila`` runs in;
- :mod:`.report` -- the output folder of a game;
- :mod:`.studio` -- the game in ``hila studio``: the demonstration sheet to draw on, the board to click.

:data:`WORLD` declares it (entry point ``hila.worlds: tictactoe``).
"""

from ...plugins.names import Name, Names
from ...plugins.registry import WorldInfo
from ...plugins.settings import Setting, boolean, choice, number
from ...plugins.studio import StudioView

WORLD = WorldInfo(
    name="tictactoe",
    factory="hila_lang.worlds.tictactoe.world:make_world",
    recorder="hila_lang.worlds.tictactoe.recording:learn_from_sim",
    icp_reader="hila_lang.worlds.tictactoe.vision:demonstration_icps",
    doc="the paper's Experiment B: the iCub plays O on a rotated grid against an opponent",
    settings=(
        Setting("opponent", "who plays X", choice("random", "minimax", "human"), default="minimax",
                metavar="random|minimax|human", flag="--opponent"),
        Setting("first", "who starts", choice("robot", "opponent"), default="robot", metavar="robot|opponent"),
        Setting("report", "write the output folder (images, traces, report.json)", boolean, default=True,
                metavar="yes|no"),
        Setting("board.bump", "after each opponent move the sheet is pushed up to D metres from where it was laid "
                              "and turned up to 15 deg (seeded)", number(0.0, 0.05), default=0.0, metavar="D"),
        Setting("board.slide", "while the robot draws, the sheet slides D metres in a seeded direction over 1.5 s, "
                               "from a seeded 20-60 % of the stroke (the robot sees it only through its eyes)",
                number(0.0, 0.05), default=0.0, metavar="D"),
        Setting("board.turn", "while the robot draws, the sheet turns DEG degrees (seeded sign) over 1.5 s, with "
                              "board.slide or alone", number(0.0, 30.0), default=0.0, metavar="DEG"),
        Setting("board.jump", "while the robot draws, the sheet jumps D metres at once (seeded direction) at a "
                              "seeded 20-60 % of the stroke", number(0.0, 0.04), default=0.0, metavar="D"),
        Setting("light", "after each opponent move the light changes to a seeded level between F and 1 of the "
                         "original, from a seeded direction", number(0.3, 2.0), default=1.0, metavar="F"),
        Setting("crosses", "how the opponent draws its crosses: neat, or sloppy (off-centre, turned, over a grid "
                           "line)", choice("neat", "sloppy"), default="neat", metavar="neat|sloppy"),
    ),
    points=Names("point", [
        Name("board.cellN.tl|tr|br|bl", "the corners of cell N (1..9) as the robot last saw them"),
        Name("board.move.tl|tr|br|bl", "the corners of the cell the robot plays next (only while it sees it is "
                                       "its turn)"),
        Name("arm.park", "where the arm was parked at the start: a seeded random place above the grid"),
        Name("arm.lift", "straight above the pen at the park height"),
    ]),
    questions=Names("question", [
        Name("game_over", "true when someone has won or the board is full", answer="ask_game_over"),
        Name("robot_to_move", "true when it is the robot's turn", answer="ask_robot_to_move"),
        Name("opponent_to_move", "true when it is the opponent's turn", answer="ask_opponent_to_move"),
        Name("best_move", "the robot's next cell as a point group, e.g. \"board.cell5\" (minimax on the board "
                          "it sees)", answer="ask_best_move"),
        Name("best_cell", "the robot's next cell as a number 1..9", answer="ask_best_cell"),
        Name("last_move", "the point group of the robot's last circle", answer="ask_last_move"),
        Name("winner", "\"robot\", \"opponent\", \"draw\" or none while the game goes on", answer="ask_winner"),
        Name("marks", "how many marks are on the board", answer="ask_marks"),
        Name("free", "true when cell N (1..9) is empty", args=("N",), answer="ask_free"),
    ]),
    events=Names("event", [
        Name("opponent_moved", "the opponent plays a cell (its cross is inked); the value is the cell",
             answer="wait_opponent_moved"),
    ]),
    default_backend="pybullet",
    drawing_surface=True,
    studio=StudioView(
        scene="hila_lang.worlds.tictactoe.studio:scene", scene_label="tic-tac-toe (robot's eye)",
        board="hila_lang.worlds.tictactoe.studio:board", outcome="hila_lang.worlds.tictactoe.studio:outcome",
        settings={"opponent": {"human": "you (click a cell)", "minimax": "minimax", "random": "random"}},
        hint="In tic-tac-toe you play the crosses: click a cell when asked."),
    tracking=True,  # the robot follows the sheet through its eyes while it draws (:mod:`.tracking`)
)
