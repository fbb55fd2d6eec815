"""``hila lsp``: a language server for ``.hila`` programs (pygls, over stdio).

:mod:`.analysis` knows the program (diagnostics as ``hila check`` gives them, hover, go to
definition, completion) without any protocol types; :mod:`.server` speaks the Language Server
Protocol with pygls, imported only when the server starts.

- ``analysis``  the program's diagnostics, hover, definition and completion, from the tree
- ``framing``   the protocol's framed messages read from a byte stream, whatever comes
- ``server``    the Language Server Protocol with pygls
"""
