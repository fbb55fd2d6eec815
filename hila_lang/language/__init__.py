"""The hila language's front end: grammar -> AST -> checked program -> FSM.

The front end is one object, :class:`.environment.Environment` (the grammar, the template
loader and its cache, the plug-in registry); every stage is callable on its own, and a
flag stops early (``stop=``)::

    from hila_lang.language.environment import Environment
    env = Environment.default()
    program = env.parse(text, "x.hila")              # frozen dataclasses (ast.py), built while parsing
    checked = env.check(program)                     # resolves imports, raises CheckError
    checked, machine = env.compile(text, "x.hila")   # fsm.FSM, plain data (stop="ast"|"check": earlier)

Modules: :mod:`.source` (reading program text, syntax errors), :mod:`.transformer` (the grammar,
the parser and the AST builder), :mod:`.loader` (templates), :mod:`.checker`, :mod:`.compiler`,
:mod:`.environment`.
``load_program(path)`` runs the whole front end; :mod:`hila_lang.engine` steps the FSM over a
world and a back end, and :mod:`hila_lang.session` wires a run (runner, REPL, recording, replay).

One line each:

- ``ast``          the program's frozen dataclasses, built while parsing
- ``source``       reading program text; syntax errors with line and column, in words
- ``transformer``  the grammar, its one parser (text -> AST while parsing) and the AST builder
- ``parsecache``   the grammar's LALR tables, built once per installation and kept in the cache folder
- ``loader``       templates by name, from the search path
- ``environment``  THE front end: one grammar, one template loader and cache, the plug-in registry
- ``checker``      names, ICP bindings, reachability; structured diagnostics
- ``calls``        task calls seen whole: no recursion, a bounded inlined size
- ``worldcheck``   what a program asks of its world, against what the world declares
- ``compiler``     checked program -> FSM
- ``fsm``          the state machine, plain data
- ``limits``       every limit of the language and its engine, with the measurement behind it
"""

from .environment import Environment



def load_program(path, text: str | None = None, *, settings: dict[str, str] | None = None,
                 backend: str | None = None):
    """Read, parse, check and compile a program: returns (CheckedProgram, FSM), through the
    shared :class:`~.environment.Environment` (:meth:`~.environment.Environment.load`).

    ``settings`` and ``backend``: what it will run with (see :func:`.checker.check`).  A
    relative path that does not exist is looked up along the search path
    (:func:`hila_lang.core.resources.find_program`: ``HILA_PATH``, then the programs hila ships)."""
    return Environment.default().load(path, text, settings=settings, backend=backend)
