"""Recognition: known library parts found in a new demonstration (issue 26, the paper's future work).

``hila learn DEMO --library DIR`` cuts a new demonstration into parts the library already holds
(its templates and their tagged sub-templates) and new parts, invariant to where, how big, how
turned and how fast each part was made.

Modules, one per stage:

- :mod:`.shape` — the invariant description: arc-length re-sampling, heading signal, Procrustes
  and elastic (DTW-paired) distances;
- :mod:`.library` — a folder of templates -> searchable parts, with located errors;
- :mod:`.search` — the search (stumpy's ``mass``), verification, selection: :func:`recognise`;
- :mod:`.online` — the same recognition while points arrive;
- :mod:`.written` — the template and JSON report ``hila learn`` writes;
- :mod:`.composite` — composite demonstrations with known parts (bench and tests).

The search libraries (stumpy, dtaidistance) are optional: ``pip install 'hila-lang[recognise]'``.
"""

from __future__ import annotations

from ..core.errors import InputError

HINT = "pip install 'hila-lang[recognise]' (stumpy and dtaidistance)"


def require() -> None:
    """Raise :class:`~hila_lang.core.errors.InputError` with the install hint if stumpy or dtaidistance is missing."""
    for name in ("stumpy", "dtaidistance"):
        try:
            __import__(name)
        except ImportError:
            raise InputError(f"--library needs the optional package {name}, which is not installed", hint=HINT) from None
