"""Text -> AST (:mod:`hila_lang.language.ast`): the grammar's one parser (:func:`grammar`), which
builds the AST while parsing, and the ``ToAst`` rules it builds with; the only place that reads
a rule's children."""

from __future__ import annotations

import functools
import re
from dataclasses import replace

import lark as lark_module
from lark import Lark, Token, Transformer, Tree, v_args
from lark.exceptions import UnexpectedInput, VisitError

from ..core.errors import HilaError, HilaSyntaxError
from ..core.resources import grammar_path
from . import ast as A
from . import parsecache
from .limits import MAX_NESTING
from .source import source_line, syntax_error


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


class ToAst(Transformer):
    """Builds the frozen dataclasses bottom-up.  A statement registered with
    :func:`hila_lang.language.ast.statement` and no method here is built by :func:`_generic` (its
    fields are its rule's children: ``let``, ``wait``, ``while``, ``until``, ``repeat``); ``run``,
    ``call`` and ``if`` have methods, their children needing more than that."""

    # ---- expressions
    def number(self, meta, ch):
        value = float(ch[0])
        if value in (float("inf"), float("-inf")):  # 1e309: too large for a float (issue 20)
            raise HilaSyntaxError(f"the number {ch[0]} is too large (more than {1.7976931348623157e308:g})",
                                  line=meta.line, column=meta.column)
        return A.Number(value, _pos(meta))

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

    def paren(self, meta, ch):  # ( expr ): the expression, spanning its brackets
        e = ch[0]
        pos = _pos(meta)
        return replace(e, pos=pos) if pos.line else e

    def expr(self, meta, ch):
        return _precedence(ch)

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

    def track_option(self, meta, ch):
        kind, number = ch
        return A.TrackOption(str(kind), float(number), _pos(meta))

    def track(self, meta, ch):
        names = tuple(c for c in ch if isinstance(c, A.Name))
        return A.Track(names, tuple(c for c in ch if isinstance(c, A.TrackOption)), _pos(meta))

    def run_stmt(self, meta, ch):
        ref, bindings, pen, *constraints, track = ch
        template, tag = ref.parts[0], (".".join(ref.parts[1:]) or None)
        return A.RunStmt(template, tag, bindings or (), pen, _pos(meta), ref.pos, tuple(constraints), track)

    def call_stmt(self, meta, ch):
        name, args, *constraints = ch
        return A.CallStmt(str(name), args or (), _pos(meta), tuple(constraints))

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

    # ---- top level
    def world_decl(self, meta, ch):
        return A.WorldDecl(str(ch[0]), _pos(meta))

    def import_decl(self, meta, ch):
        src, alias = ch
        if src.type == "STRING":
            path = _unquote(src)
            if alias is None:
                # lazy: only this branch needs it
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


# --------------------------------------------------------------------------- expressions by precedence
#
# The grammar reads an expression flat (``_operand (_binop _operand)*``, each operand with its
# 'not' and '-' prefixes); :func:`_precedence` builds the tree, level by level, loosest first.  A
# node spans what its grammar level would have spanned: every operator of a chain at one level
# spans the whole chain (``a + b + c``: both '+'), a prefix from its token to the end of what it
# applies to.  Nothing recurses with the length of the expression.

_LOOSE = ("OR", "AND")  # 'not' may follow these


def _precedence(ch):
    operands, ops, i = [], [], 0  # operands: [nots, value]; ops: the tokens between them
    while i < len(ch):
        nots, negs = [], []
        while isinstance(ch[i], Token) and ch[i].type == "NOT":
            nots.append(ch[i])
            i += 1
        while isinstance(ch[i], Token) and ch[i].type == "NEG":
            negs.append(ch[i])
            i += 1
        value = ch[i]
        for tok in reversed(negs):  # innermost first; -2.5 folds into a literal
            pos = A.Pos(tok.line, tok.column, value.pos.end_line, value.pos.end_column)
            value = A.Number(-value.value, pos) if isinstance(value, A.Number) else A.Unary("-", value, pos)
        if nots and ops and ops[-1].type not in _LOOSE:
            raise HilaSyntaxError(f"'not' cannot follow '{ops[-1]}' (it applies to a whole comparison): "
                                  f"put it in brackets, '{ops[-1]} (not ...)'", line=nots[0].line, column=nots[0].column)
        operands.append((nots, value))
        i += 1
        if i < len(ch):
            ops.append(ch[i])
            i += 1
    return _level(operands, ops, 0, len(operands) - 1, 0)


#: the binary levels, loosest first, with where 'not' stands among them
_LEVELS = (("OR",), ("AND",), "not", ("COMPARE",), ("ADD_OP",), ("MUL_OP",))


def _level(operands, ops, lo: int, hi: int, level: int):
    """The expression of operands ``lo..hi`` (and the ``ops`` between them) from ``level`` down."""
    while True:
        if level == len(_LEVELS):
            return operands[lo][1]
        kind = _LEVELS[level]
        if kind == "not":
            nots = operands[lo][0]
            if not nots:
                level += 1
                continue
            inner = _level(operands, ops, lo, hi, level + 1)
            end = operands[hi][1].pos
            for tok in reversed(nots):
                inner = A.Unary("not", inner, A.Pos(tok.line, tok.column, end.end_line, end.end_column))
            return inner
        cuts = [k for k in range(lo, hi) if ops[k].type in kind]
        if not cuts:
            level += 1
            continue
        if kind == ("COMPARE",) and len(cuts) > 1:
            second = ops[cuts[1]]
            raise HilaSyntaxError(f"comparisons do not chain: write 'a {ops[cuts[0]]} b and b {second} c'",
                                  line=second.line, column=second.column)
        first = operands[lo]
        # a chain's span: from its first operand ('not's included above the comparison level) to its last
        head = first[0][0] if first[0] and level < _LEVELS.index("not") else first[1].pos
        end = operands[hi][1].pos
        pos = A.Pos(head.line, head.column, end.end_line, end.end_column)
        bounds = [lo, *(k + 1 for k in cuts), hi + 1]
        result = _level(operands, ops, bounds[0], bounds[1] - 1, level + 1)
        for k, a, b in zip(cuts, bounds[1:], bounds[2:]):
            result = A.Binary(str(ops[k]), result, _level(operands, ops, a, b - 1, level + 1), pos)
        return result


def _generic(cls):
    """The rule method of statement class ``cls``: its fields are the rule's children in order (a
    token as its text), then ``pos``."""
    def build(self, meta, ch):
        return cls(*(str(c) if isinstance(c, Token) else c for c in ch), pos=_pos(meta))

    return build


def _with_statement_rules(cls):
    """``cls`` with a :func:`_generic` method for every registered statement rule it has no method for."""
    for rule, statement in A.RULES.items():
        if not hasattr(cls, rule):
            setattr(cls, rule, _generic(statement))
    return cls


ToAst = v_args(meta=True)(_with_statement_rules(ToAst))


_EXPR_TYPES = (A.Number, A.String, A.Bool, A.NoneLit, A.Name, A.Vector, A.Unary, A.Binary, A.Ask)


def _is_expr(x) -> bool:
    return isinstance(x, _EXPR_TYPES)


def to_ast(tree, text: str = "", file: str = "<program>") -> A.Program:
    """Transform a lark parse tree to a :class:`~hila_lang.language.ast.Program` (VisitError
    unwrapped): the reference path, a tree walk, for a tree from a plain tree parser of the
    grammar (the tests and ``bench/parse.py`` build one).  :func:`parse_program` builds the same
    AST while parsing, and ``tests/test_lang_limits.py`` holds the two equal.
    """
    try:
        items = ToAst().transform(tree)
    except VisitError as exc:
        inner = exc.orig_exc
        if isinstance(inner, (HilaError, RecursionError)):
            raise inner from None
        raise
    return A.Program(items, file, text)


# --------------------------------------------------------------------------- parsing to the AST
#
# The LALR parser calls a rule's callback as it reduces the rule, so the AST can be built while
# parsing: no lark tree is ever held whole, and nothing recurses however deep the program nests.
# lark refuses ``v_args(meta=True)`` callbacks during parsing, because a rule's span can include
# keywords and brackets its callback never sees (a ``run`` statement starts at ``run``); lark's
# public ``propagate_positions`` works it out from the raw children after the callback returns,
# and writes it into the meta of the tree the callback returned.  So:
#
# - a rule that may start or end with a dropped keyword or bracket (``run_stmt``, ``block``,
#   ``vector``, ``paren`` ...) returns a one-level :class:`_Node` (a ``Tree`` holding the ``ToAst``
#   method and its children's values); lark fills in its meta, and the parent's callback -- or
#   :func:`parse_items` for the root -- builds the AST node from the two;
# - a rule whose first and last children are always kept (``dotted``, ``sum``, ``number`` ...;
#   worked out from the grammar's rules once, :meth:`Streaming.learn`) is spanned by them, so its
#   AST node is built at once and handed up as a :class:`_Span`, which lark reads through the
#   public ``__lark_meta__`` hook (no tree, and nothing for lark to do on the way up).
#
# lark's own child filter still drops keywords and inserts ``None`` for an absent ``[optional]``
# before a ``ToAst`` method sees the children, so ``ToAst`` is the same for both paths, and
# ``tests/test_lang_limits.py`` holds the result equal to the tree walk's, positions included.


class _Node(Tree):
    """A rule just reduced: ``build(meta, values)`` makes its AST node once lark has set its meta."""

    def __init__(self, name: str, build, values: list) -> None:
        super().__init__(name, values)
        self.build = build


class _Span:
    """A rule's AST value with the span it came from, for a rule whose first and last children are
    never a dropped keyword or bracket (so its children give its span): built at once, no tree.
    lark's ``propagate_positions`` reads its span through ``__lark_meta__``."""

    __slots__ = ("value", "line", "column", "start_pos", "end_line", "end_column", "end_pos")
    empty = False

    def __lark_meta__(self):
        return self


def _edges(c):
    """(line, column, start_pos, end_line, end_column, end_pos) of a positioned child, as lark's
    propagate_positions reads it (a container's span when it has one); None for a placeholder."""
    t = type(c)
    if t is _Span or t is Token:
        return c
    if t is _Node:
        m = c.meta
        return None if m.empty else _Container(m)
    return None


class _Container:
    __slots__ = ("line", "column", "start_pos", "end_line", "end_column", "end_pos")

    def __init__(self, m) -> None:
        self.line = getattr(m, "container_line", m.line)
        self.column = getattr(m, "container_column", m.column)
        self.start_pos = getattr(m, "container_start_pos", m.start_pos)
        self.end_line = getattr(m, "container_end_line", m.end_line)
        self.end_column = getattr(m, "container_end_column", m.end_column)
        self.end_pos = getattr(m, "container_end_pos", m.end_pos)


class Streaming(Transformer):
    """The ``ToAst`` methods as lark's in-parse callbacks (one attribute per rule, see above);
    what :func:`grammar` is built with.  :meth:`learn` tells each callback, from the grammar's
    rules, whether its rule spans its own children (:class:`_Span`) or needs lark's positions
    (:class:`_Node`)."""

    def __init__(self) -> None:
        builder = ToAst()
        self.spans_itself: dict[str, bool] = {}
        for name, member in vars(ToAst).items():
            if not name.startswith("_") and callable(member):
                setattr(self, name, self._reducer(name, getattr(builder, name)))

    def learn(self, rules) -> None:
        """Which callbacks' rules always start and end with a kept child (see :func:`_kept_edge`)."""
        by_origin: dict[str, list] = {}
        for r in rules:
            by_origin.setdefault(r.origin.name, []).append(r)
        memo: dict = {}
        names: dict[str, bool] = {}
        for r in rules:
            name = r.alias or r.options.template_source or r.origin.name
            ok = bool(r.expansion) and _kept_edge(r.expansion[0], 0, by_origin, memo) and \
                _kept_edge(r.expansion[-1], -1, by_origin, memo)
            names[name] = names.get(name, True) and ok
        self.spans_itself.update(names)

    def _reducer(self, name: str, method):
        node, span, edges, modes = _Node, _Span, _edges, self.spans_itself

        def reduce(children):  # runs once per rule reduced: kept small
            values = [c.value if type(c) is span else c.build(c.meta, c.children) if type(c) is node else c
                      for c in children]
            if not modes.get(name):
                return node(name, method, values)
            first = last = None
            for c in children:
                first = edges(c)
                if first is not None:
                    break
            for c in reversed(children):
                last = edges(c)
                if last is not None:
                    break
            if first is None:
                return node(name, method, values)
            out = span()
            out.line, out.column, out.start_pos = first.line, first.column, first.start_pos
            out.end_line, out.end_column, out.end_pos = last.end_line, last.end_column, last.end_pos
            out.value = method(out, values)
            return out

        return reduce


def _kept_edge(symbol, which: int, by_origin, memo) -> bool:
    """Whether ``symbol``, at the start (``which`` 0) or end (-1) of an expansion, always gives the
    rule a positioned child there: a kept terminal, a rule of its own, or an inlined ``_rule`` all
    of whose expansions do (a dropped keyword or bracket does not)."""
    if symbol.is_term:
        return not symbol.filter_out
    if not symbol.name.startswith("_"):
        return True
    key = (symbol.name, which)
    if key not in memo:
        memo[key] = True  # a rule that recurses on this edge: its other expansions decide
        memo[key] = all(r.expansion and _kept_edge(r.expansion[which], which, by_origin, memo)
                        for r in by_origin.get(symbol.name, ()))
    return memo[key]


def _value(child):
    t = type(child)
    if t is _Span:
        return child.value
    return child.build(child.meta, child.children) if t is _Node else child


#: how :func:`grammar` builds the parser (LALR, positions kept; a program or one expression)
PARSER_OPTIONS = {"parser": "lalr", "start": ["start", "expr"], "propagate_positions": True, "maybe_placeholders": True}


@functools.lru_cache(maxsize=1)
def grammar():
    """THE lark parser of ``grammar/hila.lark`` (LALR, positions kept), loaded once per process:
    the only ``Lark`` construction in hila (:class:`~hila_lang.language.environment.Environment`
    owns it).  Its parses return AST nodes, not trees (see the comment above); it starts at
    ``start`` (a program) or ``expr`` (one expression).  A ``lark`` module older than 1.0 (the
    ``lark-parser`` 0.12 that ROS 2's message wheels pull in installs one over lark 1.x) is
    refused with how to put lark 1.x back."""
    version = getattr(lark_module, "__version__", "0")
    if not version.split(".")[0].isdigit() or int(version.split(".")[0]) < 1:
        raise HilaError(f"hila needs lark 1.x, but the installed 'lark' module is {version} (lark-parser, which "
                        "ros-rosidl-parser depends on, installs one over it)",
                        hint="pip install --force-reinstall --no-deps 'lark>=1.1,<2'")

    streaming = Streaming()
    # the LALR tables come from the cache folder after the first build (parsecache: 0.3 s a process)
    lark = parsecache.build(grammar_path(), streaming, **PARSER_OPTIONS)
    streaming.learn(lark.rules)
    return lark


def keywords() -> tuple[str, ...]:
    """The grammar's keywords (``run``, ``ask``, ``up``, ...), read from its terminals."""
    return _keywords(grammar())


@functools.lru_cache(maxsize=1)
def _keywords(lark) -> tuple[str, ...]:
    words = set()
    for term in lark.terminals:
        pattern = term.pattern
        if type(pattern).__name__ == "PatternStr":
            values = [pattern.value]
        else:  # a terminal of alternatives, such as PEN_STATE: "up" | "down"
            values = pattern.value.strip("()?:").split("|")
        words.update(v for v in values if v.isidentifier())
    return tuple(sorted(words))


_NAME = re.compile(r"[A-Za-z_][A-Za-z_0-9]*")


def _parses_as(name: str, text: str, read) -> bool:
    """Whether ``text`` (a program that writes ``name``) parses and ``read(items)`` gives ``name``
    back: the grammar decides what a name may be, keywords and all."""
    if not _NAME.fullmatch(name):
        return False
    try:
        return read(parse_items(text)) == name
    except UnexpectedInput:
        return False


def usable_as_tag(tag: str) -> bool:
    """Whether a program can write ``tag`` as a sub-template's tag: ``run t.TAG(...)`` parses
    and names it."""
    return _parses_as(tag, f"main {{ run t.{tag}() }}", lambda items: items[-1].body[0].tag)


def usable_as_point(name: str) -> bool:
    """Whether a program can declare a scene point ``name`` and pass it to a template:
    ``point NAME = (0, 0)`` and ``run t(a = NAME)`` both parse and name it."""
    def read(items):
        (binding,) = items[-1].body[0].bindings
        return items[0].name if getattr(binding.value, "parts", None) == (name,) else None

    return _parses_as(name, f"point {name} = (0, 0)\nmain {{ run t(a = {name}) }}", read)


def parse_items(text: str, start: str = "start"):
    """Parse ``text`` straight to AST items (or one expression for ``start="expr"``); lark's
    ``UnexpectedInput`` propagates."""
    return _value(grammar().parse(text, start=start))


_SLOT_OR_STRING = re.compile(r'"[^"\n]*"|\{([^{}"]*)\}')


def parse_expr(text: str):
    """Expression text as :func:`~hila_lang.language.ast.expr_text` writes it -> the expression.

    Variables written as slots (``{main/mark:c}.tl``) come back as
    :class:`~hila_lang.language.ast.Var`; anything that is not one expression is a
    :class:`HilaSyntaxError`.
    """
    slots: dict[str, str] = {}

    def placeholder(m):
        if m.group(1) is None:  # a string literal: left as it is
            return m.group(0)
        key = f"__slot{len(slots)}__"
        slots[key] = m.group(1)
        return key

    source = _SLOT_OR_STRING.sub(placeholder, text)

    try:
        e = parse_items(source, "expr")
    except UnexpectedInput as exc:
        raise HilaSyntaxError(f"not an expression: {text!r}", line=getattr(exc, "line", None),
                              column=getattr(exc, "column", None)) from None
    return A.map_names(e, lambda n: A.Var(slots[n.parts[0]], n.parts[1:], n.pos) if n.parts[0] in slots else n)



def deepest(items):
    """(node, blocks, expression levels) of the most deeply nested node of ``items``
    (see :data:`MAX_NESTING`), walking without recursion; None for no items."""
    stack = [(item, 0, 0) for item in reversed(items)]
    best = None
    while stack:
        node, blocks, exprs = stack.pop()
        if best is None or blocks + exprs > best[1] + best[2]:
            best = (node, blocks, exprs)
        for child in reversed(A.children(node)):  # popped in source order
            if isinstance(child, A.STATEMENTS):  # a statement in a block of this node's
                stack.append((child, blocks + 1, 0))
            else:  # an expression (a binding ``icp = value`` is not a level of its own)
                stack.append((child, blocks, exprs + (0 if isinstance(child, A.Binding) else 1)))
    return best


def _nesting_error(items, text: str, file: str) -> HilaSyntaxError | None:
    found = deepest(items)
    if found is None or found[1] + found[2] <= MAX_NESTING:
        return None
    node, blocks, exprs = found
    pos = getattr(node, "pos", A.NOPOS)
    line, column = (pos.line, pos.column) if pos.line else (1, 1)
    parts = [f"{blocks} blocks one inside another" if blocks > 1 else "1 block"] if blocks else []
    if exprs:
        parts.append(f"{exprs} expression level{'s' if exprs != 1 else ''}")
    hint = ("compute part of the expression first with 'let': each operator of a chain like "
            "a + b + c nests one level") if exprs > blocks else "move inner blocks into tasks"
    return HilaSyntaxError(
        f"the program nests too deeply here: {' and '.join(parts)}, {blocks + exprs} levels "
        f"(at most {MAX_NESTING})", file=file, line=line, column=column,
        source_line=source_line(text, line), hint=hint)


def parse_program(text: str, file: str = "<program>") -> A.Program:
    """Text -> AST in one call; any failure is a :class:`HilaSyntaxError` with line and column.

    A byte-order mark at the start is skipped (editors on Windows write one).  Parsing builds
    the AST directly (:func:`grammar`, no recursion), and nesting deeper than
    :data:`MAX_NESTING` is refused here, so no later stage (checker, compiler, interpreter, all
    recursive) can run out of stack.
    """
    text = text.removeprefix("\ufeff")
    try:
        items = parse_items(text)
    except UnexpectedInput as exc:
        raise syntax_error(exc, text, file, grammar()) from None
    except HilaError as exc:  # raised by a rule's callback (a number too large): locate it in the file
        exc.file = exc.file or file
        if exc.source_line is None and exc.line:
            exc.source_line = (text.splitlines() or [""])[min(exc.line, len(text.splitlines()) or 1) - 1]
        raise
    error = _nesting_error(items, text, file)
    if error is not None:
        raise error
    return A.Program(items, file, text)
