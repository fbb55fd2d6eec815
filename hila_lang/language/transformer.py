"""lark tree -> AST (:mod:`hila_lang.language.ast`); the only place that reads ``Tree.children``."""

from __future__ import annotations

import re

from lark import Token, Transformer, v_args
from lark.exceptions import VisitError

from . import ast as A
from ..errors import HilaError, HilaSyntaxError
from .parser import parse_text, source_line


def _pos(meta) -> A.Pos:
    if getattr(meta, "empty", True):
        return A.NOPOS
    return A.Pos(meta.line, meta.column, meta.end_line, meta.end_column)


def _tpos(tok: Token) -> A.Pos:
    return A.Pos(tok.line, tok.column, tok.end_line, tok.end_column)


def _unquote(tok: Token) -> str:
    return str(tok)[1:-1]


def _items(children) -> tuple:
    return tuple(c for c in children if c is not None and not isinstance(c, Token))


@v_args(meta=True)
class ToAst(Transformer):
    """Builds the frozen dataclasses bottom-up."""

    # ---- expressions
    def number(self, meta, ch):
        return A.Number(float(ch[0]), _pos(meta))

    def string(self, meta, ch):
        return A.String(_unquote(ch[0]), _pos(meta))

    def true(self, meta, ch):
        return A.Bool(True, _pos(meta))

    def false(self, meta, ch):
        return A.Bool(False, _pos(meta))

    def none(self, meta, ch):
        return A.NoneLit(_pos(meta))

    def dotted(self, meta, ch):
        return A.Name(tuple(str(t) for t in ch), _pos(meta))

    def name(self, meta, ch):
        return ch[0]

    def vector(self, meta, ch):
        return A.Vector(tuple(c for c in ch if c is not None), _pos(meta))

    def not_op(self, meta, ch):
        return A.Unary("not", ch[0], _pos(meta))

    def neg(self, meta, ch):
        if isinstance(ch[0], A.Number):  # fold -2.5 into a literal
            return A.Number(-ch[0].value, _pos(meta))
        return A.Unary("-", ch[0], _pos(meta))

    def _chain(self, meta, ch, op=None):
        result = ch[0]
        i = 1
        while i < len(ch):
            if isinstance(ch[i], Token):
                operator, right, i = str(ch[i]), ch[i + 1], i + 2
            else:
                operator, right, i = op, ch[i], i + 1
            result = A.Binary(operator, result, right, _pos(meta))
        return result

    def or_expr(self, meta, ch):
        return self._chain(meta, ch, "or")

    def and_expr(self, meta, ch):
        return self._chain(meta, ch, "and")

    compare = sum = product = _chain

    def args(self, meta, ch):
        return tuple(c for c in ch if c is not None)

    def ask(self, meta, ch):
        return A.Ask(str(ch[0]), ch[1] or (), _pos(meta))

    def wait_expr(self, meta, ch):
        return A.Wait(str(ch[0]), ch[1] or (), _pos(meta))

    # ---- statements
    def block(self, meta, ch):
        return _items(ch)

    def binding(self, meta, ch):
        return A.Binding(ch[0].text, ch[1], _pos(meta))

    def spread(self, meta, ch):
        return A.Binding(A.SPREAD, ch[0], _pos(meta))

    def bindings(self, meta, ch):
        return tuple(c for c in ch if c is not None)

    def pen(self, meta, ch):
        return str(ch[0])

    def constraint(self, meta, ch):
        kind, value, radius = ch
        return A.Constraint(str(kind), value, radius, _pos(meta))

    def run_stmt(self, meta, ch):
        ref, bindings, pen, *constraints = ch
        template, tag = ref.parts[0], (".".join(ref.parts[1:]) or None)
        return A.RunStmt(template, tag, bindings or (), pen, _pos(meta), ref.pos, tuple(constraints))

    def call_stmt(self, meta, ch):
        name, args, *constraints = ch
        return A.CallStmt(str(name), args or (), _pos(meta), tuple(constraints))

    def let_stmt(self, meta, ch):
        return A.LetStmt(str(ch[0]), ch[1], _pos(meta))

    def wait_stmt(self, meta, ch):
        return A.WaitStmt(ch[0], _pos(meta))

    def elif_clause(self, meta, ch):
        return (ch[0], ch[1])

    def else_clause(self, meta, ch):
        return ch[0]

    def if_stmt(self, meta, ch):
        branches = [(ch[0], ch[1])]
        orelse = None
        for c in ch[2:]:
            if isinstance(c, tuple) and len(c) == 2 and not isinstance(c[0], tuple) and _is_expr(c[0]):
                branches.append(c)
            elif c is not None:
                orelse = c
        return A.IfStmt(tuple(branches), orelse, _pos(meta))

    def while_stmt(self, meta, ch):
        return A.WhileStmt(ch[0], ch[1], _pos(meta))

    def until_stmt(self, meta, ch):
        return A.UntilStmt(ch[0], ch[1], _pos(meta))

    def repeat_stmt(self, meta, ch):
        return A.RepeatStmt(ch[0], ch[1], _pos(meta))

    # ---- top level
    def world_decl(self, meta, ch):
        return A.WorldDecl(str(ch[0]), _pos(meta))

    def import_decl(self, meta, ch):
        src, alias = ch
        if src.type == "STRING":
            path = _unquote(src)
            if alias is None:
                from pathlib import PurePath

                alias_text = PurePath(path).stem
            else:
                alias_text = str(alias)
            return A.ImportDecl(path, alias_text, True, _pos(meta))
        return A.ImportDecl(str(src), str(alias or src), False, _pos(meta))

    def point_decl(self, meta, ch):
        return A.PointDecl(ch[0].text, ch[1], _pos(meta))

    def hand_decl(self, meta, ch):
        return A.HandDecl(ch[0], _pos(meta))

    def params(self, meta, ch):
        return tuple(ch)

    def task_def(self, meta, ch):
        name, params, body = ch
        params = params or ()
        return A.TaskDef(str(name), tuple(str(p) for p in params), body, _pos(meta),
                         tuple(_tpos(p) for p in params))

    def main_def(self, meta, ch):
        return A.MainDef(ch[0], _pos(meta))

    def start(self, meta, ch):
        return _items(ch)


_EXPR_TYPES = (A.Number, A.String, A.Bool, A.NoneLit, A.Name, A.Vector, A.Unary, A.Binary, A.Ask)


def _is_expr(x) -> bool:
    return isinstance(x, _EXPR_TYPES)


def to_ast(tree, text: str = "", file: str = "<program>") -> A.Program:
    """Transform a parse tree to a :class:`~hila_lang.language.ast.Program` (VisitError unwrapped)."""
    try:
        items = ToAst().transform(tree)
    except VisitError as exc:
        inner = exc.orig_exc
        if isinstance(inner, (HilaError, RecursionError)):
            raise inner from None
        raise
    return A.Program(items, file, text)


_SLOT_OR_STRING = re.compile(r'"[^"\n]*"|\{([^{}"]*)\}')


def parse_expr(text: str):
    """Expression text as :func:`~hila_lang.language.ast.expr_text` writes it -> the expression.

    Variables written as slots (``{main/mark:c}.tl``) come back as
    :class:`~hila_lang.language.ast.Var`; anything that is not one expression is a
    :class:`HilaSyntaxError`.
    """
    from .parser import expr_parser

    slots: dict[str, str] = {}

    def placeholder(m):
        if m.group(1) is None:  # a string literal: left as it is
            return m.group(0)
        key = f"__slot{len(slots)}__"
        slots[key] = m.group(1)
        return key

    source = _SLOT_OR_STRING.sub(placeholder, text)
    from lark.exceptions import UnexpectedInput

    try:
        tree = expr_parser().parse(source)
    except UnexpectedInput as exc:
        raise HilaSyntaxError(f"not an expression: {text!r}", line=getattr(exc, "line", None),
                              column=getattr(exc, "column", None)) from None
    e = ToAst().transform(tree)
    return A.map_names(e, lambda n: A.Var(slots[n.parts[0]], n.parts[1:], n.pos) if n.parts[0] in slots else n)


#: deepest parse tree accepted (an ``if`` inside an ``if`` adds two levels, a parenthesis one or two)
MAX_DEPTH = 300


def _too_deep(tree):
    """The first tree node deeper than :data:`MAX_DEPTH`, or None (iterative: no recursion)."""
    from lark import Tree

    stack = [(tree, 1)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_DEPTH:
            return node
        stack.extend((c, depth + 1) for c in node.children if isinstance(c, Tree))
    return None


def parse_program(text: str, file: str = "<program>") -> A.Program:
    """Text -> AST in one call; any failure is a :class:`HilaSyntaxError` with line and column.

    Nesting deeper than :data:`MAX_DEPTH` tree levels is refused here, so no later stage
    (checker, compiler, interpreter, all recursive) can run out of stack.
    """
    tree = parse_text(text, file)
    deep = _too_deep(tree)
    if deep is not None:
        line = getattr(deep.meta, "line", 1) if not getattr(deep.meta, "empty", True) else 1
        column = getattr(deep.meta, "column", 1) if not getattr(deep.meta, "empty", True) else 1
        raise HilaSyntaxError(
            f"the program nests too deeply (more than {MAX_DEPTH} levels of blocks and parentheses)",
            file=file, line=line, column=column, source_line=source_line(text, line),
            hint="split it into tasks",
        )
    try:
        return to_ast(tree, text, file)
    except RecursionError:  # pragma: no cover - MAX_DEPTH keeps well inside the stack
        raise HilaSyntaxError("the program nests too deeply", file=file, line=1, column=1,
                              source_line=source_line(text, 1)) from None
