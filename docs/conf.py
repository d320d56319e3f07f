"""Sphinx configuration for the sklearn-ifog documentation."""

import os
import re
import sys
from datetime import date

import sklearn_ifog

os.environ.setdefault("MPLBACKEND", "Agg")
sys.path.insert(0, os.path.abspath("."))

project = "sklearn-ifog"
author = "sklearn-ifog developers"
copyright = f"{date.today().year}, {author}"
version = release = sklearn_ifog.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
]

templates_path = ["_templates"]
exclude_patterns = [
    "_build",
    "generated/_pages",
    "auto_examples/*.ipynb",
    "auto_examples/*.py",
    "auto_examples/*.zip",
]
root_doc = "index"

autosummary_generate = True
autodoc_default_options = {"members": True, "inherited-members": False}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
# Cross-references to other projects would need the network (intersphinx): keep them as
# literals instead.
numpydoc_xref_param_type = False

html_theme = "pydata_sphinx_theme"
html_title = "sklearn-ifog"
html_static_path = ["_static"]
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "header_links_before_dropdown": 6,
    "navbar_align": "left",
    "secondary_sidebar_items": ["page-toc", "sg_download_links"],
}
# Pages without sub-pages need no section navigation: give their tables the width.
html_sidebars = {
    page: []
    for page in ("index", "getting_started", "cli", "paper_comparison", "api", "changelog")
}
html_css_files = ["custom.css"]

sphinx_gallery_conf = {
    "examples_dirs": "../examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "within_subsection_order": "_gallery_order.ReadingOrder",
    "download_all_examples": False,
    "show_memory": False,
    "remove_config_comments": True,
    "abort_on_example_error": True,
    "matplotlib_animations": False,
    # Back-references: the "Examples using ..." mini-galleries of the API pages.
    "doc_module": ("sklearn_ifog",),
    "backreferences_dir": "generated/backreferences",
    "image_scrapers": ("matplotlib",),
}


# In numpydoc type lines such as "ndarray of shape (n_centers_, n_features_in_)", reST reads
# a word ending in "_" as a link to a target of that name; scikit-learn writes them in
# backquotes. Escape the bare ones so a docstring can say it either way.
_BARE_TRAILING_UNDERSCORE = re.compile(r"(?<![`\\\w])([A-Za-z]\w*?)_(?=[\s,)\]]|$)")


def _escape_shape_names(app, what, name, obj, options, lines):
    for index, line in enumerate(lines):
        if "shape (" in line or "shape=(" in line:
            lines[index] = _BARE_TRAILING_UNDERSCORE.sub(r"\1\\_", line)


def _generate_pages(app):
    """Write the pages computed from the package: CLI help and the paper comparison."""
    import _hooks

    _hooks.write_cli_reference()
    _hooks.write_paper_comparison()


def setup(app):
    """Hook the build-time pages into the build (see ``_hooks.py``)."""
    app.connect("builder-inited", _generate_pages)
    app.connect("autodoc-process-docstring", _escape_shape_names)
