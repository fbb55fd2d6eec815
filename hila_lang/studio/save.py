"""A demonstration saved as a template (the Demonstrate page's *Save template*): :func:`learned`
makes the three files' texts (``NAME.demo.csv``, ``NAME.icps.yaml``, ``NAME.yaml``) with
``hila learn``'s own function, in a worker (:mod:`.worker`); :func:`save` writes them as one
transaction (:func:`.files.write`), an existing name only with ``overwrite``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.errors import InputError
from . import files
from .security import inside


def _names(req: dict) -> tuple[str, str, str]:
    """(``NAME.yaml``, ``NAME.demo.csv``, ``NAME.icps.yaml``) of a save, its name checked (the
    template first: a 409 names it)."""
    from ..language.transformer import usable_as_tag

    name = str(req.get("name", "")).strip()
    if not usable_as_tag(name):
        raise InputError(f"template name {name!r}: a program imports it by name, so use a letter or '_' and "
                         "then letters, digits or '_'")
    return f"{name}.yaml", f"{name}.demo.csv", f"{name}.icps.yaml"


def learned(folder: Path, req: dict) -> tuple[dict[str, str], dict]:
    """What a save writes, learned but not written: ({file name: text} of ``NAME.demo.csv``,
    ``NAME.icps.yaml`` and ``NAME.yaml``, the answer ``{template, demo, icps, command,
    segments}``).  The template is learned with ``hila learn``'s function from the very CSV and
    ICP texts written (copies in a private temporary folder), so it is byte for byte what ``hila
    learn NAME.demo.csv --icps NAME.icps.yaml ...`` writes.  Runs in a worker (:mod:`.worker`).

    ``req``: ``name``, ``path`` (T, D), ``times`` (T,), ``icps`` {name: point}, ``tags``
    (list), ``contact`` (list), ``method``, ``seed`` and optional ``cuts`` (k - 1 indices) with
    ``cuts_from``, where they come from when not from a hand (the Camera scene: the pen's tracked contact).
    """
    import tempfile

    from ..hierarchy.learn import learn_files
    from ..osila.demofile import demo_csv, icps_text
    from ..osila.template import Segment, check_segments, template_text

    target_name, demo_name, icps_name = _names(req)
    name = target_name[:-len(".yaml")]
    path = np.asarray(req.get("path"), float)
    times = np.asarray(req.get("times"), float)
    if path.ndim != 2 or path.shape[1] not in (2, 3) or len(times) != len(path):
        raise InputError(f"expected a path (T, 2 or 3) with T times, got {path.shape} and {times.shape}")
    icps = req.get("icps") or {}
    if not icps:
        raise InputError("place at least one ICP (click on the scene) before saving")
    tags = [str(t) for t in req.get("tags") or []]
    contact = [str(t) for t in req.get("contact") or []]
    method, seed = str(req.get("method", "speed")), int(req.get("seed", 0))
    target, demo, icps_file = (inside(folder, n) for n in (target_name, demo_name, icps_name))
    k = max(len(tags), 1)
    texts = {demo_name: demo_csv(path, times), icps_name: icps_text(icps)}
    with tempfile.TemporaryDirectory(prefix="hila-learn-") as tmp:
        copies = [Path(tmp) / n for n in (demo_name, icps_name)]
        for copy in copies:
            copy.write_text(texts[copy.name], encoding="utf-8")
        template = learn_files(str(copies[0]), str(copies[1]), name=name, tags=tags, contact=contact, k=k,
                               method=method, seed=seed, named=(str(demo), str(icps_file)))
    argv = [str(demo), "--icps", str(icps_file), "-k", str(k), "--method", method, "--seed", str(seed),
            "-o", str(target)] + (["--tags", ",".join(tags)] if tags else []) + \
        (["--contact", ",".join(contact)] if contact else [])
    cuts = req.get("cuts")
    proposed = [s.start for s in template.segments[1:]]
    if cuts is not None and tags and len(cuts) != len(tags) - 1:
        raise InputError(f"cuts: expected {len(tags) - 1} cuts for {len(tags)} tags, got {len(cuts)}")
    if cuts is not None and tags and [int(c) for c in cuts] != proposed:
        bounds = [0, *[int(c) for c in cuts], len(path)]
        segs = [Segment(tag, bounds[i], bounds[i + 1], tag in contact) for i, tag in enumerate(tags)]
        check_segments(segs, len(path), "cuts")
        template.segments = segs
        why = str(req.get("cuts_from") or "") or "moved by hand in hila studio"
        template.description += f" Cuts {why}: {[int(c) for c in cuts]} (proposed {proposed})."
    texts[target_name] = template_text(template)
    return texts, dict(template=target_name, demo=demo_name, icps=icps_name, command="hila learn " + " ".join(argv),
                       segments=[dict(tag=s.tag, start=s.start, stop=s.stop, contact=s.contact)
                                 for s in template.segments])


def save(folder: Path, req: dict) -> dict:
    """Learn (:func:`learned`) and write ``NAME.demo.csv``, ``NAME.icps.yaml`` and ``NAME.yaml``
    in ``folder`` as one transaction (:func:`.files.write`: all or none; an existing name only
    with ``req["overwrite"]``); returns ``{template, demo, icps, command, segments}``."""
    overwrite = bool(req.get("overwrite"))
    files.refuse_existing(folder, _names(req), overwrite)  # before the work
    texts, answer = learned(folder, req)
    files.write(folder, texts, overwrite=overwrite)
    return answer
