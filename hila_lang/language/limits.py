"""Every limit of the language and its engine in one place, each with the measurement behind it.

Exceeding one is a located error (exit status 2 for a program, 1 for a run), never a hang, a
``RecursionError`` or memory without end.
"""

#: deepest nesting a program may have: blocks inside blocks (a task's or main's body is the
#: first) plus expression levels (an operand inside an operator, a point's coordinate, an
#: argument: every operator of a chain like ``a + b + c`` nests one level).  Every stage after
#: the parser walks the AST recursively; measured on this machine, the deepest walk (nested
#: ``if``) takes 4.05 Python frames per level, so 100 levels use about 400 of Python's default
#: 1000 (``tests/test_lang_limits.py`` runs every stage at the limit with the recursion limit
#: lowered to 4.5 frames per level).  No program written by hand nests 100 deep.
MAX_NESTING = 100

#: most states a program may compile to (tasks are inlined, so a task called twice by a task
#: called twice ... doubles at every level).  A state takes about 0.5 kB, so 500,000 are about
#: 250 MB; a 5 MB program of plain statements compiles to about 270,000 (``bench/parse.py``).
MAX_STATES = 500_000

#: steps one run may take before it is stopped as a loop that never ends (``--max-steps``;
#: 0 for none).  The longest shipped program takes 62 steps (a tic-tac-toe game), writing a
#: 26-letter word about 800; a ``let`` loop reaches 100,000 steps in under a second here
#: (160,000 steps/s without printing), so a runaway loop stops quickly while real programs keep
#: two orders of magnitude of headroom.
DEFAULT_STEP_LIMIT = 100_000

#: trace entries the engine keeps in memory (the newest; up to twice this many between trims).
#: A run entry holds its planned and executed paths (about 5 kB), so 2,000 entries stay near
#: 10 MB; ``hila exec --trace FILE`` streams every entry to the file instead.
TRACE_KEEP = 1000
