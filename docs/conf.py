"""Sphinx configuration of the slam_env documentation: furo, Markdown pages through
myst-parser, and the API reference from the docstrings (autodoc, napoleon, mathjax).

Build it with ``make docs`` (``sphinx-build -W --keep-going -n -b html docs
docs/_build/html``): every warning is an error, and nitpicky mode makes every
cross-reference that leads nowhere one.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))  # this checkout's packages, as the tests import them
sys.path.insert(0, str(DOCS / "_ext"))
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")  # importing the renderer opens nothing

import slam_env  # noqa: E402

project = "slam_env"
author = "the slam_env authors"
copyright = "the slam_env authors"
release = slam_env.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "slam_docs",  # docs/_ext: the docstrings as written, re-exported names linked
    "env_pages",  # docs/_ext: docs/envs/*.md written afresh from the code
]
source_suffix = {".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_ext", "Thumbs.db", ".DS_Store"]

# Markdown: GitHub's heading anchors (the pages link to #sections as GitHub spells
# them), $…$ and $$…$$ math, ::: fences.
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 4

# The API reference: every module's public names, in source order.
autodoc_default_options = {"undoc-members": True, "ignore-module-all": True}
autodoc_member_order = "bysource"
autodoc_typehints = "signature"
# Not the source's default expressions: ActiveSLAMEnv.__init__ takes **options and its
# signature, the option table's defaults, is built, so the source has none to show.
autodoc_preserve_defaults = False
# A method without a docstring shows its signature, not the text of the Gymnasium (or
# stable-baselines3) method it overrides.
autodoc_inherit_docstrings = False
add_module_names = False
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_ivar = True  # "Attributes:" as fields: the members are documented on their own

nitpicky = True
# Types from outside the project that appear in signatures, with no inventory to link
# them to (the build runs offline): Python's builtins and standard library, numpy,
# gymnasium, and the few third-party libraries that agents' and plots' signatures name.
# Every other cross-reference must resolve.
nitpick_ignore_regex = [
    (r"py:.*", r"(builtins\.)?(int|float|bool|str|bytes|object|type|list|dict|tuple|set)"),
    (
        r"py:.*",
        r"(collections\.abc|typing|pathlib|os|enum|dataclasses|argparse|inspect|threading)\..+",
    ),
    (r"py:.*", r"(numpy|np)(\..+)?"),
    (r"py:.*", r"(gymnasium|gym)(\..+)?"),
    (r"py:.*", r"(ObsType|ActType)"),  # gymnasium's type variables
    (r"py:.*", r"(torch|stable_baselines3|sb3_contrib|matplotlib|pymunk|ray)\..+"),
    (r"py:class", r"VecEnv"),  # stable-baselines3's, imported only for type checking
]

html_theme = "furo"
html_title = f"slam_env {release}"
html_static_path: list[str] = []
