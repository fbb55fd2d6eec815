"""How long ``hila check`` takes on a large program, and how much memory: now, before, and a floor.

A seeded program of ``--mb`` megabytes (default 5: about 170,000 statements -- lets with
arithmetic, ifs, calls of a task that runs a template) is checked three ways, each in its own
process so that peak memory (``ru_maxrss``) is its own:

- ``now``: ``hila_lang.language.load_program`` -- parse straight to the AST, check, compile;
- ``before``: the front end as it was before issue 13, rebuilt from the same parts -- lark's
  parse tree with positions, then the tree-walking ``ToAst`` transformer, check and compile,
  with Python's garbage collector left running;
- ``floor``: lark's lexer alone over the same text (every lark-based parser pays at least this).

It prints seconds and peak MB for each and the ratios; run it from the checkout with the package
installed: ``python bench/parse.py [--mb 5] [--skip-before]``.
"""

from __future__ import annotations

import argparse
import json
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CHILD = r"""
import gc, json, resource, sys, time
mode, path = sys.argv[1], sys.argv[2]
text = open(path, encoding="utf-8").read()
def tree_parser():  # lark's plain tree parser of the same grammar (hila itself parses to the AST)
    from lark import Lark
    from hila_lang.core.resources import grammar_path
    return Lark.open(str(grammar_path()), parser="lalr", propagate_positions=True, maybe_placeholders=True)
t0 = time.perf_counter()
if mode == "now":
    from hila_lang.language import load_program
    checked, fsm = load_program(path)
    states = len(fsm.states)
elif mode == "before":
    from hila_lang.language.checker import check
    from hila_lang.language.compiler import compile_program
    from hila_lang.language.transformer import to_ast
    fsm = compile_program(check(to_ast(tree_parser().parse(text), text, path)))
    states = len(fsm.states)
else:
    states = sum(1 for _ in tree_parser().lex(text))  # tokens, for the floor
seconds = time.perf_counter() - t0
print(json.dumps({"seconds": seconds, "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "count": states}))
"""


def make_program(megabytes: float, seed: int = 0) -> str:
    """A seeded program of about ``megabytes`` MB that checks cleanly."""
    rng = random.Random(seed)
    lines = ["import reach", "point home = (0.18, -0.25, 0.75)", "hand at home",
             "task visit(thing) {", "    run reach.reach(object = thing, home = home)",
             "    run reach.back(object = thing, home = home)", "}", "main {", "    let v0 = 1"]
    size, lets, i = sum(len(x) + 1 for x in lines), [0], 1
    while size < megabytes * 1e6:
        k = rng.random()
        if k < 0.5:
            line = f"    let v{i} = {rng.randint(0, 99)} + v{rng.choice(lets[-50:])} * 2"
            lets.append(i)
        elif k < 0.8:
            line = f"    if v{rng.choice(lets[-50:])} > 3 {{ let w{i} = 1 }}"
        else:
            line = f"    visit(({rng.uniform(0.25, 0.35):.3f}, {rng.uniform(-0.15, 0.05):.3f}, 0.6))"
        lines.append(line)
        size += len(line) + 1
        i += 1
    lines.append("}")
    return "\n".join(lines) + "\n"


def measure(mode: str, path: Path) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, mode, str(path)], capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"{mode} failed:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mb", type=float, default=5.0, help="program size, megabytes (default 5)")
    ap.add_argument("--skip-before", action="store_true", help="skip the slow 'before' front end")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "big.hila"
        text = make_program(args.mb)
        path.write_text(text, encoding="utf-8")
        print(f"program: {len(text) / 1e6:.2f} MB, {text.count(chr(10))} lines")
        results = {}
        for mode in ("floor", "now") + (() if args.skip_before else ("before",)):
            t = time.perf_counter()
            results[mode] = r = measure(mode, path)
            print(f"{mode:>7}: {r['seconds']:7.1f} s  {r['peak_mb']:7.0f} MB peak  "
                  f"({'tokens' if mode == 'floor' else 'states'}: {r['count']}; process {time.perf_counter() - t:.1f} s)")
        now, floor = results["now"], results["floor"]
        print(f"now / floor (lexing alone): {now['seconds'] / floor['seconds']:.1f}x time")
        if "before" in results:
            before = results["before"]
            print(f"before / now: {before['seconds'] / now['seconds']:.1f}x time, "
                  f"{before['peak_mb'] / now['peak_mb']:.1f}x peak memory")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
