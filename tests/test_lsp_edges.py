"""``hila lsp`` at the edges editors and broken clients reach (issue 20 items 5 and 7), and
answers read from the tree (issue 21 item 3; completion narrowed to the word typed, issue 23).

The server runs over stdio as an editor starts it; every test fails on a server that hangs,
answers -32603, drops a request or prints a traceback.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from test_lsp import Client

from hila_lang.language import ast as A
from hila_lang.lsp.analysis import MAX_CHARACTERS, Document, path_at

ROOT = Path(__file__).resolve().parent.parent

GAME = """\
world tictactoe
import circle
point home = (0.18, -0.25, 0.75)

task mark(c) {
    run circle.reach(c.*, hand = home, start = none)
    run circle.draw(c.*, hand = none)
}

task spare(c) {
    mark(c)
}

main {
    until ask game_over {
        let c = ask best_move
        mark(c)
    }
}
"""


class Raw(Client):
    """:class:`test_lsp.Client` that can also send what a broken client sends, keeps every
    message it reads, and returns whole replies (result or error)."""

    def __init__(self) -> None:
        self.seen: list[dict] = []  # every message read, kept or passed over
        super().__init__(ROOT)
        self.ids = 0

    def raw(self, data: bytes) -> None:
        self.proc.stdin.write(data)
        self.proc.stdin.flush()

    def wait(self, accept, timeout: float = 30) -> dict:
        while True:
            message = self.messages.get(timeout=timeout)
            assert message is not None, "the server closed its output"
            self.seen.append(message)
            if accept(message):
                return message

    def request(self, method: str, params, timeout: float = 30) -> dict:
        """The whole reply (result or error)."""
        self.ids += 1
        rid = self.ids
        self.send({"id": rid, "method": method, "params": params})
        return self.wait(lambda m: m.get("id") == rid and "method" not in m, timeout)

    def start(self) -> None:
        reply = self.request("initialize", {"processId": None, "rootUri": None, "capabilities": {}})
        assert "result" in reply
        self.send({"method": "initialized", "params": {}})

    def open(self, uri: str, text: str) -> None:
        self.send({"method": "textDocument/didOpen",
                   "params": {"textDocument": {"uri": uri, "languageId": "hila", "version": 1, "text": text}}})

    def diagnostics(self, uri: str, timeout: float = 30) -> list[dict]:
        return self.wait(lambda m: m.get("method") == "textDocument/publishDiagnostics"
                         and m["params"]["uri"] == uri, timeout)["params"]["diagnostics"]

    def finish(self) -> str:
        """shutdown, exit; the exit status must be 0; returns stderr."""
        assert self.request("shutdown", None) == {"jsonrpc": "2.0", "id": self.ids, "result": None}
        self.send({"method": "exit"})
        assert self.proc.wait(timeout=30) == 0
        return self.proc.stderr.read().decode()

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


@pytest.fixture
def server():
    client = Raw()
    yield client
    client.close()


def test_bad_framing_is_skipped_and_logged_and_the_session_goes_on(server):
    server.raw(b'Content-Length: -5\r\n\r\n{"jsonrpc": "2.0", "id": 99, "method": "shutdown"}')
    server.start()
    server.raw(b"abc\r\n\r\n")
    server.request("shutdown-not", None)  # an unknown method: answered, so the stream is in step
    server.raw(b"Content-Length: abc\r\n\r\nnonsense")
    server.request("shutdown-not", None)
    logs = [m["params"]["message"] for m in server.seen if m.get("method") == "window/logMessage"]
    assert "Content-Length must be a number of bytes >= 0" in logs[0] and "'Content-Length: -5'" in logs[0]
    assert "bad message header 'abc': no Content-Length; skipped" in logs
    assert "bad message header 'Content-Length: abc': Content-Length must be a number of bytes >= 0; skipped" in logs
    body = b"{not json"
    server.raw(b"Content-Length: %d\r\n\r\n" % len(body) + body)
    assert server.wait(lambda m: "error" in m)["error"]["code"] == -32700
    assert "Traceback" not in server.finish()


def test_a_request_before_initialize_is_answered_32002(server):
    reply = server.request("textDocument/hover", {"textDocument": {"uri": "file:///x.hila"},
                                                  "position": {"line": 0, "character": 0}})
    assert reply["error"]["code"] == -32002 and "initialize" in reply["error"]["message"]
    server.start()
    assert "Traceback" not in server.finish()


def test_every_position_is_answered(server, tmp_path):
    prog = tmp_path / "game.hila"
    prog.write_text(GAME)
    uri = prog.as_uri()
    server.start()
    server.open(uri, GAME)
    server.diagnostics(uri)
    doc = {"textDocument": {"uri": uri}}
    lines = GAME.split("\n")
    end = {"line": 4, "character": len(lines[4])}  # the end of 'task mark(c) {'
    for method in ("textDocument/hover", "textDocument/definition", "textDocument/completion"):
        for position in ({"line": -1, "character": -1}, end, {"line": 4, "character": 500},
                         {"line": 900, "character": 3}):
            reply = server.request(method, {**doc, "position": position})
            assert "error" not in reply, (method, position, reply)
    hover = server.request("textDocument/hover", {**doc, "position": end})["result"]
    assert hover["contents"]["value"].startswith("**task mark(c)**")  # clamped onto the line's last word
    unopened = {"textDocument": {"uri": (tmp_path / "never-opened.hila").as_uri()}, "position": end}
    assert server.request("textDocument/hover", unopened) == {"jsonrpc": "2.0", "id": server.ids, "result": None}
    assert server.request("textDocument/definition", unopened)["result"] is None
    assert "Traceback" not in server.finish()


def test_a_document_over_the_limit_gets_one_stated_diagnostic_at_once(server, tmp_path):
    server.start()
    big = "main {\n" + "    let x = 1 + 2\n" * 300_000 + "}\n"  # 5.4 MB
    lets = "main {\n" + "".join(f"let v{i} = {i}\n" for i in range(500_001)) + "}\n"
    for name, text in (("big.hila", big), ("lets.hila", lets)):
        uri = (tmp_path / name).as_uri()
        server.open(uri, text)
        (diag,) = server.diagnostics(uri, timeout=20)
        assert f"hila lsp analyses documents of up to {MAX_CHARACTERS:,} characters" in diag["message"]
        assert f"{len(text):,} characters" in diag["message"] and diag["code"] == "too-large"
    small = (tmp_path / "small.hila").as_uri()
    server.open(small, "main { let x = }\n")  # the server is free again: the next document is analysed
    (diag,) = server.diagnostics(small, timeout=20)
    assert diag["message"].startswith("unexpected '}'") and diag["code"] == "syntax"
    assert "Traceback" not in server.finish()


# --------------------------------------------------------------------------- from the tree


def test_path_at_finds_the_innermost_node(monkeypatch):
    monkeypatch.chdir(ROOT)
    doc = Document(str(ROOT / "game.hila"))
    assert doc.analyse(GAME)[0].message == "task 'spare' is never called"
    line = GAME.split("\n").index("        let c = ask best_move") + 1
    path = path_at(doc.items, line, GAME.split("\n")[line - 1].index("best") + 1)
    assert [type(n).__name__ for n in path] == ["MainDef", "UntilStmt", "LetStmt", "Ask"]
    assert path[-1].name == "best_move"
    assert path_at(doc.items, 4, 1) == []  # a blank line holds no node


def test_warnings_are_the_checkers_own_span(monkeypatch):
    monkeypatch.chdir(ROOT)
    (warning,) = Document(str(ROOT / "game.hila")).analyse(GAME)
    assert (warning.severity, warning.code, warning.line, warning.character, warning.end_line,
            warning.end_character) == ("warning", "unused-task", 9, 0, 9, 4)  # 'task' of 'task spare(c) {'



def _pos(text: str, needle: str, offset: int = 0) -> tuple[int, int]:
    index = text.index(needle) + offset
    return text.count("\n", 0, index), index - (text.rfind("\n", 0, index) + 1)


def test_hover_reads_nodes(monkeypatch):
    monkeypatch.chdir(ROOT)
    doc = Document(str(ROOT / "game.hila"))
    doc.analyse(GAME)
    icp = doc.hover(*_pos(GAME, "hand = home", 1))
    assert icp.text.startswith("**ICP hand** of `circle.reach`: template point hand at (")
    assert (icp.character, icp.end_character) == (_pos(GAME, "hand = home")[1], _pos(GAME, "hand = home")[1] + 4)
    point = doc.hover(*_pos(GAME, "= home", 3))
    assert point.text == "**point home** = `(0.18, -0.25, 0.75)` (line 3)"
    assert doc.hover(*_pos(GAME, "world tictactoe", 8)).text.startswith("**world tictactoe**")
    assert doc.definition(*_pos(GAME, "= home", 3)).line == 2


def test_completion_keeps_what_begins_with_the_word_typed(monkeypatch):
    monkeypatch.chdir(ROOT)
    doc = Document(str(ROOT / "game.hila"))
    typing = GAME.replace("let c = ask best_move", "let c = ask be")
    doc.analyse(typing)
    assert [c.label for c in doc.completion(*_pos(typing, "ask be", 6))] == ["best_move", "best_cell"]
    typing = GAME.replace("run circle.draw(", "run circle.re")
    doc.analyse(typing)
    assert [c.label for c in doc.completion(*_pos(typing, "circle.re", 9))] == ["reach", "retract"]
    typing = GAME.replace("hand = home, start", "ha")
    doc.analyse(typing)
    assert [c.label for c in doc.completion(*_pos(typing, "c.*, ha", 7))] == ["hand"]
    assert {c.label for c in doc.completion(*_pos(typing, "c.*, ha", 5))} >= {"tl", "hand", "start"}
    labels = [c.label for c in doc.completion(*_pos(GAME, "    mark(c)\n    }", 6))]
    assert labels == ["main", "mark"]  # the keyword and the task that begin with 'ma'
    typing = GAME.replace("run circle.draw(", "run circ")
    doc.analyse(typing)
    assert [(c.label, c.kind) for c in doc.completion(*_pos(typing, "run circ", 8))] == [("circle", "template")]
    typing = GAME.replace("until ask", "until as")
    doc.analyse(typing)
    assert [c.label for c in doc.completion(*_pos(typing, "until as", 8))] == ["as", "ask"]


def test_keywords_are_the_grammars():
    from hila_lang.language.environment import Environment

    words = Environment.default().keywords
    assert isinstance(words, tuple) and "until" in words and "radius" in words
    node = A.Ask("q")
    assert A.children(node) == []
