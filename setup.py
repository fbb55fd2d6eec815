"""Package discovery that pyproject.toml alone cannot express.

The grammar, the learned templates and the example programs live at the top of the checkout
(``grammar/``, ``primitives/``, ``programs/``, where people look for them) and are installed
inside the package as ``hila_lang.grammar``, ``hila_lang.primitives`` and ``hila_lang.programs``,
so an installed ``hila`` finds them through ``importlib.resources`` whether the install is
editable or not, from any folder (``hila_lang/core/resources.py``).
"""

from setuptools import find_packages, setup

SHIPPED = {"hila_lang.grammar": "grammar", "hila_lang.primitives": "primitives",
           "hila_lang.primitives.letters": "primitives/letters", "hila_lang.programs": "programs"}

setup(
    packages=find_packages(include=["hila_lang", "hila_lang.*"]) + list(SHIPPED),
    package_dir=SHIPPED,
)
