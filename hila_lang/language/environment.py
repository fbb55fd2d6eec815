"""The front end in one object (Jinja2's ``Environment``): the grammar, the template loader and
the plug-in registry, and the stages that use them.

Every command that reads a program goes through an :class:`Environment` -- ``check``,
``compile``, ``exec``, ``repl``, ``replay``, ``explain`` and ``lsp`` -- so a program means the same
everywhere.  It owns:

- ``lark``: THE parser of ``grammar/hila.lark``, loaded once per process
  (:func:`hila_lang.language.transformer.grammar`; it builds the AST while parsing);
- ``templates``: a :class:`~hila_lang.language.loader.TemplateLoader` (search path and cache);
  an environment kept alive (the language server's, a studio's) reads a template once while
  its file is unchanged;
- ``registry``: :mod:`hila_lang.plugins.registry` (worlds and back ends by name);
- ``keywords``: the grammar's keywords.

Stages, each callable on its own, and :meth:`Environment.compile` stops after any of them::

    from hila_lang.language.environment import Environment

    env = Environment.default()             # the process's shared environment (for a studio too)
    program = env.parse(text, "x.hila")      # text -> AST (HilaSyntaxError, located)
    checked = env.check(program)             # -> CheckedProgram (CheckError, located)
    checked, fsm = env.compile(text, "x.hila")            # parse once, check, compile
    program = env.compile(text, "x.hila", stop="ast")     # or stop="check"
    checked, fsm = env.load("programs/abc.hila")          # a file, found along the search path

``Environment(search_path=[...])`` looks for ``import NAME`` only in the folders given.
"""

from __future__ import annotations

import gc
import threading

from ..core.resources import find_program
from ..plugins import registry
from . import ast as A
from .checker import check
from .compiler import compile_program
from .loader import TemplateLoader
from .source import read_source

#: where :meth:`Environment.compile` may stop: after parsing, after checking, or with the FSM
STAGES = ("ast", "check", "fsm")


def _without_gc(work):
    """``work()`` with Python's cyclic garbage collector paused: the front end builds millions
    of small acyclic objects for a large program, and every collection pass walks all of them
    (a 5 MB program: parsing took twice as long, and grew faster than the program)."""
    was = gc.isenabled()
    gc.disable()
    try:
        return work()
    finally:
        if was:
            gc.enable()


class Environment:
    """The grammar, a template loader and the plug-in registry, and the front-end stages."""

    _default: Environment | None = None
    _lock = threading.Lock()

    def __init__(self, *, templates: TemplateLoader | None = None, search_path=None) -> None:
        self.templates = templates if templates is not None else TemplateLoader(search_path)
        self.registry = registry

    @classmethod
    def default(cls) -> Environment:
        """The process's shared environment (default search path; its template cache is shared)."""
        with cls._lock:
            if cls._default is None:
                cls._default = cls()
            return cls._default

    # ------------------------------------------------------------------ what it owns
    @property
    def lark(self):
        """The lark parser (one per process; it returns AST nodes)."""
        # lazy: loads lark, which importing this module does not
        from .transformer import grammar

        return grammar()

    @property
    def keywords(self) -> tuple[str, ...]:
        # lazy: loads lark, which importing this module does not
        from .transformer import keywords

        return keywords()

    # ------------------------------------------------------------------ stages
    def read(self, path) -> tuple[str, str]:
        """``(path, text)`` of a program named as people type it (found along the search path:
        :func:`hila_lang.core.resources.find_program`); OS failures are InputError, bad UTF-8 a
        located syntax error."""
        path = find_program(path)
        return str(path), read_source(path)

    def parse(self, text: str, file: str = "<program>") -> A.Program:
        """Text -> AST (:func:`hila_lang.language.transformer.parse_program`)."""
        # lazy: loads lark, which importing this module does not
        from .transformer import parse_program

        return parse_program(text, file)

    def parse_expr(self, text: str):
        """One expression, as :func:`hila_lang.language.ast.expr_text` writes it -> the expression."""
        # lazy: loads lark, which importing this module does not
        from .transformer import parse_expr

        return parse_expr(text)

    def check(self, program: A.Program, *, settings: dict[str, str] | None = None,
              backend: str | None = None):
        """AST -> :class:`~hila_lang.language.checker.CheckedProgram`, imports read through
        :attr:`templates` (see :func:`hila_lang.language.checker.check`)."""
        return check(program, self.templates, settings=settings, backend=backend)

    def compile(self, source, file: str = "<program>", *, stop: str = "fsm",
                settings: dict[str, str] | None = None, backend: str | None = None):
        """Text (or an AST) through the stages up to ``stop`` (:data:`STAGES`): the AST
        (``"ast"``), the checked program (``"check"``) or ``(checked program, FSM)`` (``"fsm"``).
        The text is parsed once."""
        if stop not in STAGES:
            raise ValueError(f"stop must be one of {', '.join(STAGES)}, got {stop!r}")

        def front_end():
            program = source if isinstance(source, A.Program) else self.parse(source, file)
            if stop == "ast":
                return program
            checked = self.check(program, settings=settings, backend=backend)
            if stop == "check":
                return checked

            return checked, compile_program(checked)

        return _without_gc(front_end)

    def load(self, path, text: str | None = None, *, settings: dict[str, str] | None = None,
             backend: str | None = None, stop: str = "fsm"):
        """Read (unless ``text`` is given), parse, check and compile a program file: by default
        ``(CheckedProgram, FSM)``; ``stop`` as in :meth:`compile`.  A relative path that does
        not exist is looked up along the search path (``HILA_PATH``, then the programs hila
        ships)."""
        if text is None:
            path, text = self.read(path)
        return self.compile(text, str(path), stop=stop, settings=settings, backend=backend)
