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
parsed instead.  Imported templates are cached by file, size and modification time.

Positions here are 0-based (line, character) as in the protocol; characters are code points.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

from ..errors import HilaError
from ..language import ast as A

#: a line that starts a top-level item
_TOP = re.compile(r"(?:world|import|point|hand|task|main)\b")
_WORD = re.compile(r"[A-Za-z_][A-Za-z_0-9]*")
KEYWORDS = ("world", "import", "point", "hand", "at", "task", "main", "run", "let", "wait", "ask", "if", "else",
            "while", "until", "repeat", "pen", "up", "down", "via", "avoid", "radius", "not", "and", "or",
            "true", "false", "none", "as")


@dataclass
class Problem:
    """A diagnostic: 0-based start and end (line, character), ``severity`` "error" or "warning"."""

    line: int
    character: int
    end_line: int
    end_character: int
    message: str
    severity: str = "error"


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
    kind: str  # "tag", "icp", "question", "event", "task", "point", "keyword"
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
        from ..language.environment import Environment

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
        (its :class:`~hila_lang.errors.HilaSyntaxError` too), chunk by chunk from the cache.
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
        problems = []
        try:
            program = self.parse(text)
            self.items = program.items
            checked, _ = self.env.compile(program)
        except HilaError as exc:
            problems.append(self._problem(exc, "error"))
        else:
            for warning in checked.warnings:
                p = warning.pos
                problems.append(Problem(p.line - 1, p.column - 1, p.end_line - 1, p.end_column - 1,
                                        warning.message, warning.severity))
        self.problems = problems
        return problems

    def _problem(self, exc: HilaError, severity: str) -> Problem:
        message = exc.message + (f"\nhint: {exc.hint}" if exc.hint else "")
        if exc.line is None:
            return Problem(0, 0, 0, 0, message, severity)
        return self._span(exc.line, exc.column or 1, message, severity)

    def _span(self, line: int, column: int, message: str, severity: str) -> Problem:
        """A problem at 1-based ``line``/``column`` covering the word (or the character) there."""
        lines = self.text.split("\n")
        text = lines[line - 1] if 0 < line <= len(lines) else ""
        start = max(column - 1, 0)
        m = _WORD.match(text, start)
        end = m.end() if m else min(start + 1, len(text))
        return Problem(line - 1, start, line - 1, max(end, start), message, severity)

    # ------------------------------------------------------------------ what the program names
    def _lines(self) -> list[str]:
        return self.text.split("\n")

    def imports(self) -> dict[str, tuple[Path, object]]:
        """alias -> (file, Template) of the imports that resolve (from the last parse)."""
        from ..language.checker import resolve_import

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
        from ..plugins import registry

        names = [i.name for i in self.items if isinstance(i, A.WorldDecl)]
        try:
            return registry.world(names[0] if names else registry.DEFAULT_WORLD)
        except (HilaError, TypeError):
            return None

    def tasks(self) -> dict[str, A.TaskDef]:
        return {t.name: t for t in self.items if isinstance(t, A.TaskDef)}

    def points(self) -> dict[str, A.PointDecl]:
        return {p.name: p for p in self.items if isinstance(p, A.PointDecl)}

    # ------------------------------------------------------------------ at a position
    def _at(self, line: int, character: int):
        """(dotted word under the cursor, its start, its end, the line's text before it)."""
        lines = self._lines()
        text = lines[line] if 0 <= line < len(lines) else ""
        text = text.split("#", 1)[0] if "#" in text[:character] else text
        start = character
        while start > 0 and (text[start - 1].isalnum() or text[start - 1] in "_."):
            start -= 1
        end = character
        while end < len(text) and (text[end].isalnum() or text[end] == "_"):
            end += 1
        return text[start:end], start, end, text[:start]

    def _run_around(self, line: int, character: int) -> str | None:
        """``T.TAG`` of the ``run T.TAG(`` whose parentheses hold the position, or None."""
        lines = self._lines()
        before = "\n".join(lines[:line] + [lines[line][:character] if line < len(lines) else ""])
        for m in reversed(list(re.finditer(r"\brun\s+([A-Za-z_][\w.]*)\s*\(", before))):
            rest = before[m.end():]
            if rest.count("(") >= rest.count(")"):
                return m.group(1)
            return None
        return None

    def _sub_template(self, ref: str):
        alias, _, tag = ref.partition(".")
        found = self.imports().get(alias)
        if found is None:
            return None
        template = found[1]
        if not tag:
            return template
        return template.sub(tag) if tag in template.tags() else None

    def hover(self, line: int, character: int) -> Hover | None:
        word, start, end, before = self._at(line, character)
        if not word:
            return None

        def answer(text: str) -> Hover:
            return Hover(text, line, start, end)

        world = self.world()
        if re.search(r"\bask\s*$", before) and world is not None:
            doc = world.questions.get(word)
            return answer(f"**ask {word}** (world {world.name}): {doc}") if doc else None
        if re.search(r"\bwait\s*$", before) and world is not None:
            doc = world.events.get(word)
            return answer(f"**wait {word}** (world {world.name}): {doc}") if doc else None
        if re.search(r"\bworld\s*$", before) and world is not None:
            settings = "".join(f"\n- `--set {s.name}={s.metavar}`: {s.doc}" for s in world.settings)
            return answer(f"**world {world.name}**: {world.doc}{settings}")
        head, _, rest = word.partition(".")
        imports = self.imports()
        if head in imports and not re.search(r"\bpoint\s*$", before):
            file, template = imports[head]
            tag = rest.split(".")[0] if rest and character > start + len(head) else ""
            if tag in template.tags():
                sub = template.sub(tag)
                seg = template.segment(tag)
                return answer(f"**{head}.{tag}**: sub-template of `{file}`, points {seg.start}..{seg.stop - 1} "
                              f"({len(sub.path)} points), pen {'down' if seg.contact else 'up'}\n\n"
                              f"ICPs: {', '.join(sub.icps)}")
            tags = ", ".join(f"{s.tag}{' (pen down)' if s.contact else ''}" for s in template.segments)
            desc = (template.description or "").strip().splitlines()
            return answer(f"**template {head}** (`{file}`): {len(template.path)} points, {template.dim}-D"
                          f"\n\ntags: {tags or 'none'}\n\nICPs: {', '.join(template.icps)}"
                          + (f"\n\n{desc[0]}" if desc else ""))
        ref = self._run_around(line, character)
        if ref is not None and re.match(r"\s*=", self._lines()[line][end:]) and "." not in word:
            sub = self._sub_template(ref)
            if sub is not None:
                members = [k for k in sub.icps if k == word or k.startswith(word + ".")]
                if members:
                    shown = ", ".join(f"{k} at {tuple(round(float(v), 3) for v in sub.icps[k])}" for k in members)
                    return answer(f"**ICP {word}** of `{ref}`: template point{'s' if len(members) > 1 else ''} {shown}")
        tasks = self.tasks()
        if word in tasks:
            t = tasks[word]
            return answer(f"**task {t.name}({', '.join(t.params)})**: {len(t.params)} parameter(s); "
                          f"defined at line {t.pos.line}")
        points = self.points()
        if word in points:
            p = points[word]
            return answer(f"**point {p.name}** = `{A.expr_text(p.value)}` (line {p.pos.line})")
        return None

    def definition(self, line: int, character: int) -> Location | None:
        word, start, end, before = self._at(line, character)
        if not word:
            return None
        head, _, rest = word.partition(".")
        tasks, points = self.tasks(), self.points()
        if word in tasks and not re.search(r"\btask\s*$", before):
            p = tasks[word].pos
            return Location(self.path, p.line - 1, p.column - 1)
        if word in points:
            p = points[word].pos
            return Location(self.path, p.line - 1, p.column - 1)
        imports = self.imports()
        if head in imports:
            file, template = imports[head]
            tag = rest.split(".")[0] if rest and character > start + len(head) else ""
            if tag:
                try:
                    lines = file.read_text(encoding="utf-8").split("\n")
                except OSError:
                    lines = []
                for i, text in enumerate(lines):
                    if re.search(rf"\btag:\s*['\"]?{re.escape(tag)}['\"]?\s*[,}}]", text):
                        return Location(str(file), i, text.index("tag"))
            return Location(str(file), 0, 0)
        return None

    def completion(self, line: int, character: int) -> list[Completion]:
        lines = self._lines()
        before = lines[line][:character] if 0 <= line < len(lines) else ""
        m = re.search(r"([A-Za-z_]\w*)\.(\w*)$", before)
        imports = self.imports()
        if m and m.group(1) in imports and not re.search(r"\bpoint\s+\S*$", before):
            template = imports[m.group(1)][1]
            return [Completion(s.tag, "tag", f"{s.stop - s.start} points, pen {'down' if s.contact else 'up'}")
                    for s in template.segments]
        world = self.world()
        m = re.search(r"\b(ask|wait)\s+(\w*)$", before)
        if m:
            if world is None:
                return []
            names = world.questions if m.group(1) == "ask" else world.events
            kind = "question" if m.group(1) == "ask" else "event"
            return [Completion(n, kind, doc) for n, doc in names.items()]
        ref = self._run_around(line, character)
        if ref is not None:
            sub = self._sub_template(ref)
            if sub is not None:
                names = list(sub.icps) + [g for g in dict.fromkeys(k.rsplit(".", 1)[0] for k in sub.icps if "." in k)]
                return [Completion(n, "icp", f"ICP of {ref}", f"{n} = ") for n in names]
        out = [Completion(k, "keyword") for k in KEYWORDS]
        out += [Completion(t.name, "task", f"task {t.name}({', '.join(t.params)})") for t in self.tasks().values()]
        out += [Completion(p, "point", A.expr_text(d.value)) for p, d in self.points().items()]
        return out
