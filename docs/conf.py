"""Sphinx configuration of the s2gen documentation.

Build: ``python -m sphinx -W --keep-going -b html docs docs/_build/html`` (warnings are errors;
the gallery in examples/gallery runs during the build, its figures come from the run).
"""

from __future__ import annotations

import sys
from pathlib import Path

import s2gen

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

project = "s2gen"
author = "the s2gen authors"
copyright = "the s2gen authors"
release = s2gen.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
    "s2gen_capi",
    "s2gen_docstrings",
    "s2gen_run",
    "s2gen_tables",
]

# our docstrings are Google style with "Example:" sections of doctests, and name code in
# single backquotes (Markdown habit): render those as code, not as italic titles
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_rtype = False
napoleon_use_ivar = True
default_role = "code"

autodoc_member_order = "bysource"
autodoc_typehints = "signature"
autodoc_default_options = {"members": True}
autosummary_generate = False

exclude_patterns = ["_build"]
templates_path: list[str] = []

sphinx_gallery_conf = {
    "examples_dirs": str(HERE.parent / "examples" / "gallery"),
    "gallery_dirs": str(HERE / "auto_examples"),
    "filename_pattern": r"/plot_",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "abort_on_example_error": True,
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
}

html_theme = "alabaster"
html_title = f"s2gen {release}"
html_static_path: list[str] = []
html_theme_options = {"description": "Mechanics on (S²)ⁿ: equations, integrators, C and NumPy"}
