"""What one HILA step did, in words: ``hila explain`` and the REPL's ``explain``.

For a run state (a :class:`hila_lang.hierarchy.step.Step`) :func:`explain_step` lists

- the ICP pairs the warp was fitted on (template point -> task point, by name), saying which
  pairs merged because their template points coincide (the later binding wins);
- the map used: a thin plate spline, or a fallback (similarity, translation) and why;
- OSILA's plan adjustment: how many rounds, and for each round after the first, which
  constraints the previous round's route violated (found by running the same step again with
  ``rounds`` = 1, 2, ...: the step is deterministic, so those runs are the rounds themselves);
- the constraint pairs it added (template point -> task point, for which constraint);
- how the final route meets each ``via`` and ``avoid``.
"""

from __future__ import annotations

import numpy as np

from ..core.errors import ConstraintError
from ..osila.noise import NOISE_MULTIPLE
from ..osila.tps import affine_rank
from ..recognition.written import library_parts
from .step import bind, hila_step, name_constraints, surface_points, three_d, violations


def _fmt(p) -> str:
    return "(" + ", ".join(f"{(0.0 if abs(v) < 5e-4 else v):.3f}" for v in np.asarray(p, float)) + ")"


def warp_reason(warp, dim: int) -> str:
    """Why OSILA's map is what it is (``warp.kind``), from the pairs it kept."""
    kept = len(warp.src)
    if warp.kind == "tps":
        return f"a thin plate spline through {kept} pairs (ICPs and any constraint pairs)"
    if warp.kind == "translation":
        return "a translation (fallback): only one distinct ICP pair, which fixes nothing but a shift"
    if warp.kind == "path":
        on = len(warp.at)
        return (f"the path bent along itself: {on} of {kept} pairs lie on the template's path, its start and end "
                f"among them, and are met where the path passes them with its shape kept between them; the other "
                f"{kept - on} place it in space" if kept > on else
                f"the path bent along itself: all {kept} pairs lie on the template's path, its start and end among "
                f"them, and are met where the path passes them with its shape kept between them")
    rank = affine_rank(warp.src)
    if kept < dim + 1:
        why = f"{kept} distinct pair(s); a thin plate spline in {dim}-D needs at least {dim + 1}"
    elif rank < dim:
        why = (f"the {kept} pairs (ICPs and constraint pairs) span only {rank} of {dim} dimensions "
               f"({'collinear' if rank == 1 else 'coplanar'}), so a spline would be unconstrained across them")
    else:
        amp = warp.amplification
        why = "the spline did not earn its place over the rigid fit" + (
            f" (amplification {amp:.1f} on the path)" if amp is not None else "")
    return f"a similarity transform (fallback): {why}"


def pairs_line(pairs, names: list[str]) -> str:
    """``pairs: 40 matched, 38 kept, 2 rejected (lmeds): a, b; residual 0.8 mm`` (metres shown in
    mm) -- the ICP pairs OSILA was given, kept and rejected as outliers (:mod:`.osila.robust`)."""
    text = f"pairs: {pairs.matched} matched, {len(pairs.kept)} kept, {len(pairs.rejected)} rejected"
    if pairs.method != "none":
        text += f" ({pairs.method})"
    if len(pairs.rejected):
        shown = [names[k] if k < len(names) else str(k) for k in pairs.rejected[:8]]
        text += ": " + ", ".join(shown) + (f" and {len(pairs.rejected) - 8} more" if len(pairs.rejected) > 8 else "")
    if pairs.residual is not None:
        text += f"; residual {pairs.residual * 1000:.3g} mm (leave-one-out, RMS)"
    if getattr(pairs, "smoothing", None) is not None:
        text += f"; smoothing {pairs.smoothing:.3g} (chosen by cross-validation)"
    return text


def _threshold_origin(options: dict) -> str:
    """Where OSILA's threshold came from: the setting, or its default rule (:mod:`.osila.noise`)."""
    if options.get("threshold") is not None:
        return "(as set: osila.threshold)"
    return f"(default: {NOISE_MULTIPLE:g} sigma of the mapped path's position noise)"


def explain_run(template, binding, hand=None, constraints=(), options=None, *, surface=None,
                title: str = "") -> list[str]:
    """Lines explaining the HILA step of ``template`` with ``binding`` (ICP name -> point or None),
    ``hand``, ``constraints``, OSILA ``options`` and the drawing ``surface`` a 2-D template runs
    on, as :func:`hila_lang.hierarchy.step.hila_step` runs it (deterministic: the same as the run it
    explains).  A step whose constraints cannot be met is explained up to its last round, then
    OSILA's error."""
    options = dict(options or {})
    forced = [c for c in constraints if c.radius is None]
    obstacles = [c for c in constraints if c.radius is not None]

    def rounds_violated(k: int) -> str | None:
        try:
            hila_step(template, binding, hand, constraints=constraints, surface=surface, **{**options, "rounds": k})
        except ConstraintError as exc:
            return violations(name_constraints(exc.message, forced, obstacles))
        return None

    if template.dim == 2 and three_d(binding, hand):  # the pairs as OSILA sees them, on the surface
        local = surface_points(template, surface)
        icps = bind(template, {k: None if v is None else local(v) for k, v in binding.items()},
                    None if hand is None else local(hand))
    else:
        icps = bind(template, binding, hand)
    lines = [f"{title}: {template.name}" if title else template.name]

    lines += [f"  library part: {part}" for part in library_parts(template)]
    lines.append(f"  ICP pairs (template -> task), {len(icps)}:")
    for k, p, q in zip(icps.names, icps.src, icps.dst):
        lines.append(f"    {k:<12} {_fmt(p)} -> {_fmt(q)}")
    for group in icps.groups():
        lines.append(f"    {', '.join(group)} coincide in the template: one pair, {group[-1]}'s, is kept")
    try:
        step = hila_step(template, binding, hand, constraints=constraints, surface=surface, **options)
    except ConstraintError as exc:
        rounds = int(options.get("rounds", 10))
        lines.append("  plan adjustment: failed")
        for k in range(1, rounds + 1):
            why = rounds_violated(k)
            if why is None:
                break
            lines.append(f"    round {k}: {why}")
        lines.append(f"  OSILA: {exc.message}")
        return lines
    res = step.result
    lines[0] += f", {len(step.path)} points"
    lines.append(f"  map: {warp_reason(res.warp, template.dim)}")
    if res.pairs is not None:
        lines.append("  " + pairs_line(res.pairs, list(icps)))
    lines.append(f"  threshold: {res.threshold * 1000:.3g} mm " + _threshold_origin(options))
    if not constraints and res.rounds == 1:
        lines.append("  plan adjustment: none needed (no via/avoid, 1 round)")
        return lines
    lines.append(f"  plan adjustment: {res.rounds} round(s)")
    for k in range(1, res.rounds):
        lines.append(f"    round {k}: {rounds_violated(k) or 'conformed'} -> round {k + 1}")
    lines.append(f"    round {res.rounds}: the route conforms")
    if res.added:
        lines.append(f"  constraint pairs added (template -> task), {len(res.added)}:")
        for t, q, label in res.added:
            lines.append(f"    template[{t}] {_fmt(template.path[t])} -> {_fmt(q)} for "
                         f"{name_constraints(label, forced, obstacles)}")
    for c, value in step.met():
        verb = f"met at {value * 1000:.1f} mm" if c.radius is None else f"cleared by {value * 1000:.1f} mm"
        lines.append(f"  {c.name}: {verb}")
    return lines


def explain_step(template, step, *, title: str = "") -> list[str]:
    """:func:`explain_run` of a step that ran (a :class:`~hila_lang.hierarchy.step.Step`)."""
    binding = {k: step.icps.get(k) for k in template.icps}
    return explain_run(template, binding, None, step.constraints, step.options, title=title)
