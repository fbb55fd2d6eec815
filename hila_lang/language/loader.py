"""Imported templates: found along a search path, loaded once while the file is unchanged.

A :class:`TemplateLoader` is the one place the front end reads template files (the checker asks
it; the :class:`~hila_lang.language.environment.Environment` owns one, and the language server
keeps its environment for the whole session).  ``import NAME`` looks for ``NAME.yaml`` in
:func:`hila_lang.core.resources.template_search_path` (``HILA_PATH``, the program's folder, the
package's own) or in the folders given; ``import "FILE.yaml"`` is relative to the program.
Loaded templates are kept by (path, size, modification time), so a template saved while an
editor session runs is read again.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..core.resources import template_search_path


class TemplateLoader:
    """Finds and loads templates; ``search_path`` (folders) replaces the default search path."""

    def __init__(self, search_path=None) -> None:
        self.search_path = None if search_path is None else [Path(p) for p in search_path]
        self._cache: dict[str, tuple[tuple, object]] = {}

    def folders(self, program_file: str | None) -> list[Path]:
        """Where ``import NAME`` looks for ``NAME.yaml``, in order, for a program at ``program_file``."""
        if self.search_path is not None:
            return list(self.search_path)

        return template_search_path(program_file)

    def candidates(self, source: str, is_path: bool, program_file: str | None) -> list[Path]:
        """The files an import of ``source`` may name, in the order they are tried."""
        if is_path:
            base = Path(program_file).parent if program_file and not program_file.startswith("<") else Path.cwd()
            return [base / source]
        return [d / f"{source}.yaml" for d in self.folders(program_file)]

    def find(self, source: str, is_path: bool, program_file: str | None) -> Path | None:
        """The template file an import names, or None when no candidate is a file."""
        return next((c for c in self.candidates(source, is_path, program_file) if c.is_file()), None)

    def known(self, program_file: str | None) -> list[str]:
        """Names ``import NAME`` would find (for "did you mean")."""
        return sorted({f.stem for d in self.folders(program_file) if d.is_dir() for f in d.glob("*.yaml")})

    def load(self, path):
        """The :class:`~hila_lang.osila.template.Template` in ``path`` (cached while the file is unchanged;
        its loading errors are :func:`hila_lang.osila.template.load_template`'s)."""
        # lazy: loads numpy, which importing this module does not
        from ..osila.template import load_template

        key = str(path)
        try:
            st = os.stat(path)
            stamp = (st.st_size, st.st_mtime_ns)
        except OSError:
            return load_template(path)  # its own error
        hit = self._cache.get(key)
        if hit is not None and hit[0] == stamp:
            return hit[1]
        template = load_template(path)
        self._cache[key] = (stamp, template)
        return template

    __call__ = load  # a loader is also the ``load_template(path)`` callable older callers pass
