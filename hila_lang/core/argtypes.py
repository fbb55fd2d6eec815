"""Command-line value types shared by every ``hila`` command, and the limits they hold.

Each is an ``argparse`` ``type=``: it returns the value or raises ``ArgumentTypeError`` with what
was expected and what came, so a bad value is exit 2 with argparse's usage line, never a
traceback.  The limits here are the ones the studio's request checks obey too, so a number the
command line refuses is refused everywhere (one place states them).

- :func:`whole`        a whole number in a range (``--seed``, ``--max-steps``, counts)
- :func:`number`       a finite number in a range
- :func:`output_path`  a path to write; an empty one is refused (an unset shell variable,
                       ``--out "$OUT"``, would otherwise mean the current folder)
"""

from __future__ import annotations

import argparse

#: seeds: numpy's SeedSequence takes any whole number >= 0; a number is read up to 40 digits
SEED_MAX = 10**40 - 1
#: ``hila eval --trials-per-setup``: 15 in the paper; 1000 per set-up is 5000 trials,
#: 25 million pairs -- days of work, the most a person could mean
TRIALS_PER_SETUP_MAX = 1000


def _integer(text: str) -> int | None:
    text = text.strip()
    if len(text) > len(str(SEED_MAX)) or not text.lstrip("+-").isdigit():  # int() would read '1_0' and 4300 digits
        return None
    return int(text)


def whole(minimum: int = 0, maximum: int | None = None, note: str = ""):
    """argparse type: a whole number in ``[minimum, maximum]`` (``note`` says what a value means)."""

    def parse(text: str) -> int:
        value = _integer(text)
        if value is None or value < minimum or (maximum is not None and value > maximum):
            span = f">= {minimum}" if maximum is None else f"from {minimum} to {maximum}"
            got = repr(text) if value is None else value
            raise argparse.ArgumentTypeError(f"expected a whole number {span}{note}, got {got}")
        return value

    return parse


def number(minimum: float | None = None, maximum: float | None = None, note: str = ""):
    """argparse type: a finite number in ``[minimum, maximum]`` (either end optional)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        low = minimum is not None and not value >= minimum
        high = maximum is not None and not value <= maximum
        if low or high or value != value or abs(value) == float("inf"):
            span = " ".join(s for s in (f">= {minimum:g}" if minimum is not None else "",
                                        f"<= {maximum:g}" if maximum is not None else "") if s)
            raise argparse.ArgumentTypeError(f"expected a finite number {span}{note}".rstrip() + f", got {text}")
        return value

    return parse


def output_path(text: str) -> str:
    """argparse type: a path to write to.  An empty (or blank) path is refused: ``--out ""`` is
    what an unset shell variable gives, and taken as ``Path("")`` it would mean the current
    folder, whose files a run would replace."""
    if not text.strip():
        raise argparse.ArgumentTypeError(
            "expected a path, got an empty one (an unset shell variable?); to write here, say '.'")
    return text


seed = whole(0)  # at most SEED_MAX: longer numbers are not read
