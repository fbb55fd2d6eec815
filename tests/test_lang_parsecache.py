"""The grammar's LALR tables kept in the cache folder (hila_lang/language/parsecache.py): a
parser loaded from the cache parses every shipped program to the same AST, and refuses a broken
program with the same error, as one built from the grammar; a damaged file is built again."""

from __future__ import annotations

import logging
import os
import subprocess
import sys
from pathlib import Path

import pytest

from hila_lang.core.errors import HilaSyntaxError
from hila_lang.language import parsecache, transformer

ROOT = Path(__file__).resolve().parents[1]
PROGRAMS = sorted((ROOT / "programs").rglob("*.hila"))
BROKEN = "task t {\n  run reach(\n}\n"


def _parse_all(caplog):
    """The ASTs of every shipped program, a syntax error's message, and whether lark read its
    tables from the cache, from a fresh grammar()."""
    transformer.grammar.cache_clear()
    caplog.clear()
    with caplog.at_level(logging.DEBUG, logger="lark"):
        asts = [transformer.parse_program(p.read_text(encoding="utf-8"), p.name) for p in PROGRAMS]
    loaded = not any("Saving grammar to cache" in r.getMessage() for r in caplog.records)  # not built
    with pytest.raises(HilaSyntaxError) as err:
        transformer.parse_program(BROKEN, "broken.hila")
    return asts, str(err.value), loaded


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("HILA_CACHE_DIR", str(tmp_path))
    yield tmp_path / "hila" / "grammar"
    transformer.grammar.cache_clear()  # the next test's grammar() is built as usual


def test_a_parser_from_the_cache_parses_like_one_built_from_the_grammar(cache, caplog):
    assert PROGRAMS
    built, built_error, was_loaded = _parse_all(caplog)
    assert not was_loaded
    assert sorted(p.name for p in cache.iterdir()) == [".lock", parsecache.cache_name(
        transformer.grammar_path().read_text(encoding="utf-8"), dict(transformer.PARSER_OPTIONS))]  # saved
    loaded, loaded_error, was_loaded = _parse_all(caplog)
    assert was_loaded  # the second grammar() read the tables
    assert loaded == built  # same AST, positions included
    assert loaded_error == built_error and "broken.hila" in loaded_error


def test_a_damaged_cache_file_is_built_again(cache, caplog):
    built, _, _ = _parse_all(caplog)
    (saved,) = cache.glob("parser-*")
    saved.write_bytes(b"\x80\x04not a parser")
    again, _, was_loaded = _parse_all(caplog)
    assert again == built and not was_loaded
    assert _parse_all(caplog)[2]  # written whole again: the next one loads it


def test_the_cache_name_follows_the_grammar_and_the_options():
    options = {"parser": "lalr", "start": ["start", "expr"]}
    name = parsecache.cache_name("start: 'a'", options)
    assert name == parsecache.cache_name("start: 'a'", dict(reversed(options.items())))
    assert name != parsecache.cache_name("start: 'b'", options)
    assert name != parsecache.cache_name("start: 'a'", {**options, "start": ["start"]})


def test_processes_building_at_once_all_parse_and_leave_a_whole_file(cache, caplog):
    """Four fresh processes start on an empty cache at once (the lock lets one build and write,
    the others read what it wrote): all parse the game, and the file left loads."""
    code = ("from hila_lang.language.transformer import parse_program; import sys; "
            "p = parse_program(open(sys.argv[1]).read(), 'game.hila'); print(len(p.items))")
    env = {**os.environ, "HILA_CACHE_DIR": str(cache.parent.parent)}
    game = str(ROOT / "programs" / "game.hila")
    procs = [subprocess.Popen([sys.executable, "-c", code, game], env=env, stdout=subprocess.PIPE, text=True)
             for _ in range(4)]
    outs = {p.communicate(timeout=120)[0] for p in procs}
    assert [p.returncode for p in procs] == [0, 0, 0, 0] and len(outs) == 1 and int(outs.pop()) > 0
    assert len(list(cache.glob("parser-*"))) == 1
    assert _parse_all(caplog)[2]  # loaded, not built again


def test_a_file_system_without_locks_still_parses(cache, caplog, monkeypatch):
    """``flock`` refused (ENOLCK on some network file systems): the parser is built and cached
    without the lock, not a traceback."""
    import fcntl

    def refuse(*_):
        raise OSError(37, "No locks available")

    monkeypatch.setattr(fcntl, "flock", refuse)
    built, _, was_loaded = _parse_all(caplog)
    assert built and not was_loaded
    assert _parse_all(caplog)[2]  # and read from the cache the next time


@pytest.mark.parametrize("kind", ["fifo", "symlink"])
def test_a_lock_file_that_is_not_a_file_is_left_alone(cache, caplog, tmp_path, kind):
    """A FIFO put where the lock file goes does not hang the parser (opened without blocking), a
    symlink there is not followed: the parser is built and cached without the lock."""
    cache.mkdir(parents=True)
    target = tmp_path / "elsewhere.txt"
    if kind == "fifo":
        os.mkfifo(cache / ".lock")
    else:
        target.write_text("keep")
        (cache / ".lock").symlink_to(target)
    built, _, was_loaded = _parse_all(caplog)
    assert built and not was_loaded
    assert _parse_all(caplog)[2]  # cached all the same
    if kind == "symlink":
        assert target.read_text() == "keep" and (cache / ".lock").is_symlink()
