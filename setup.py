"""Package discovery that pyproject.toml alone cannot express.

The grammar lives at the top of the checkout (``grammar/hila.lark``, where people look for it)
and is installed inside the package as ``hila_lang.grammar``, so an installed ``hila`` finds it
through ``importlib.resources`` whether the install is editable or not.
"""

from setuptools import find_packages, setup

setup(
    packages=find_packages(include=["hila_lang", "hila_lang.*"]) + ["hila_lang.grammar"],
    package_dir={"hila_lang.grammar": "grammar"},
)
