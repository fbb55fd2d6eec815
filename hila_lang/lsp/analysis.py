"""What the language server knows about one ``.hila`` document, without any LSP types.

:class:`Document` analyses a program's text the way ``hila check`` does -- the same parser,
checker and compiler, so its problems are the same located errors -- and answers hover,
go-to-definition and completion at a position.

Speed.  Typing changes one top-level item (a task, ``main``), so the text is parsed item by
item: a *chunk* starts at every line that begins with ``world``, ``import``, ``point``,
``hand``, ``task`` or ``main``, and is parsed alone with as many newlines before it as lines
precede it (so line numbers are the file's; after the first chunk, the first of those lines holds
``;``, an empty item, so the parser's state stack is as deep as after the items before it).
Unchanged chunks come from a cache; one that only moved (lines typed above it) has its positions
shifted (:func:`hila_lang.language.ast.shift_lines`) instead of being parsed again.  This gives
the same result as parsing the whole text: a chunk boundary is a boundary between items (where
the parser is in its start state), except when a chunk ends inside an unfinished item; such a
chunk fails with "unexpected end of file" before the last chunk, and then the whole text is
parsed instead.  The document's :class:`~hila_lang.language.environment.Environment` parses,
checks and compiles (one grammar for the process), and its template loader keeps imported
templates by file, size and modification time.  A document larger than :data:`MAX_CHARACTERS`
is not analysed: one diagnostic says so (``hila check`` reads any size).

Answers come from the tree, not the text: :func:`path_at` finds the nodes under a position (the
AST keeps every node's span), hover and go-to-definition read those nodes, diagnostics are the
checker's structured errors and warnings (span, code, message).  Completion, where the text
being typed does not parse yet, reads the tokens of the grammar's lexer before the cursor, and
offers only what begins with the word being typed.

Positions here are 0-based (line, character) as in the protocol; characters are code points.
Any position is answered: one outside the text is moved to its nearest end.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from ..core.errors import CheckError, HilaError, HilaSyntaxError
from ..language import ast as A
from ..language.checker import resolve_import
from ..language.environment import Environment

#: a line that starts a top-level item
_TOP = re.compile(r"(?:world|import|point|hand|task|main)\b")
#: the largest document analysed (characters).  Measured here (bench/parse.py's seeded program,
#: one long ``main``; load average 4.7): re-analysing after a keystroke took 0.66 s at 250 kB and
#: 2.0 s at 1 MB, beyond the second an editor tolerates for diagnostics (a 5 MB document took
#: 57 s before this limit).  256 kB is about 7,000 lines, 40 times the largest shipped program.
MAX_CHARACTERS = 256_000


@dataclass
class Problem:
    """A diagnostic: 0-based start and end (line, character), ``severity`` "error", "warning" or "note",
    ``code``: a stable name (``syntax``, ``check``, ``too-large``, or the checker's warning code)."""

    line: int
    character: int
    end_line: int
    end_character: int
    message: str
    severity: str = "error"
    code: str = "error"


@dataclass
class Hover:
    text: str  # markdown
    line: int
    character: int
    end_character: int


@dataclass
class Location:
    path: str
    line: int = 0
    character: int = 0


@dataclass
class Completion:
    label: str
    kind: str  # "tag", "icp", "question", "event", "template", "task", "point", "keyword"
    detail: str = ""
    insert: str | None = None


def chunks(text: str) -> list[tuple[int, str]]:
    """``(first line, 1-based; text)`` of each top-level chunk (see the module docstring)."""
    lines = text.split("\n")
    starts = [0] + [i for i, line in enumerate(lines) if i and _TOP.match(line)]
    ends = starts[1:] + [len(lines)]
    return [(a + 1, "\n".join(lines[a:b]) + ("\n" if b < len(lines) else "")) for a, b in zip(starts, ends)]


class Document:
    """One program being edited: its path (imports are found from it) and the last analysis."""

    def __init__(self, path: str, env=None) -> None:
        self.path = str(path)
        self.env = env if env is not None else Environment()  # its own template cache
        self.templates = self.env.templates
        self._parsed: dict[str, tuple] = {}  # chunk text -> (first line, (items, error))
        self.text = ""
        self.items: tuple = ()  # the items that parsed (all of them when the text parses)
        self.problems: list[Problem] = []

    # ------------------------------------------------------------------ diagnostics
    def parse(self, text: str) -> A.Program:
        """The program's AST, as :func:`hila_lang.language.transformer.parse_program` gives it
        (its :class:`~hila_lang.core.errors.HilaSyntaxError` too), chunk by chunk from the cache.
        :attr:`items` gets every item that parsed, for hover and completion in a broken text."""
        parse_program = self.env.parse
        parsed, items, first = {}, [], None
        pieces = chunks(text)
        for k, (line, chunk) in enumerate(pieces):
            key = chunk
            cached = self._parsed.get(key)
            hit = None
            if cached is not None and cached[0] == line:
                hit = cached[1]
            elif cached is not None and cached[1][1] is None:  # the same item, moved: shift it
                hit = (A.shift_lines(cached[1][0], line - cached[0]), None)
            if hit is None:
                # lines before the chunk are blank (line numbers stay the file's); after the first
                # chunk one of them holds ';', an empty item, so the parser is where it would be
                # after the items before (it labels common slips only in the first item)
                padding = "\n" * (line - 1) if line == 1 else ";" + "\n" * (line - 1)
                try:
                    hit = (parse_program(padding + chunk, self.path).items, None)
                except HilaError as exc:
                    hit = ((), exc)
            parsed[key] = (line, hit)
            items.extend(hit[0])
            if hit[1] is not None and first is None:
                first = (k, hit[1])
        self._parsed, self.items = parsed, tuple(items)
        if first is None:
            return A.Program(tuple(items), self.path, text)
        k, error = first
        if k < len(pieces) - 1 and error.message.startswith("unexpected end of file"):
            return parse_program(text, self.path)  # the chunk ends inside an item: the whole text decides
        raise error

    def analyse(self, text: str) -> list[Problem]:
        """Parse, check and compile ``text`` as ``hila check`` does; the problems found."""
        self.text = text
        self.items = ()
        if len(text) > MAX_CHARACTERS:
            self.problems = [Problem(
                0, 0, 0, 0, f"this document has {len(text):,} characters; hila lsp analyses documents of up to "
                f"{MAX_CHARACTERS:,} characters (no diagnostics, hover or completion here)\nhint: run "
                "'hila check FILE' for the whole program", "warning", "too-large")]
            return self.problems
        problems = []
        try:
            program = self.parse(text)
            self.items = program.items
            checked, _ = self.env.compile(program)
        except HilaError as exc:
            problems.append(self._problem(exc))
        else:
            for w in checked.warnings:
                problems.append(self._located(w.pos, w.message, w.severity, w.code))
        self.problems = problems
        return problems

    def _problem(self, exc: HilaError) -> Problem:
        message = exc.message + (f"\nhint: {exc.hint}" if exc.hint else "")
        code = "syntax" if isinstance(exc, HilaSyntaxError) else "check" if isinstance(exc, CheckError) else "error"
        if exc.line is None:
            return Problem(0, 0, 0, 0, message, "error", code)
        span = getattr(exc, "span", None)  # the checker's node; other errors: one character
        if span is None or span.line != exc.line:
            span = A.Pos(exc.line, exc.column or 1, exc.line, (exc.column or 1) + 1)
        return self._located(A.Pos(exc.line, exc.column or 1, span.end_line, span.end_column), message, "error",
                             code)

    def _located(self, pos: A.Pos, message: str, severity: str, code: str) -> Problem:
        """A problem at a 1-based span, kept to its first line (a whole task is not underlined)."""
        lines = self._lines()
        line = min(max(pos.line, 1), max(len(lines), 1)) - 1
        width = len(lines[line]) if line < len(lines) else 0
        start = min(max(pos.column - 1, 0), width)
        end = pos.end_column - 1 if pos.end_line == pos.line else width
        return Problem(line, start, line, min(max(end, start), width), message, severity, code)

    # ------------------------------------------------------------------ what the program names
    def _lines(self) -> list[str]:
        return self.text.split("\n")

    def imports(self) -> dict[str, tuple[Path, object]]:
        """alias -> (file, Template) of the imports that resolve (from the last parse)."""
        program = A.Program(self.items, self.path, self.text)
        out = {}
        for imp in program.of(A.ImportDecl):
            try:
                out[imp.alias] = resolve_import(program, imp, self.templates)
            except HilaError:
                continue
        return out

    def world(self):
        """The world's declaration (:class:`~hila_lang.plugins.registry.WorldInfo`), or None."""
        registry = self.env.registry
        names = [i.name for i in self.items if isinstance(i, A.WorldDecl)]
        try:
            return registry.world(names[0] if names else registry.DEFAULT_WORLD)
        except (HilaError, TypeError):
            return None

    def tasks(self) -> dict[str, A.TaskDef]:
        return {t.name: t for t in self.items if isinstance(t, A.TaskDef)}

    def points(self) -> dict[str, A.PointDecl]:
        return {p.name: p for p in self.items if isinstance(p, A.PointDecl)}

    def _sub_template(self, template: str, tag: str | None):
        found = self.imports().get(template)
        if found is None:
            return None
        if not tag:
            return found[1]
        return found[1].sub(tag) if tag in found[1].tags() else None

    # ------------------------------------------------------------------ at a position
    def clamp(self, line: int, character: int) -> tuple[int, int]:
        """A protocol position moved into the text (negative: its start; past the end: the end)."""
        lines = self._lines()
        line = min(max(line, 0), len(lines) - 1)
        return line, min(max(character, 0), len(lines[line]))

    def _target(self, line: int, character: int):
        """(node, its parent or None) under a clamped 0-based position: the innermost node."""
        line, character = self.clamp(line, character)
        found = path_at(self.items, line + 1, character + 1)
        if not found:
            return None, None
        return found[-1], (found[-2] if len(found) > 1 else None)

    def _hover(self, text: str, pos: A.Pos, column: int | None = None, width: int | None = None) -> Hover:
        """A hover over ``pos`` (or ``width`` characters from 1-based ``column``), on its first line."""
        start = (column or pos.column) - 1
        if width is not None:
            end = start + width
        else:
            end = pos.end_column - 1 if pos.end_line == pos.line else len(self._lines()[pos.line - 1])
        return Hover(text, pos.line - 1, start, end)

    def hover(self, line: int, character: int) -> Hover | None:
        node, parent = self._target(line, character)
        if node is None:
            return None
        line, character = self.clamp(line, character)
        column = character + 1
        world = self.world()
        if isinstance(node, A.Ask) and world is not None:
            doc = world.questions.get(node.name)
            return self._hover(f"**ask {node.name}** (world {world.name}): {doc}", node.pos) if doc else None
        if isinstance(node, A.Wait) and world is not None:
            doc = world.events.get(node.event)
            return self._hover(f"**wait {node.event}** (world {world.name}): {doc}", node.pos) if doc else None
        if isinstance(node, A.WorldDecl) and world is not None:
            settings = "".join(f"\n- `--set {s.name}={s.metavar}`: {s.doc}" for s in world.settings)
            return self._hover(f"**world {world.name}**: {world.doc}{settings}", node.pos)
        if isinstance(node, A.ImportDecl):
            return self._template_hover(node.alias, node.pos)
        if isinstance(node, A.RunStmt) and _inside(node.ref_pos, line + 1, column):
            on_tag = node.tag is not None and column > node.ref_pos.column + len(node.template)
            if not on_tag:
                return self._template_hover(node.template, node.ref_pos, width=len(node.template))
            return self._tag_hover(node, node.ref_pos)
        if isinstance(node, A.Binding) and isinstance(parent, A.RunStmt) and node.icp != A.SPREAD:
            sub = self._sub_template(parent.template, parent.tag)
            members = [k for k in getattr(sub, "icps", ()) if k == node.icp or k.startswith(node.icp + ".")]
            if members:
                shown = ", ".join(f"{k} at {tuple(round(float(v), 3) for v in sub.icps[k])}" for k in members)
                return self._hover(f"**ICP {node.icp}** of `{parent.template}.{parent.tag}`: template point"
                                   f"{'s' if len(members) > 1 else ''} {shown}", node.pos, width=len(node.icp))
            return None
        if isinstance(node, A.TrackOption):
            return self._hover(f"**{node.text()}**: {TRACK_HOVER[node.kind]}", node.pos)
        if isinstance(node, A.Track):
            return self._hover(f"**{node.text()}**: {TRACK_HOVER['track']}", node.pos, width=len("track"))
        if isinstance(node, (A.CallStmt, A.TaskDef)):
            t = self.tasks().get(node.task if isinstance(node, A.CallStmt) else node.name)
            if t is None or (isinstance(node, A.TaskDef) and line + 1 != node.pos.line):
                return None
            return self._hover(f"**task {t.name}({', '.join(t.params)})**: {len(t.params)} parameter(s); "
                               f"defined at line {t.pos.line}", node.pos)
        if isinstance(node, (A.Name, A.PointDecl)):
            p = self._point(node)
            if p is not None:
                return self._hover(f"**point {p.name}** = `{A.expr_text(p.value)}` (line {p.pos.line})", node.pos)
        return None

    def _point(self, node) -> A.PointDecl | None:
        """The ``point`` a name (or a point declaration) stands for."""
        points = self.points()
        if isinstance(node, A.PointDecl):
            return points.get(node.name)
        for k in range(len(node.parts), 0, -1):  # home, or the point c.tl of c.tl.x
            found = points.get(".".join(node.parts[:k]))
            if found is not None:
                return found
        return None

    def _template_hover(self, alias: str, pos: A.Pos, width: int | None = None) -> Hover | None:
        found = self.imports().get(alias)
        if found is None:
            return None
        file, template = found
        tags = ", ".join(f"{s.tag}{' (pen down)' if s.contact else ''}" for s in template.segments)
        desc = (template.description or "").strip().splitlines()
        return self._hover(f"**template {alias}** (`{file}`): {len(template.path)} points, {template.dim}-D"
                           f"\n\ntags: {tags or 'none'}\n\nICPs: {', '.join(template.icps)}"
                           + (f"\n\n{desc[0]}" if desc else ""), pos, width=width)

    def _tag_hover(self, run: A.RunStmt, pos: A.Pos) -> Hover | None:
        found = self.imports().get(run.template)
        if found is None or run.tag not in found[1].tags():
            return None
        file, template = found
        sub, seg = template.sub(run.tag), template.segment(run.tag)
        return self._hover(f"**{run.template}.{run.tag}**: sub-template of `{file}`, "
                           f"points {seg.start}..{seg.stop - 1} "
                           f"({len(sub.path)} points), pen {'down' if seg.contact else 'up'}\n\n"
                           f"ICPs: {', '.join(sub.icps)}", pos, column=pos.column + len(run.template) + 1,
                           width=len(run.tag))

    def definition(self, line: int, character: int) -> Location | None:
        node, _ = self._target(line, character)
        if node is None:
            return None
        line, character = self.clamp(line, character)
        if isinstance(node, A.CallStmt):
            t = self.tasks().get(node.task)
            return None if t is None else Location(self.path, t.pos.line - 1, t.pos.column - 1)
        if isinstance(node, A.Name):
            p = self._point(node)
            return None if p is None else Location(self.path, p.pos.line - 1, p.pos.column - 1)
        if isinstance(node, A.ImportDecl):
            found = self.imports().get(node.alias)
            return None if found is None else Location(str(found[0]), 0, 0)
        if isinstance(node, A.RunStmt) and _inside(node.ref_pos, line + 1, character + 1):
            found = self.imports().get(node.template)
            if found is None:
                return None
            on_tag = node.tag is not None and character + 1 > node.ref_pos.column + len(node.template)
            where = _tag_line(found[0], node.tag) if on_tag else None
            return Location(str(found[0]), *(where or (0, 0)))
        return None

    def completion(self, line: int, character: int) -> list[Completion]:
        """What may be typed at the position, read from the grammar's tokens before it, narrowed to
        the names that begin with the word being typed."""
        line, character = self.clamp(line, character)
        tokens, typed = self._tokens_before(line, character)
        return [c for c in self._candidates(tokens) if c.label.startswith(typed)]

    def _tokens_before(self, line: int, character: int):
        """(tokens of the item being typed up to the cursor, the word being typed there or "")."""
        lines = self._lines()
        first = line
        while first > 0 and not _TOP.match(lines[first]):
            first -= 1
        text = "\n".join(lines[first:line] + [lines[line][:character]])
        tokens = []
        try:
            for tok in self.env.lark.lex(text):
                tokens.append(tok)
        except Exception:  # noqa: BLE001 - a character the grammar refuses: what came before it counts
            pass
        typed = ""
        if tokens and tokens[-1].end_pos == len(text) and str(tokens[-1]).isidentifier():
            typed = str(tokens.pop())
        return tokens, typed

    def _candidates(self, tokens) -> list[Completion]:
        kinds = [t.type for t in tokens]
        imports = self.imports()
        if kinds[-1:] == ["DOT"] and len(tokens) >= 2 and str(tokens[-2]) in imports and kinds[-3:-2] != ["POINT"]:
            template = imports[str(tokens[-2])][1]
            return [Completion(s.tag, "tag", f"{s.stop - s.start} points, pen {'down' if s.contact else 'up'}")
                    for s in template.segments]
        world = self.world()
        if kinds[-1:] in (["ASK"], ["WAIT"]):
            if world is None:
                return []
            ask = kinds[-1] == "ASK"
            names = world.questions if ask else world.events
            return [Completion(n, "question" if ask else "event", doc) for n, doc in names.items()]
        ref = _open_run(tokens)
        if ref is not None and kinds[-1] in ("LPAR", "COMMA"):
            sub = self._sub_template(*ref)
            if sub is not None:
                names = list(sub.icps) + [g for g in dict.fromkeys(k.rsplit(".", 1)[0] for k in sub.icps if "." in k)]
                return [Completion(n, "icp", f"ICP of {ref[0]}.{ref[1]}", f"{n} = ") for n in names]
        out = [Completion(k, "keyword") for k in self.env.keywords]
        out += [Completion(alias, "template", f"template {file}") for alias, (file, _) in imports.items()]
        out += [Completion(t.name, "task", f"task {t.name}({', '.join(t.params)})") for t in self.tasks().values()]
        out += [Completion(p, "point", A.expr_text(d.value)) for p, d in self.points().items()]
        return out


#: hover texts of a ``track`` clause and its options (docs/language.md, "Moving scenes")
TRACK_HOVER = {
    "track": "keeps the ICPs bound through these names live while the step runs: the robot perceives them "
             "again every tick and, when one moved more than the threshold, warps the rest of the step again "
             "with OSILA from where the pen is (needs a world that can show its points while the robot moves "
             "and a streaming back end)",
    "every": "how often the robot looks again while the step runs (default 100 ms)",
    "threshold": "a tracked ICP must move more than this before the rest of the step is warped again (default 1 mm)",
    "blend": "the new plan takes over from the pen's measured position over this much path, with a minimum-jerk "
             "weight (default 5 mm)",
    "lift": "when the scene under a pen that is down moved more than this at once, the pen lifts, travels and "
            "is put down where its ink stopped (default: never)",
}


def _inside(pos: A.Pos, line: int, column: int) -> bool:
    """Whether 1-based (line, column) is within ``pos`` (its end included: a cursor just after a word
    is on it)."""
    if not pos.line:
        return False
    return (pos.line, pos.column) <= (line, column) <= (pos.end_line, pos.end_column)


def path_at(items, line: int, column: int) -> list:
    """The AST nodes that hold 1-based (line, column), outermost first (an item, a statement in
    it, ..., the innermost expression); [] when none does.  No recursion."""
    path: list = []
    level = list(items)
    while level:
        inner = [n for n in level if _inside(getattr(n, "pos", A.NOPOS), line, column)]
        if not inner:
            break
        node = inner[-1]
        path.append(node)
        level = A.children(node)
    return path


def _open_run(tokens) -> tuple[str, str | None] | None:
    """(template, tag) of the ``run T.TAG(`` whose parenthesis is still open at the end of ``tokens``."""
    depth = 0
    for i in range(len(tokens) - 1, -1, -1):
        kind = tokens[i].type
        if kind == "RPAR":
            depth += 1
        elif kind == "LPAR":
            if depth:
                depth -= 1
                continue
            j = i - 1
            parts = []
            while j >= 1 and tokens[j].type == "NAME" and tokens[j - 1].type in ("DOT", "RUN"):
                parts.insert(0, str(tokens[j]))
                if tokens[j - 1].type == "RUN":
                    return parts[0], ".".join(parts[1:]) or None
                j -= 2
            return None
        elif kind in ("LBRACE", "RBRACE"):
            return None
    return None


def _tag_line(file: Path, tag: str) -> tuple[int, int] | None:
    """0-based (line, character) of the segment tagged ``tag`` in a template's YAML, read from
    the YAML's node tree (None when the file does not say)."""
    # lazy: loads yaml, which importing this module does not
    import yaml

    try:
        root = yaml.compose(Path(file).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        return None
    stack = [root] if root is not None else []
    while stack:
        node = stack.pop()
        if isinstance(node, yaml.MappingNode):
            for key, value in node.value:
                if key.value == "tag" and isinstance(value, yaml.ScalarNode) and value.value == tag:
                    return key.start_mark.line, key.start_mark.column
                stack.append(value)
        elif isinstance(node, yaml.SequenceNode):
            stack.extend(node.value)
    return None
