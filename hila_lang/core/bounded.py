"""Logs that keep memory flat however long a run: :class:`BoundedLog`.

A run of a hundred thousand steps must not keep a hundred thousand paths.  The engine's trace,
the dry back end's moves, the scripted world's notifications and the PyBullet back end's
executed traces are append-only logs that keep their newest items only.  A log still behaves as
the whole log where code measures it: ``len()`` counts every item ever appended, and
``del log[n:]`` removes the items appended after the n-th -- what a snapshot that saved a log's
length does to go back (:class:`hila_lang.plugins.snapshots.AttributeSnapshots`).
"""

from __future__ import annotations


class BoundedLog(list):
    """An append-only list that keeps its newest ``keep`` items (up to twice that between trims;
    ``keep=0``: all of them).

    ``len(log)`` is the number of items appended since it was made (the log's length as a
    whole); indexing, slicing, iteration and comparison see the items kept, the newest last;
    ``dropped`` says how many were let go.  ``del log[n:]`` removes the items appended after the
    n-th.  Appending is the only way in (``append``, ``extend``).
    """

    def __init__(self, keep: int, items=()) -> None:
        super().__init__()
        self.keep = keep
        self.dropped = 0
        self.extend(items)

    def append(self, item) -> None:
        super().append(item)
        kept = super().__len__()
        if self.keep and kept >= 2 * self.keep:
            super().__delitem__(slice(0, kept - self.keep))
            self.dropped += kept - self.keep

    def extend(self, items) -> None:
        for item in items:
            self.append(item)

    def __iadd__(self, items):
        self.extend(items)
        return self

    def __len__(self) -> int:
        return self.dropped + super().__len__()

    def __delitem__(self, index) -> None:
        if isinstance(index, slice) and index.stop is None and index.step is None and (index.start or 0) >= 0:
            start = index.start or 0
            super().__delitem__(slice(max(start - self.dropped, 0), None))
            self.dropped = min(self.dropped, start)
            return
        raise TypeError("a BoundedLog only cuts its end: del log[n:]")

    def removed_after(self, n: int) -> list:
        """The kept items appended after the n-th (what ``del log[n:]`` would remove)."""
        return list(self[max(n - self.dropped, 0):])
