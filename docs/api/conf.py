# Sphinx configuration of the kfx Python API reference (make docs; issue 21). autodoc reads the
# docstrings of the built package (PYTHONPATH set by the Makefile); they carry the C++ doc comments of
# include/kfx/*.hpp (python/gen_cpp_docs.py), written in the plain-text notation of docs/notation.md,
# not reStructuredText, so every docstring is shown as a literal block.
project = "kfx"
author = "the kfx authors"
copyright = "the kfx authors, BSD-3-Clause"
extensions = ["sphinx.ext.autodoc"]
autodoc_default_options = {"members": True, "imported-members": True, "undoc-members": True}
autodoc_member_order = "alphabetical"
html_theme = "alabaster"
highlight_language = "none"  # the literal docstrings are math notation, not Python
exclude_patterns = ["_build"]

try:
    import kfx

    release = version = kfx.__version__
except ImportError:  # the Makefile puts the built package on PYTHONPATH
    release = version = "unknown"


def _as_literal(app, what, name, obj, options, lines):
    if lines:
        lines[:] = ["::", ""] + ["   " + line for line in lines] + [""]


def setup(app):
    app.connect("autodoc-process-docstring", _as_literal)
