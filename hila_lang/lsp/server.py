"""The Language Server Protocol over stdio with pygls: ``hila lsp``.

Diagnostics as you type (``didOpen``, ``didChange``, ``didSave``: the errors ``hila check``
reports, at the same place), hover, go to definition and completion, all answered by
:class:`hila_lang.lsp.analysis.Document`.  Templates saved while the server runs are picked up
(they are cached by modification time).
"""

from __future__ import annotations

from lsprotocol import types as T
from pygls.lsp.server import LanguageServer

from .. import __version__
from ..language.environment import Environment
from .analysis import Document

_KINDS = {"tag": T.CompletionItemKind.Function, "icp": T.CompletionItemKind.Field,
          "question": T.CompletionItemKind.Value, "event": T.CompletionItemKind.Event,
          "task": T.CompletionItemKind.Method, "point": T.CompletionItemKind.Constant,
          "keyword": T.CompletionItemKind.Keyword}


class HilaServer(LanguageServer):
    def __init__(self) -> None:
        super().__init__("hila", __version__)
        self.env = Environment()  # one grammar, one template cache for the session
        self.documents: dict[str, Document] = {}

    def document(self, uri: str, *, again: bool = False) -> Document:
        """The analysis of the document's current text (``again``: even if the text is the same,
        e.g. on save, when an imported template may have changed)."""
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
                message=p.message, source="hila",
                severity=T.DiagnosticSeverity.Error if p.severity == "error" else T.DiagnosticSeverity.Warning)
            for p in doc.problems]
        self.text_document_publish_diagnostics(
            T.PublishDiagnosticsParams(uri=uri, diagnostics=diagnostics, version=text_doc.version))


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
        from pygls.uris import from_fs_path

        at = T.Position(found.line, found.character)
        return T.Location(uri=from_fs_path(found.path), range=T.Range(at, at))

    @server.feature(T.TEXT_DOCUMENT_COMPLETION, T.CompletionOptions(trigger_characters=[".", "(", ",", " "]))
    def completion(ls: HilaServer, params: T.CompletionParams) -> T.CompletionList:
        items = ls.document(params.text_document.uri).completion(params.position.line, params.position.character)
        return T.CompletionList(is_incomplete=False, items=[
            T.CompletionItem(label=c.label, kind=_KINDS.get(c.kind), detail=c.detail or None,
                             insert_text=c.insert) for c in items])

    return server


def serve() -> None:
    """Serve on stdin/stdout until the client says exit."""
    make_server().start_io()
