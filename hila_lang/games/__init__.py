"""Tic-tac-toe, the paper's Experiment B: rules, opponents, the demonstration, the world.

- :mod:`.tictactoe` -- rules and a minimax player that never loses (pure Python);
- :mod:`.opponents` -- seeded built-in opponents and a person typing at a prompt;
- :mod:`.demonstration` -- the seeded human-like demonstration behind ``primitives/circle.yaml``;
- :mod:`.world` -- the ``tictactoe`` world ``hila exec programs/game.hila`` runs in;
- :mod:`.report` -- the output folder of a game.
"""
