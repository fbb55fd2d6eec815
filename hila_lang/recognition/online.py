"""Recognition while the demonstration is still arriving (issue 26 item 2).

:class:`OnlineRecogniser` takes points as they come (:meth:`~OnlineRecogniser.push`) and every
:data:`EVERY` seconds of demonstration time recognises the stretch not yet settled with
:func:`.search.recognise` — the offline method, unchanged.  A known part is *announced* as soon
as it is found (``recognise(..., open_end=True)``: no part may end in the last few samples, where
the buffer's edge would pass for the hand slowing down); if later evaluations no longer find it
for :data:`PATIENCE` seconds (the shape went on and became another one), it is *withdrawn*.  A part is settled once the
next known part after it has been found and stayed announced for :data:`SETTLE` seconds: the
stretch before its end is not searched again, so each evaluation costs about the same however
long the demonstration gets.  (Settling a part on its own stability was tried first: a shape in
progress whose first half looks like another library part was settled as that part before it
was complete, and the whole shape was then only found at the end.)

:meth:`~OnlineRecogniser.finish` recognises the whole path once more, so the final answer *is*
the offline answer; it withdraws or announces whatever differs from what was said online (each
such event is counted in :attr:`OnlineRecogniser.corrections`).

Latency: a part is announced EVERY + EDGE samples after its end at the earliest; at 20 Hz that
is 0.05 + 0.15 s, under the issue's 0.3 s (tests/test_recognition_online.py measures it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .library import Entry
from .search import Part, recognise

#: seconds of demonstration between two evaluations
EVERY = 0.05
#: seconds an announced part may go unfound before it is withdrawn (one evaluation can miss it
#: while its end's pause is half arrived)
PATIENCE = 0.3
#: seconds the next known part must stay announced before the stretch up to a part's end is settled
SETTLE = 1.5
#: two findings are the same part if template and tag agree and they overlap by IoU above this
#: (an end may move within the pause it lies in as more of the pause arrives)
SAME = 0.5


@dataclass
class Event:
    """``kind`` "known" (announced) or "withdrawn", the part, and ``at``: the demonstration time it was said."""

    kind: str
    part: Part
    at: float


def _same(a: Part, b: Part) -> bool:
    inter = min(a.end, b.end) - max(a.start, b.start)
    return (a.template, a.tag) == (b.template, b.tag) and inter / (max(a.end, b.end) - min(a.start, b.start)) > SAME


class OnlineRecogniser:
    """Recognise library parts in a demonstration that arrives point by point.

    Parameters
    ----------
    entries : list of Entry
        The library's parts (:func:`.library.load_library`).
    """

    def __init__(self, entries: list[Entry]):
        self.entries = entries
        self.points: list[np.ndarray] = []
        self.times: list[float] = []
        self.events: list[Event] = []
        self.corrections = 0
        self._said: list[list] = []  # announced, not settled: [part, since, unfound since or None]
        self._base = 0  # samples before it are settled
        self._last = -np.inf

    def push(self, point, t: float) -> list[Event]:
        """Add one sample (D,) at time ``t`` seconds; returns the events it caused."""
        self.points.append(np.asarray(point, float))
        self.times.append(float(t))
        if t - self._last < EVERY - 1e-9:
            return []
        self._last = t
        return self._evaluate(t)

    def _evaluate(self, now: float) -> list[Event]:
        n = len(self.points)
        if n - self._base < 4:
            return []
        path = np.array(self.points[self._base:])
        times = np.array(self.times[self._base:])
        found = []
        for p in recognise(path, self.entries, times, open_end=True):
            if p.known:
                p.start += self._base
                p.end += self._base
                found.append(p)
        out = []
        kept = []
        for p, since, unfound in self._said:
            match = [q for q in found if _same(p, q)]
            if match:  # the same part; its ends may have moved within their pauses
                p.start, p.end, p.distance, p.confidence = match[0].start, match[0].end, match[0].distance, match[0].confidence
                kept.append([p, since, None])
            elif unfound is not None and now - unfound >= PATIENCE - 1e-9:
                out.append(Event("withdrawn", p, now))
            else:
                kept.append([p, since, now if unfound is None else unfound])
        for q in found:
            if not any(_same(p, q) for p, *_ in kept):
                kept.append([q, now, None])
                out.append(Event("known", q, now))
        kept.sort(key=lambda ps: ps[0].start)
        # settle the oldest part once the NEXT known part has been found and stayed SETTLE seconds:
        # until then the oldest may still grow into a bigger library part (a Trapezoid-like start
        # of a PShape in progress)
        while len(kept) >= 2 and kept[0][2] is None and kept[1][2] is None and now - kept[1][1] >= SETTLE:
            self._base = kept.pop(0)[0].end
        self._said = kept
        self.events += out
        return out

    def finish(self) -> tuple[list[Part], list[Event]]:
        """The final answer (the offline one, on the whole path) and the corrections it makes."""
        now = self.times[-1] if self.times else 0.0
        final = recognise(np.array(self.points), self.entries, np.array(self.times))
        said = self.said()
        out = [Event("withdrawn", p, now) for p in said if not any(_same(p, q) for q in final if q.known)]
        out += [Event("known", q, now) for q in final if q.known and not any(_same(p, q) for p in said)]
        self.corrections = len(out)
        self.events += out
        return final, out

    def said(self) -> list[Part]:
        """The known parts announced and not withdrawn so far, in time order."""
        live: list[Part] = []
        for e in self.events:
            if e.kind == "known":
                live.append(e.part)
            else:
                live = [p for p in live if p is not e.part]
        return sorted(live, key=lambda p: p.start)
