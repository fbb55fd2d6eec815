"""The ``hila`` commands, one module each, loaded by ``cli``'s ``COMMANDS`` table when run.

- ``check``     ``hila check``: parse, check and compile; the first error of each file
- ``compile_``  ``hila compile``: the FSM (text, dot, json) or the AST of a program
- ``exec_``     ``hila exec``: run a program to the end on a back end
- ``repl``      ``hila repl``: step a program interactively (or from piped stdin)
- ``replay``    ``hila replay``: step through a recorded run, or verify it
- ``explain``   ``hila explain``: run a program and say what OSILA did in each run state and why
- ``learn``     ``hila learn``: one demonstration -> a segmented template YAML
- ``sheet``     ``hila sheet``: the printable pen sheet (ArUco markers) as PDF or PNG
- ``imitate``   ``hila imitate``: one template imitated in a task scene
- ``eval_``     ``hila eval``: OSILA against controls, baselines and its ablation
- ``snapshot``  ``hila snapshot``: PNGs of the simulated iCub drawing
- ``show``      ``hila show``: what a template or a world offers a program
- ``lsp``       ``hila lsp``: the language server (stdio)
- ``studio``    ``hila studio``: the local browser app
- ``robot_sim`` ``hila robot-sim``: a simulated arm behind ROS 2 topics, for ``--backend ros``

The top floor with the studio: a command may import anything below it; nothing below imports a command.
"""
