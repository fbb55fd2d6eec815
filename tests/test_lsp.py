"""``hila lsp``: a session over stdio with a plain JSON-RPC client, and the analysis behind it.

The diagnostics are ``hila check``'s own errors: compared with ``hila check`` on the same file,
and, for seeded random edits of every shipped program, with the whole-text front end
(``load_program``) that ``hila check`` runs -- the chunked, cached parse must agree exactly.
"""

from __future__ import annotations

import json
import queue
import random
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from hila_lang.core.errors import HilaError
from hila_lang.language import load_program
from hila_lang.lsp.analysis import Document, chunks

ROOT = Path(__file__).resolve().parent.parent
PROGRAMS = sorted((ROOT / "programs").glob("*.hila")) + sorted((ROOT / "tests" / "programs").glob("*.hila"))

BROKEN = """\
world tictactoe
import circle

task mark(c) {
    run circle.reach(c.*, hand = arm.lift, start = none)
    run circle.drw(c.*, hand = none)
}

main {
    until ask game_over {
        if ask robot_to_move {
            let c = ask best_move
            mark(c)
        } else {
            wait opponent_moved
        }
    }
}
"""


class Client:
    """A minimal LSP client: Content-Length framed JSON-RPC on the server's stdin/stdout."""

    def __init__(self, cwd: Path) -> None:
        self.proc = subprocess.Popen([sys.executable, "-m", "hila_lang", "lsp"], cwd=cwd, stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        self.messages: queue.Queue = queue.Queue()
        self.next_id = 0
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        out = self.proc.stdout
        while True:
            length = None
            while True:
                line = out.readline()
                if not line:
                    self.messages.put(None)
                    return
                if line in (b"\r\n", b"\n"):
                    break
                name, _, value = line.decode().partition(":")
                if name.lower() == "content-length":
                    length = int(value)
            self.messages.put(json.loads(out.read(length)))

    def send(self, message: dict) -> None:
        body = json.dumps({"jsonrpc": "2.0", **message}).encode()
        self.proc.stdin.write(f"Content-Length: {len(body)}\r\n\r\n".encode() + body)
        self.proc.stdin.flush()

    def notify(self, method: str, params: dict) -> None:
        self.send({"method": method, "params": params})

    def wait(self, accept) -> dict:
        while True:
            message = self.messages.get(timeout=60)
            assert message is not None, "the server closed its output"
            if accept(message):
                return message

    def request(self, method: str, params: dict):
        self.next_id += 1
        rid = self.next_id
        self.send({"id": rid, "method": method, "params": params})
        reply = self.wait(lambda m: m.get("id") == rid and "method" not in m)
        assert "error" not in reply, reply
        return reply["result"]

    def diagnostics(self, uri: str) -> list[dict]:
        return self.wait(lambda m: m.get("method") == "textDocument/publishDiagnostics"
                         and m["params"]["uri"] == uri)["params"]["diagnostics"]


def at(text: str, needle: str, offset: int = 0, nth: int = 0) -> dict:
    """The LSP position of ``needle`` (its ``nth`` occurrence) plus ``offset`` characters."""
    index = -1
    for _ in range(nth + 1):
        index = text.index(needle, index + 1)
    line = text.count("\n", 0, index)
    return {"line": line, "character": index - (text.rfind("\n", 0, index) + 1) + offset}


def test_a_session_over_stdio(tmp_path):
    prog = tmp_path / "game.hila"
    prog.write_text(BROKEN)
    uri = prog.as_uri()
    c = Client(ROOT)  # from the checkout: import circle finds primitives/circle.yaml
    try:
        init = c.request("initialize", {"processId": None, "rootUri": None, "capabilities": {}})
        caps = init["capabilities"]
        assert caps["hoverProvider"] and caps["definitionProvider"] and "." in caps["completionProvider"]["triggerCharacters"]
        c.notify("initialized", {})
        c.notify("textDocument/didOpen", {"textDocument": {"uri": uri, "languageId": "hila", "version": 1, "text": BROKEN}})
        (diag,) = c.diagnostics(uri)
        # the same located error as hila check
        check = subprocess.run([sys.executable, "-m", "hila_lang", "check", str(prog)], capture_output=True, text=True,
                               cwd=ROOT, timeout=120)
        first = check.stderr.splitlines()[0]
        assert first == f"{prog}:6:16: error: template 'circle' has no sub-template 'drw'"
        assert diag["range"] == {"start": {"line": 5, "character": 15}, "end": {"line": 5, "character": 18}}
        assert diag["message"] == "template 'circle' has no sub-template 'drw'\nhint: did you mean 'draw'?"
        assert diag["severity"] == 1

        fixed = BROKEN.replace("circle.drw", "circle.draw")
        c.notify("textDocument/didChange", {"textDocument": {"uri": uri, "version": 2},
                                            "contentChanges": [{"text": fixed}]})
        assert c.diagnostics(uri) == []

        doc = {"textDocument": {"uri": uri}}
        hover = c.request("textDocument/hover", {**doc, "position": at(fixed, "circle.draw", 9)})
        assert hover["contents"]["value"].startswith("**circle.draw**: sub-template of ")
        assert "ICPs: tl, tr, br, bl, hand, start, end" in hover["contents"]["value"]
        hover = c.request("textDocument/hover", {**doc, "position": at(fixed, "import circle", 8)})
        assert "tags: reach, draw (pen down), retract" in hover["contents"]["value"]
        assert "ICPs: tl, tr, br, bl, hand" in hover["contents"]["value"]
        hover = c.request("textDocument/hover", {**doc, "position": at(fixed, "best_move", 2)})
        assert hover["contents"]["value"].startswith("**ask best_move** (world tictactoe): the robot's next cell")
        hover = c.request("textDocument/hover", {**doc, "position": at(fixed, "opponent_moved", 1)})
        assert hover["contents"]["value"].startswith("**wait opponent_moved** (world tictactoe): the opponent plays")
        hover = c.request("textDocument/hover", {**doc, "position": at(fixed, "mark(c)", 1, nth=1)})
        assert hover["contents"]["value"] == "**task mark(c)**: 1 parameter(s); defined at line 4"

        where = c.request("textDocument/definition", {**doc, "position": at(fixed, "mark(c)", 2, nth=1)})
        assert where["uri"] == uri and where["range"]["start"] == {"line": 3, "character": 0}
        where = c.request("textDocument/definition", {**doc, "position": at(fixed, "import circle", 9)})
        assert where["uri"] == (ROOT / "primitives" / "circle.yaml").as_uri()
        where = c.request("textDocument/definition", {**doc, "position": at(fixed, "circle.draw", 8)})
        yaml_lines = (ROOT / "primitives" / "circle.yaml").read_text().split("\n")
        assert "tag: draw" in yaml_lines[where["range"]["start"]["line"]]

        typing = fixed.replace("    run circle.draw(c.*, hand = none)\n",
                               "    run circle.draw(c.*, hand = none)\n    run circle.\n")
        c.notify("textDocument/didChange", {"textDocument": {"uri": uri, "version": 3},
                                            "contentChanges": [{"text": typing}]})
        assert c.diagnostics(uri)  # 'run circle.' does not parse yet
        items = c.request("textDocument/completion", {**doc, "position": at(typing, "run circle.\n", 11)})
        assert [i["label"] for i in items["items"]] == ["reach", "draw", "retract"]
        items = c.request("textDocument/completion", {**doc, "position": at(typing, "c.*, hand = arm", 5)})
        labels = [i["label"] for i in items["items"]]
        assert labels[:5] == ["tl", "tr", "br", "bl", "hand"] and "start" in labels
        assert items["items"][0]["insertText"] == "tl = "
        items = c.request("textDocument/completion", {**doc, "position": at(typing, "ask game_over", 4)})
        assert {"game_over", "robot_to_move", "best_move", "free"} <= {i["label"] for i in items["items"]}
        items = c.request("textDocument/completion", {**doc, "position": at(typing, "wait opponent_moved", 5)})
        assert [i["label"] for i in items["items"]] == ["opponent_moved"]

        assert c.request("shutdown", None) is None
        c.notify("exit", None)
        assert c.proc.wait(timeout=30) == 0
    finally:
        if c.proc.poll() is None:
            c.proc.kill()


def test_hila_lsp_without_pygls_says_how_to_install_it(tmp_path):
    blocker = tmp_path / "pygls.py"  # shadows the real package: the import fails as if absent
    blocker.write_text("raise ModuleNotFoundError('no pygls', name='pygls')\n")
    proc = subprocess.run([sys.executable, "-m", "hila_lang", "lsp"], capture_output=True, text=True, cwd=ROOT,
                          timeout=60, env={"PYTHONPATH": str(tmp_path), "PATH": ""})
    assert proc.returncode == 2
    assert "hila lsp needs pygls, which is not installed" in proc.stderr
    assert "pip install 'hila-lang[lsp]'" in proc.stderr


def _whole(path: Path, text: str, templates):
    """What hila check's front end (load_program: parse the whole text, check, compile) says."""
    from hila_lang.language.checker import check
    from hila_lang.language.compiler import compile_program
    from hila_lang.language.transformer import parse_program

    try:
        compile_program(check(parse_program(text, str(path)), templates))  # load_program, templates cached
    except HilaError as exc:
        return exc.message + (f"\nhint: {exc.hint}" if exc.hint else ""), exc.line, exc.column
    return None


def _loaded(path: Path, text: str):
    try:
        load_program(str(path), text)
    except HilaError as exc:
        return exc.message + (f"\nhint: {exc.hint}" if exc.hint else ""), exc.line, exc.column
    return None


def _edits(text: str, rng: random.Random, n: int):
    pieces = ["{", "}", "(", ")", "=", ".", ",", "\n", " ", "run ", "main ", "task ", "x", "#", '"', "point ", "via "]
    for _ in range(n):
        lines = text.split("\n")
        kind = rng.randrange(4)
        if kind == 0 and len(text) > 1:
            i = rng.randrange(len(text))
            yield text[:i] + text[i + 1:]
        elif kind == 1:
            i = rng.randrange(len(text) + 1)
            yield text[:i] + rng.choice(pieces) + text[i:]
        elif kind == 2:
            i = rng.randrange(len(lines))
            yield "\n".join(lines[:i] + lines[i + 1:])
        else:
            i = rng.randrange(len(lines))
            yield "\n".join(lines[:i + 1] + [lines[i]] + lines[i + 1:])


@pytest.mark.parametrize("program", PROGRAMS, ids=lambda p: p.stem)
def test_diagnostics_are_hila_checks_errors_for_random_edits(program, monkeypatch):
    monkeypatch.chdir(ROOT)
    text = program.read_text()
    doc = Document(str(program))
    rng = random.Random(program.stem)
    for sample in (text, text + "}"):  # the reference is what load_program (hila check) says
        assert _whole(program, sample, doc.templates) == _loaded(program, sample)
    compared = broken = 0
    for edited in [text, *_edits(text, rng, 200)]:
        if compared >= 41 and broken >= 5:  # a short program (picture.hila) needs more edits to break 5 times
            break
        problems = [p for p in doc.analyse(edited) if p.severity == "error"]
        expected = _whole(program, edited, doc.templates)
        if expected is None:
            assert problems == []
        else:
            broken += 1
            (p,) = problems
            message, line, column = expected
            assert (p.message, p.line + 1, p.character + 1) == (message, line, column), edited
        compared += 1
    assert compared >= 41 and broken >= 5  # many random edits break the program


def test_chunks_cover_the_text_line_for_line():
    text = (ROOT / "programs" / "game.hila").read_text()
    parts = chunks(text)
    assert "".join(c for _, c in parts) == text
    assert [line for line, _ in parts] == [1] + [i + 1 for i, l in enumerate(text.split("\n"))
                                                 if i and l.startswith(("world", "import", "task", "main"))]
