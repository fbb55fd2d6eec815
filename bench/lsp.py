"""Benchmark: ``hila lsp`` diagnostics for a 500-line program (target <= 50 ms as you type).

A 500-line tic-tac-toe program (comments, blank lines, 40 tasks, a main with a loop) is checked
the way the server checks it.  Printed, medians over repeated runs, with the bare parse of the
same text (hila's LALR parser, positions kept: the floor of any front end) measured in the same
run and every figure also as a ratio to it, since machines differ:

- ``cold``: a document opened for the first time (every chunk parsed, templates read);
- ``keystroke``: the same document after typing one character inside a task (the case the
  target is for: unchanged chunks come from the cache);
- ``new line``: after typing a newline near the top (every chunk below moves: parsed again);
- ``stdio``: ``textDocument/didChange`` of one character to ``publishDiagnostics`` through a
  running ``hila lsp`` (JSON-RPC over pipes included).

    python bench/lsp.py [--repeat 21]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def program(lines: int = 500) -> str:
    """A tic-tac-toe program of exactly ``lines`` lines: 9-line tasks, a main that calls each."""
    head = ["# A long game program for the language server benchmark.", "world tictactoe",
            "import circle                          # tags reach, draw, retract", "",
            "point home = (0.18, -0.25, 0.75)", ""]
    tasks = (lines - len(head) - 9) // 10
    body: list[str] = []
    for k in range(1, tasks + 1):
        body += [f"# mark {k}: reach the cell, draw, keep away from home", f"task mark{k}(c) {{",
                 "    run circle.reach(c.*, hand = arm.lift, start = none)",
                 "    run circle.draw(c.*, hand = none) avoid home radius 0.01",
                 f"    if ask free({k % 9 + 1}) {{", f"        let x = {k} * 2 + 1", "    }", "}", ""]
    main = ["main {", "    until ask game_over {", "        if ask robot_to_move {", "            let c = ask best_move"]
    main += [f"            mark{k}(c)" for k in range(1, tasks + 1)]
    main += ["        } else {", "            wait opponent_moved", "        }", "    }", "}"]
    filler = ["# (blank)"] * (lines - len(head) - len(body) - len(main))
    return "\n".join(head + body + filler + main) + "\n"


def median_ms(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times) * 1000


def stdio_ms(path: Path, text: str, repeat: int) -> float:
    proc = subprocess.Popen([sys.executable, "-m", "hila_lang", "lsp"], cwd=ROOT, stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE)

    def send(msg):
        body = json.dumps({"jsonrpc": "2.0", **msg}).encode()
        proc.stdin.write(f"Content-Length: {len(body)}\r\n\r\n".encode() + body)
        proc.stdin.flush()

    def read():
        length = 0
        while (line := proc.stdout.readline()) not in (b"\r\n", b"\n", b""):
            if line.lower().startswith(b"content-length"):
                length = int(line.split(b":")[1])
        return json.loads(proc.stdout.read(length))

    def until_diagnostics():
        while read().get("method") != "textDocument/publishDiagnostics":
            pass

    uri = path.as_uri()
    send({"id": 1, "method": "initialize", "params": {"processId": None, "rootUri": None, "capabilities": {}}})
    read()
    send({"method": "initialized", "params": {}})
    send({"method": "textDocument/didOpen", "params": {"textDocument": {"uri": uri, "languageId": "hila",
                                                                        "version": 1, "text": text}}})
    until_diagnostics()
    lines = text.split("\n")
    where = next(i for i, l in enumerate(lines) if "run circle.draw" in l)
    times = []
    for k in range(repeat):
        change = {"range": {"start": {"line": where, "character": 4}, "end": {"line": where, "character": 4}},
                  "text": " " if k % 2 == 0 else ""}
        if k % 2:
            change["range"]["end"]["character"] = 5
        t = time.perf_counter()
        send({"method": "textDocument/didChange", "params": {"textDocument": {"uri": uri, "version": k + 2},
                                                              "contentChanges": [change]}})
        until_diagnostics()
        times.append(time.perf_counter() - t)
    send({"id": 2, "method": "shutdown"})
    read()
    send({"method": "exit"})
    proc.wait(timeout=30)
    return statistics.median(times) * 1000


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=21)
    args = ap.parse_args()
    from lark import Lark

    from hila_lang.language.environment import Environment
    from hila_lang.lsp.analysis import Document
    from hila_lang.core.resources import grammar_path

    text = program()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "long.hila"
        path.write_text(text)
        (Path(tmp) / "circle.yaml").write_text((ROOT / "primitives" / "circle.yaml").read_text())
        # lark's plain tree parser of the same grammar (hila's own builds the AST while parsing)
        lark = Lark.open(str(grammar_path()), parser="lalr", propagate_positions=True, maybe_placeholders=True)
        lark.parse(text)  # warm-up
        floor = median_ms(lambda: lark.parse(text), args.repeat)
        env = Environment()
        Document(str(path), env).analyse(text)  # imports and caches warm (not the chunks)
        cold = median_ms(lambda: Document(str(path), env).analyse(text), args.repeat)
        doc = Document(str(path), env)
        assert doc.analyse(text) == [], doc.problems
        lines = text.split("\n")
        where = next(i for i, l in enumerate(lines) if "run circle.draw" in l)
        edits = []
        for k in range(args.repeat):
            changed = list(lines)
            changed[where] = changed[where] + (" " * (k % 3 + 1))
            edits.append("\n".join(changed))
        state = iter(edits * 2)
        key = median_ms(lambda: doc.analyse(next(state)), args.repeat)
        moved = iter(["\n" * (k % 2) + text for k in range(args.repeat * 2)])
        newline = median_ms(lambda: doc.analyse(next(moved)), args.repeat)
        wire = stdio_ms(path, text, args.repeat)
    n = len(text.split("\n")) - 1
    print(f"{n}-line program, {len(text)} characters; medians of {args.repeat} runs")
    print(f"  bare parse (floor)        {floor:7.1f} ms   1.00x")
    print(f"  cold: opened              {cold:7.1f} ms   {cold / floor:5.2f}x")
    print(f"  keystroke in a task       {key:7.1f} ms   {key / floor:5.2f}x   (target <= 50 ms)")
    print(f"  newline at the top        {newline:7.1f} ms   {newline / floor:5.2f}x")
    print(f"  stdio: didChange -> diagnostics {wire:5.1f} ms   {wire / floor:5.2f}x")


if __name__ == "__main__":
    main()
