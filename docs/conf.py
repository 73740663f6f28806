"""Sphinx configuration of gshade's documentation (``sphinx-build -W -n docs docs/_build/html``).

Tools, chosen for what the libraries gshade's users know do (scikit-image, PyVista,
Mitsuba 3): numpydoc for the API reference from the docstrings, sphinx-gallery for the
examples (each a script run at build time, its pictures the real output, downloadable as a
script or a Jupyter notebook), MyST-NB for the tutorial notebook (executed at build time),
and the PyData theme.  ``_ext/gshade_reference.py`` writes the command-line, scene-key and
shape-function references from gshade's parser and registries, as ``gshade --help``,
``gshade keys`` and ``gshade shapes`` print them.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

import gshade  # noqa: E402

project = "gshade"
author = "the gshade developers"
copyright = "2026, the gshade developers"
release = version = gshade.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
    "myst_nb",
    "gshade_reference",
]

# the examples and the notebook render small pictures: one thread of BLAS each, as in gshade
os.environ.setdefault("OMP_NUM_THREADS", "1")

source_suffix = {".rst": "restructuredtext", ".ipynb": "myst-nb"}
# sphinx-gallery writes a notebook beside each example page: a download, not a source
exclude_patterns = [
    "_build",
    "**.ipynb_checkpoints",
    "examples/README.txt",
    "auto_examples/**.ipynb",
]
templates_path = ["_templates"]

autosummary_generate = True
autodoc_typehints = "none"  # numpydoc writes the types from the signatures' docstrings
autodoc_default_options = {"members": False}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_validation_checks: set[str] = set()

# -n: every reference between pages (:ref:, :doc:, labels, downloads) must resolve; a
# docstring's Python cross-reference to a name the API reference does not document (a
# module-local helper, an internal module) is shown as plain code instead of a link
nitpick_ignore_regex = [(r"py:.*", r".*")]

# no network at build time: intersphinx only from inventories kept beside the docs, if any
intersphinx_mapping: dict[str, tuple[str, str | None]] = {}

sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "abort_on_example_error": True,
    "show_memory": False,
    "plot_gallery": "True",
}

nb_execution_mode = "force"  # the tutorial runs at every build
nb_execution_timeout = 600
nb_execution_raise_on_error = True
# a rendered image shows itself in Jupyter as the inspection page (an iframe, every channel
# embedded); the static site shows its PNG, a fraction of the size
nb_mime_priority_overrides = [("html", "image/png", 0)]
myst_enable_extensions = ["dollarmath"]

html_theme = "pydata_sphinx_theme"
html_title = f"gshade {version}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
}
html_static_path: list[str] = []
html_last_updated_fmt = None
