"""The Language Server Protocol over stdio with pygls: ``hila lsp``.

Diagnostics as you type (``didOpen``, ``didChange``, ``didSave``: the errors ``hila check``
reports, at the same place), hover, go to definition and completion, all answered by
:class:`hila_lang.lsp.analysis.Document`.  Templates saved while the server runs are picked up
(they are cached by modification time).

What an editor may send, the server survives (:func:`serve` reads the stream itself,
:mod:`.framing`): a bad header (``Content-Length: -5``, ``abc``) is skipped and logged, bad JSON
is answered -32700, a request before ``initialize`` -32002, one after ``shutdown`` -32600; a
position outside the text (``(-1, -1)``, past the end of a line) is moved to the nearest place
in it.  Everything the server logs goes to the client (``window/logMessage``), not to stderr.
"""

from __future__ import annotations

import asyncio
import json
import logging
import sys

from lsprotocol import types as T
from pygls.io_ import StdoutWriter
from pygls.lsp.server import LanguageServer
from pygls.uris import from_fs_path

from .. import __version__
from ..language.environment import Environment
from .analysis import Document
from .framing import Framing

_KINDS = {"tag": T.CompletionItemKind.Function, "icp": T.CompletionItemKind.Field,
          "question": T.CompletionItemKind.Value, "event": T.CompletionItemKind.Event,
          "task": T.CompletionItemKind.Method, "template": T.CompletionItemKind.Module,
          "point": T.CompletionItemKind.Constant, "keyword": T.CompletionItemKind.Keyword}


class HilaServer(LanguageServer):
    def __init__(self) -> None:
        super().__init__("hila", __version__)
        self.env = Environment()  # one grammar, one template cache for the session
        self.documents: dict[str, Document] = {}
        self.started = False  # 'initialize' received
        self.early_logs: list[tuple[str, int]] = []  # said before it
        self.stopping = False  # 'shutdown' received

    def document(self, uri: str, *, again: bool = False) -> Document:
        """The analysis of the document's current text (``again``: even if the text is the same,
        e.g. on save, when an imported template may have changed).  A document the editor has not
        opened is empty here (its requests are answered with nothing found)."""
        if uri not in self.workspace.text_documents:
            return Document(uri, self.env)
        text_doc = self.workspace.get_text_document(uri)
        doc = self.documents.get(uri)
        if doc is None:
            doc = self.documents[uri] = Document(text_doc.path, self.env)
            again = True
        if again or doc.text != text_doc.source:
            doc.analyse(text_doc.source)
        return doc

    def publish(self, uri: str, *, again: bool = False) -> None:
        text_doc = self.workspace.get_text_document(uri)
        doc = self.document(uri, again=again)
        diagnostics = [
            T.Diagnostic(
                range=T.Range(T.Position(p.line, p.character), T.Position(p.end_line, p.end_character)),
                message=p.message, source="hila", code=p.code,
                severity={"error": T.DiagnosticSeverity.Error, "note": T.DiagnosticSeverity.Information}.get(
                    p.severity, T.DiagnosticSeverity.Warning))
            for p in doc.problems]
        self.text_document_publish_diagnostics(
            T.PublishDiagnosticsParams(uri=uri, diagnostics=diagnostics, version=text_doc.version))

    # ------------------------------------------------------------------ the stream
    def log(self, message: str, level: int = logging.WARNING) -> None:
        """Say ``message`` to the client (``window/logMessage``; kept until ``initialize`` has been
        answered, as the protocol asks)."""
        if not self.started:
            if len(self.early_logs) < 100:  # a client sending garbage forever costs no memory
                self.early_logs.append((message, level))
            return
        kind = T.MessageType.Error if level >= logging.ERROR else (
            T.MessageType.Warning if level >= logging.WARNING else T.MessageType.Info)
        self.window_log_message(T.LogMessageParams(type=kind, message=message))

    def send_error(self, rid, code: int, message: str) -> None:
        """A JSON-RPC error response written directly (for messages pygls never sees)."""
        body = json.dumps({"jsonrpc": "2.0", "id": rid, "error": {"code": code, "message": message}}).encode()
        self.protocol.writer.write(b"Content-Length: %d\r\n\r\n" % len(body) + body)

    def receive(self, body: bytes) -> None:
        """One message body from the stream: checked, its positions clamped, then handled."""
        try:
            raw = json.loads(body)
        except (ValueError, RecursionError) as exc:
            self.log(f"a message that is not JSON was answered 'parse error': {str(exc)[:200]}")
            self.send_error(None, -32700, "parse error: the message is not JSON")
            return
        if not isinstance(raw, dict) or not isinstance(raw.get("method", ""), str):
            self.log("a message that is not a JSON-RPC object was ignored")
            self.send_error(raw.get("id") if isinstance(raw, dict) else None, -32600, "invalid request")
            return
        method, rid = raw.get("method"), raw.get("id")
        is_request = method is not None and "id" in raw
        if method is not None and not self.started and method not in ("initialize", "exit"):
            if is_request:
                self.send_error(rid, -32002, f"the server is not initialized: send 'initialize' before '{method}'")
            return  # notifications before initialize are dropped (the protocol says so)
        if is_request and self.stopping and method != "exit":
            self.send_error(rid, -32600, f"the server is shutting down: '{method}' refused")
            return
        _clamp_positions(raw.get("params"))
        try:
            message = json.loads(json.dumps(raw), object_hook=self.protocol.structure_message)
        except Exception as exc:  # noqa: BLE001 - params the protocol types refuse
            self.log(f"'{method}' with parameters the protocol does not allow: {exc}")
            if is_request:
                self.send_error(rid, -32602, f"invalid parameters for '{method}'")
            return
        if method == "shutdown":
            self.stopping = True
        try:
            self.protocol.handle_message(message)
        except Exception as exc:  # noqa: BLE001 - a failed handler must not end the session
            self.log(f"'{method}' failed: {type(exc).__name__}: {exc}", logging.ERROR)
            if is_request:
                self.send_error(rid, -32603, f"internal error in '{method}'")
        if method == "initialize" and not self.started:
            self.started = True
            for said in self.early_logs:
                self.log(*said)
            self.early_logs.clear()


def _clamp_positions(params) -> None:
    """Negative ``line``/``character`` of every position in ``params`` raised to 0 (in place): the
    protocol's types refuse them, and an editor may still send them."""
    stack = [params]
    while stack:
        node = stack.pop()
        if isinstance(node, dict):
            for key in ("line", "character"):
                if key in node and isinstance(node[key], int) and node[key] < 0 and len(node) <= 2:
                    node[key] = 0
            stack.extend(v for v in node.values() if isinstance(v, (dict, list)))
        elif isinstance(node, list):
            stack.extend(v for v in node if isinstance(v, (dict, list)))


class _ToClient(logging.Handler):
    """Log records (pygls's and hila's) sent to the client as ``window/logMessage``."""

    def __init__(self, server: HilaServer) -> None:
        super().__init__(logging.WARNING)
        self.server = server
        self.busy = False

    def emit(self, record: logging.LogRecord) -> None:
        if self.busy or self.server.protocol.writer is None:
            return
        self.busy = True  # a failure while sending is not logged again
        try:
            self.server.log(record.getMessage(), record.levelno)
        except Exception:  # noqa: BLE001 - the client is gone: nothing to tell
            pass
        finally:
            self.busy = False


def make_server() -> HilaServer:
    server = HilaServer()

    @server.feature(T.TEXT_DOCUMENT_DID_OPEN)
    def did_open(ls: HilaServer, params: T.DidOpenTextDocumentParams) -> None:
        ls.publish(params.text_document.uri)

    @server.feature(T.TEXT_DOCUMENT_DID_CHANGE)
    def did_change(ls: HilaServer, params: T.DidChangeTextDocumentParams) -> None:
        ls.publish(params.text_document.uri)

    @server.feature(T.TEXT_DOCUMENT_DID_SAVE)
    def did_save(ls: HilaServer, params: T.DidSaveTextDocumentParams) -> None:
        ls.publish(params.text_document.uri, again=True)

    @server.feature(T.TEXT_DOCUMENT_DID_CLOSE)
    def did_close(ls: HilaServer, params: T.DidCloseTextDocumentParams) -> None:
        ls.documents.pop(params.text_document.uri, None)
        ls.text_document_publish_diagnostics(T.PublishDiagnosticsParams(uri=params.text_document.uri, diagnostics=[]))

    @server.feature(T.TEXT_DOCUMENT_HOVER)
    def hover(ls: HilaServer, params: T.HoverParams) -> T.Hover | None:
        found = ls.document(params.text_document.uri).hover(params.position.line, params.position.character)
        if found is None:
            return None
        return T.Hover(contents=T.MarkupContent(kind=T.MarkupKind.Markdown, value=found.text),
                       range=T.Range(T.Position(found.line, found.character), T.Position(found.line, found.end_character)))

    @server.feature(T.TEXT_DOCUMENT_DEFINITION)
    def definition(ls: HilaServer, params: T.DefinitionParams) -> T.Location | None:
        found = ls.document(params.text_document.uri).definition(params.position.line, params.position.character)
        if found is None:
            return None

        at = T.Position(found.line, found.character)
        return T.Location(uri=from_fs_path(found.path), range=T.Range(at, at))

    @server.feature(T.TEXT_DOCUMENT_COMPLETION, T.CompletionOptions(trigger_characters=[".", "(", ",", " "]))
    def completion(ls: HilaServer, params: T.CompletionParams) -> T.CompletionList:
        items = ls.document(params.text_document.uri).completion(params.position.line, params.position.character)
        return T.CompletionList(is_incomplete=False, items=[
            T.CompletionItem(label=c.label, kind=_KINDS.get(c.kind), detail=c.detail or None,
                             insert_text=c.insert) for c in items])

    return server


def serve(stdin=None, stdout=None) -> None:
    """Serve on stdin/stdout (binary streams) until the client says exit or closes the stream."""
    server = make_server()
    server.protocol.set_writer(StdoutWriter(stdout or sys.stdout.buffer))
    root = logging.getLogger()
    handler = _ToClient(server)
    root.addHandler(handler)  # nothing the server logs reaches stderr
    framing = Framing(stdin or sys.stdin.buffer)

    async def loop() -> None:
        running = asyncio.get_running_loop()
        while True:
            item = await running.run_in_executor(None, framing.next)
            if item is None:
                return
            body, problem = item
            if problem is not None:
                server.log(problem)
            else:
                server.receive(body)

    try:
        asyncio.run(loop())
    except BrokenPipeError:
        pass  # the client went away
    finally:
        root.removeHandler(handler)
        server.shutdown()
