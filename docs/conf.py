"""Sphinx configuration of the skmba documentation.

Build from the repository root with warnings as errors::

    python -m sphinx -W -b html docs docs/_build/html
"""

import os
import re
import shutil
import tempfile
import warnings

# The examples factor matrices of a few dozen rows, for which threaded BLAS
# only adds overhead; on a busy machine its threads contend for the cores and
# an example can run a hundred times slower. Use one thread unless the
# environment says otherwise (set before NumPy is first imported).
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import matplotlib  # noqa: E402  (after the thread settings)

matplotlib.use("Agg")  # the gallery runs headless

import skmba  # noqa: E402

# -- Project -----------------------------------------------------------------
project = "skmba"
author = "skmba developers"
copyright = "skmba developers"
release = skmba.__version__
version = ".".join(release.split(".")[:2])

# -- General -----------------------------------------------------------------
extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
]
# No intersphinx: the build must not need the network.

templates_path = ["_templates"]
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "**.ipynb_checkpoints"]
root_doc = "index"
default_role = "literal"  # `x` renders as code rather than a broken reference

# autodoc / autosummary
autosummary_generate = True
autodoc_default_options = {"members": True, "inherited-members": True}
autodoc_typehints = "none"  # types are in the numpydoc sections

# numpydoc: members are listed by the autosummary class template, not by
# numpydoc (which would list them twice and build a second toctree).
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_attributes_as_param_list = True


# -- Sphinx-Gallery ------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": "../examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    # Backreferences feed the "Examples using ..." mini-galleries of the API
    # pages; they live with the other generated files.
    "doc_module": ("skmba",),
    "backreferences_dir": os.path.join("generated", "backreferences"),
    "reference_url": {"skmba": None},
    "image_scrapers": ("matplotlib",),
    "matplotlib_animations": False,
    "write_computation_times": False,
    "abort_on_example_error": True,
    "min_reported_time": 1,
}

# The truss sensor-design example saves a table and a figure into the folder
# named by SKMBA_SENSOR_VALIDATION_DIR (default ./skmba-sensor-validation).
# During the build it writes into a temporary folder, removed when the build
# finishes, so that the build leaves nothing behind in the repository.
_VALIDATION_DIR = tempfile.mkdtemp(prefix="skmba-sensor-validation-")
os.environ["SKMBA_SENSOR_VALIDATION_DIR"] = _VALIDATION_DIR


def _remove_validation_dir(app, exception):
    shutil.rmtree(_VALIDATION_DIR, ignore_errors=True)


# Keep the build output free of a known, harmless matplotlib message when the
# gallery closes figures under the Agg backend.
warnings.filterwarnings(
    "ignore",
    category=UserWarning,
    message="FigureCanvasAgg is non-interactive, and thus cannot be shown",
)

# -- HTML --------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"skmba {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
}
html_show_sourcelink = False


# -- Inherited scikit-learn docstrings ---------------------------------------
# Methods inherited from scikit-learn (score, get_metadata_routing,
# set_*_request) refer to labels and glossary terms of scikit-learn's own
# documentation. Without intersphinx (no network) they cannot resolve, so
# they are rendered as plain text in those docstrings only.
_SPHINX_ROLE = re.compile(r":(?:ref|term|doc):`(?:([^`<]*?)\s*<[^`>]*>|([^`]*))`")


def _plain_sklearn_references(app, what, name, obj, options, lines):
    module = getattr(obj, "__module__", None) or ""
    if not module.startswith("sklearn"):
        return
    for i, line in enumerate(lines):
        lines[i] = _SPHINX_ROLE.sub(
            lambda m: "*" + (m.group(1) or m.group(2)).strip() + "*", line
        )


def setup(app):
    app.connect("autodoc-process-docstring", _plain_sklearn_references)
    app.connect("build-finished", _remove_validation_dir)
