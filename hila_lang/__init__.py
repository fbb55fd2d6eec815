"""hila: a language for one-shot hierarchical imitation learning (HILA-OSILA).

The folders are the floors, top to bottom.  An import points down or along a floor, never up,
and no import loops (``tests/test_layers.py`` reads every import, the lazy ones and those made
through ``importlib`` too, and checks this list):

- ``cli``, ``__main__``                  the ``hila`` program; its ``COMMANDS`` table loads a command
- ``commands/``, ``studio/``             one module per ``hila`` command; the local browser app
- ``worlds/``                            what a program runs in: scripted, tictactoe, letters, picture
- ``session/``, ``lsp/``, ``evaluation/``  a run wired and watched: runner, REPL, recording, replay; the LSP; ``hila eval``
- ``engine/``                            the stepping engine: step loop, one executor per state class, scene, trace
- ``language/``                          the front end: grammar, AST, checker, compiler, the FSM
- ``robot/``, ``ros/``                   robots from their specs (iCub, Panda, KUKA, any URDF) in PyBullet; the dry back end; the ROS 2 back end and robot-sim
- ``perception/``                        stereo eyes: calibration, marker tracks, scene matching; a pen on a sheet
- ``sim/``, ``plugins/``                 the simulated scene and camera; the plug-in seam
- ``hierarchy/``                         HILA: THE step (bind a sub-template, run OSILA), sequences, explain
- ``recognition/``                       known sub-actions found in a new demonstration
- ``osila/``, ``metrics``                OSILA (``imitate``), templates, segmentation; R, MSD, resampling
- ``core/``                              errors, validation, file io, shipped resources, logs, Ctrl-C, jit

Each package's docstring names its modules, one line each.

Importing ``hila_lang`` sets one thing for the whole process: the numeric libraries' threads
(one each by default; ``HILA_THREADS`` changes it; :mod:`hila_lang.core.threads`), before any of
them loads.
"""

from .core import threads as _threads

__version__ = "0.1.0"

_threads.startup()
