"""ICP pairs by name: the one shape a template's ICPs take between binding and OSILA.

A step binds its template's ICPs to scene points once (:func:`hila_lang.hierarchy.step.bind`)
and gets :class:`Pairs`: the names in the template's order, the template points ``src`` (K, D)
and the task points ``dst`` (K, D), row by row -- exactly the arrays :func:`hila_lang.osila.imitate`
takes, so nothing is reshaped on the way in.  It reads as a mapping name -> task point (what a
trace, a recording and ``hila explain`` show) and answers the questions about pairs that need
OSILA's own tolerances, so no caller reaches into OSILA's modules for them:

- :meth:`Pairs.pins` -- the bound ``start``/``end`` as OSILA's ``pin`` (first and last stamp);
- :meth:`Pairs.coincident` -- pairs that are one template point but bound apart (OSILA keeps one
  pair per template point, :data:`hila_lang.osila.tps.MERGE_TOL`);
- :meth:`Pairs.groups` -- names whose template points OSILA merges;
- :meth:`Pairs.through` -- names of the ICPs the template path passes through
  (:func:`hila_lang.osila.adjust.on_path`);
- :meth:`Pairs.renamed` -- OSILA's messages about "ICP k" (a row) told by name.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Callable, Iterator

import numpy as np

from .adjust import ON_PATH, on_path
from .template import END, START
from .tps import MERGE_TOL


@dataclass(frozen=True, eq=False)
class Pairs(Mapping):
    """Bound ICPs: ``names`` (K,), template points ``src`` (K, D), task points ``dst`` (K, D).

    As a mapping: name -> task point (D,), in the template's ICP order.
    """

    names: tuple[str, ...]
    src: np.ndarray
    dst: np.ndarray

    def __post_init__(self):
        src, dst = np.asarray(self.src, dtype=float), np.asarray(self.dst, dtype=float)
        if src.ndim != 2 or dst.ndim != 2 or not len(src) == len(dst) == len(self.names):
            raise ValueError(f"expected {len(self.names)} template and task points, one row per name, "
                             f"got {src.shape} and {dst.shape}")
        object.__setattr__(self, "names", tuple(self.names))
        object.__setattr__(self, "src", src)
        object.__setattr__(self, "dst", dst)

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.dst[self.names.index(name)]
        except ValueError:
            raise KeyError(name) from None

    def __iter__(self) -> Iterator[str]:
        return iter(self.names)

    def __len__(self) -> int:
        return len(self.names)

    def __repr__(self) -> str:
        return f"Pairs({', '.join(self.names)})"

    def without(self, name: str) -> Pairs:
        """These pairs less ``name``'s."""
        keep = [i for i, n in enumerate(self.names) if n != name]
        return Pairs(tuple(self.names[i] for i in keep), self.src[keep], self.dst[keep])

    def mapped(self, task: Callable[[np.ndarray], np.ndarray]) -> Pairs:
        """The same pairs with every task point passed through ``task`` (e.g. lifted onto a
        surface: the task points may change size, the template points do not)."""
        dst = np.array([np.asarray(task(p), dtype=float) for p in self.dst]).reshape(len(self), -1)
        return Pairs(self.names, self.src, dst)

    def pins(self) -> dict[int, np.ndarray]:
        """OSILA's ``pin`` for the bound boundary ICPs: ``start`` -> first stamp, ``end`` -> last."""
        return {i: self[name] for i, name in ((0, START), (-1, END)) if name in self.names}

    def coincident(self, path: np.ndarray, threshold: float | None = None) -> list[tuple[str, str, float]]:
        """``(a, b, gap)`` for each two ICPs that are one template point (OSILA merges them) but
        bound ``gap`` apart, more than the distortion ``threshold`` (given, else
        :data:`~hila_lang.osila.adjust.ON_PATH` of the template path's size): one of the two
        bindings cannot hold."""
        if len(self) < 2:
            return []
        same = MERGE_TOL * float(np.ptp(self.src, axis=0).max())
        tol = threshold if threshold else ON_PATH * float(np.linalg.norm(np.ptp(np.asarray(path, float), axis=0)))
        out = []
        for i in range(len(self)):
            for j in range(i + 1, len(self)):
                if np.linalg.norm(self.src[i] - self.src[j]) > same:
                    continue
                gap = float(np.linalg.norm(self.dst[i] - self.dst[j]))
                if gap > tol:
                    out.append((self.names[i], self.names[j], gap))
        return out

    def groups(self) -> list[list[str]]:
        """Groups (>= 2) of names whose template points coincide (OSILA keeps one pair of each)."""
        extent = float(np.ptp(self.src, axis=0).max()) if len(self) > 1 else 0.0
        groups: list[list[int]] = []
        for i, p in enumerate(self.src):
            for g in groups:
                if np.linalg.norm(self.src[g[0]] - p) <= MERGE_TOL * max(extent, 1e-300):
                    g.append(i)
                    break
            else:
                groups.append([i])
        return [[self.names[i] for i in g] for g in groups if len(g) > 1]

    def through(self, path: np.ndarray) -> set[str]:
        """Names of the ICPs the template ``path`` passes through (a touched object, a boundary)."""
        return {self.names[k] for k in on_path(np.asarray(path, float), self.src)}

    def renamed(self, message: str) -> str:
        """OSILA's ``message`` with each "ICP k" (a row of these pairs) told by its name."""
        return re.sub(r"\bICP (\d+)\b", lambda m: f"ICP '{self.names[int(m.group(1))]}'"
                      if int(m.group(1)) < len(self) else m.group(0), message)

