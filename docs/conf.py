"""Sphinx configuration of the ema_phm documentation (MyST Markdown pages in docs/).

Build: `.venv/bin/python -m sphinx -W --keep-going -b html docs build/docs` (test/test_docs.py
does, warnings as errors).  No extension reaches the network: no intersphinx.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# The CLI reference (cli.md) imports ema_phm.tools.cli from this checkout.
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

project = "ema_phm"
author = "the ema_phm developers"
copyright = "the ema_phm developers"

extensions = ["myst_parser", "sphinxarg.ext"]
source_suffix = {".md": "markdown"}
root_doc = "index"
# only .md files are sources: the benchmark rows (.json) beside the reports are not pages
exclude_patterns = ["_build"]

myst_enable_extensions = ["colon_fence", "deflist"]
# anchors for headings down to ####, so [text](page.md#a-heading) resolves
myst_heading_anchors = 4

html_theme = "alabaster"
html_title = "ema_phm"
html_show_sourcelink = False
