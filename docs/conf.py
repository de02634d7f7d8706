"""Sphinx configuration of haptex's documentation site.

Build: ``pip install ".[docs]"`` then ``python -m sphinx -W --keep-going -b html docs docs/_build/html``.
Every number a page shows is computed by the build: the gallery (``examples/plot_*.py``) is
executed, and the pages listed in :data:`COMPUTED` are Jinja2 templates rendered with the values
of ``docs/_numbers.py``.
"""

import os
import sys
from pathlib import Path

import haptex

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS))

project = "haptex"
author = "the haptex developers"
copyright = "2026, the haptex developers"
version = release = haptex.__version__

extensions = [
    "myst_parser",
    "sphinx_design",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
    "sphinx_click",
    "sphinx_gallery.gen_gallery",
]

templates_path = ["_templates"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "_templates", "**/*.ipynb", "**/*.py.md5", "**/*.codeobj.json", "sg_execution_times.rst"]
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
suppress_warnings = ["myst.header"]

# --- API reference -------------------------------------------------------------------------
autosummary_generate = True
autodoc_default_options = {"members": True, "inherited-members": False, "show-inheritance": True}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_xref_param_type = False
numpydoc_attributes_as_param_list = False
# A public docstring that lacks what numpydoc checks here fails the build by name (-W):
#   PR01 a parameter not documented, PR02 a documented parameter that does not exist,
#   GL08 no docstring at all, SS01 no summary line, RT01 a function that returns without
#   saying what (not for properties and classes).
numpydoc_validation_checks = {"PR01", "PR02", "GL08", "SS01", "RT01"}
import re as _re

numpydoc_validation_exclude = {
    r"\.__init__$",
    r"\.__call__$",
    r"\.__repr__$",
    r"\.__post_init__$",
}  # (no allow-list: every public name's docstring passes, or the build fails naming it)

intersphinx_mapping = {
    "python": ("https://docs.python.org/3", None),
    "numpy": ("https://numpy.org/doc/stable/", None),
    "scipy": ("https://docs.scipy.org/doc/scipy/", None),
    "xarray": ("https://docs.xarray.dev/en/stable/", None),
    "dask": ("https://docs.dask.org/en/stable/", None),
    "trimesh": ("https://trimesh.org/", None),
    "SurfaceTopography": ("https://contactengineering.github.io/SurfaceTopography/", None),
}
# The build runs offline (this project's machines reach the package registries only): each
# inventory is fetched when reachable, and an unreachable one is not an error of the build.
intersphinx_timeout = 3
intersphinx_disabled_reftypes = ["*"]
if os.environ.get("HAPTEX_DOCS_OFFLINE", "1") == "1":
    intersphinx_mapping = {}

# --- gallery -------------------------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": ["../examples/gallery"],
    "gallery_dirs": ["gallery"],
    "filename_pattern": r"/plot_",
    "ignore_pattern": r"__init__\.py",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "abort_on_example_error": False,
    "only_warn_on_example_error": False,
    "show_memory": False,
    "min_reported_time": 1e9,
    "write_computation_times": False,
}

# --- theme ---------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"haptex {release}"
html_static_path = []
html_theme_options = {
    # the sidebar's navigation tree rendered collapsed (pydata-sphinx-theme's advice for large sites)
    "collapse_navigation": True,
    "navigation_depth": 3,
    "show_toc_level": 2,
    "header_links_before_dropdown": 7,
    "navbar_align": "left",
}
html_sidebars = {"index": [], "reference/generated/*": []}  # the API pages: the navbar and their own contents
# (the sidebar's tree, rendered on each of the ~380 generated pages, was 31 of the build's 103 s, profiled)

# --- pages whose numbers the build computes ------------------------------------------------
COMPUTED = {"explanation/paper", "reference/presets", "guides/devices-and-stability", "explanation/algorithms", "explanation/validation",
            "guides/data-driven-textures"}


def _render(app, docname, source):
    if docname not in COMPUTED:
        return
    import jinja2

    import _numbers

    env = jinja2.Environment(undefined=jinja2.StrictUndefined, autoescape=False, keep_trailing_newline=True)
    env.filters["g"] = lambda value, digits=4: f"{value:.{digits}g}"
    source[0] = env.from_string(source[0]).render(**_numbers.context(docname))


_BAR = _re.compile(r"(?<![|\\])\|(?!\|)")


def _plain_bars(app, what, name, obj, options, lines):
    """Docstrings write absolute values and norms as plain text, |x| (read as such by help());
    reStructuredText would take them for substitutions, so each lone bar is shown as a bar."""
    for i, line in enumerate(lines):
        if "|" in line and not line.lstrip().startswith(("| ", "+")):  # (a line block, a table's row)
            lines[i] = _BAR.sub(r"\\|", line)


def setup(app):
    app.connect("source-read", _render)
    app.connect("autodoc-process-docstring", _plain_bars)
