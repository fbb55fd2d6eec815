"""The hila language: grammar -> AST -> checked program -> FSM -> stepping interpreter.

Every stage is callable on its own (STYLE.md habit 2)::

    from hila_lang.language import parser, transformer, checker, compiler
    tree = parser.parse_text(text, "x.hila")          # lark tree
    program = transformer.to_ast(tree, text, "x.hila")  # frozen dataclasses (ast.py)
    checked = checker.check(program)                  # resolves imports, raises CheckError
    machine = compiler.compile_program(checked)       # fsm.FSM, plain data

``load_program(path)`` runs the whole front end; ``hila_lang.language.interpreter`` steps the
FSM over a world and a back end (found through :mod:`hila_lang.plugins`; :mod:`.runner` wires them);
:mod:`.repl` is the interactive stepper, :mod:`.recording` writes a run to one file and
:mod:`.replay` steps through it or verifies it.
"""



def _without_gc(work):
    """``work()`` with Python's cyclic garbage collector paused: the front end builds millions
    of small acyclic objects for a large program, and every collection pass walks all of them
    (a 5 MB program: parsing took twice as long, and grew faster than the program)."""
    import gc

    was = gc.isenabled()
    gc.disable()
    try:
        return work()
    finally:
        if was:
            gc.enable()


def load_program(path, text: str | None = None, *, settings: dict[str, str] | None = None,
                 backend: str | None = None):
    """Read, parse, check and compile a program: returns (CheckedProgram, FSM).

    ``settings`` and ``backend``: what it will run with (see :func:`.checker.check`).  A
    relative path that does not exist is looked up along the search path
    (:func:`hila_lang.resources.find_program`: ``HILA_PATH``, then the programs hila ships)."""
    from .checker import check
    from .compiler import compile_program
    from .parser import read_source
    from .transformer import parse_program

    if text is None:  # a program named as people type it: found along the search path
        from ..resources import find_program

        path = find_program(path)
        text = read_source(path)
    file = str(path)

    def front_end():
        checked = check(parse_program(text, file), settings=settings, backend=backend)
        return checked, compile_program(checked)

    return _without_gc(front_end)
