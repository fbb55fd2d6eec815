"""The ground floor: what every stage above shares, importing nothing of hila's above it.

- ``errors``      one error root for everything a user can get wrong, with exit codes
- ``validation``  array checks at the library boundary: what was expected and what came
- ``fileio``      atomic writes, safe YAML, CSV paths
- ``resources``   where hila finds what it ships (grammar, templates, programs); the search path
- ``bounded``     logs that keep memory flat however long a run
- ``interrupts``  Ctrl-C where it can be acted on cleanly
- ``jit``         optional numba compilation of a few hot loops
- ``threads``     the numeric libraries' threads: one by default, set once at start-up
- ``rotation``    rotations: one convention, through one library
- ``argtypes``    command-line value types and the limits they hold (the studio obeys them too)
- ``images``      pictures a person gives, their size checked by the header before decoding
"""
