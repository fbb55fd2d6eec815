"""The checkout's fallback of :func:`hila_lang.core.resources.shipped` counts the module's depth:
``hila_lang/core/resources.py`` finds ``grammar/``, ``primitives/`` and ``programs/`` two folders
up (an installed wheel carries them inside the package; ``tests/test_install.py``)."""

import importlib.util
from pathlib import Path

import pytest

from hila_lang.core import resources

CHECKOUT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("kind", sorted(resources.SHIPPED))
def test_a_checkout_finds_what_it_ships_at_its_top(kind):
    if importlib.util.find_spec(f"hila_lang.{kind}") is not None:
        pytest.skip("an installed hila carries its data inside the package")
    assert resources.shipped(kind) == CHECKOUT / resources.SHIPPED[kind]


def test_the_grammar_is_found_from_the_checkout():
    assert resources.grammar_path() == resources.shipped("grammar") / "hila.lark"
    assert resources.grammar_path().is_file()
