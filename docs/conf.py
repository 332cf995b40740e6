"""Sphinx configuration: formulas rendered by MathJax from a copy shipped with the site
(sphinx-mathjax-offline), so the pages load nothing from the network; API reference from the
docstrings (numpydoc), a gallery of executed examples (sphinx-gallery), narrative pages in
Markdown (MyST), and a reproduction page built from a fresh run of the paper's figures."""

from __future__ import annotations

import logging
import os
import subprocess
import sys
from pathlib import Path

import trigint
import trigint.experiments

HERE = Path(__file__).parent
# A handler on the root logger first, at WARNING: a theme dependency otherwise configures it at
# INFO when imported, and the Dask gallery example would print its scheduler's chatter.
logging.basicConfig(level=logging.WARNING)
project = "trigint"
author = "the trigint developers"
copyright = "2026, the trigint developers"
version = release = trigint.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "sphinx.ext.mathjax",
    "sphinx-mathjax-offline",  # MathJax 3 from the package, copied into _static/mathjax
]
myst_enable_extensions = ["dollarmath", "amsmath"]  # $...$ and $$...$$ in the Markdown pages
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "_generated/**/*.md", "examples/README.txt"]
html_theme = "furo"
html_title = f"trigint {release}"
html_static_path = ["_static"]
html_css_files = ["custom.css"]  # wrapped code lines, numbers on one line
autosummary_generate = True
templates_path = ["_templates"]  # the class page: methods, no __init__ or blank attribute table
autodoc_default_options = {"members": True, "inherited-members": False}
numpydoc_show_class_members = False
numpydoc_validation_checks: set[str] = set()
suppress_warnings = ["myst.header"]

sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "write_computation_times": False,  # its page loads scripts from CDNs
}


def _reproduction() -> None:
    """Runs the paper's figures (full settings, about 35 s on 2 cores) into _generated/, unless
    they are there already; TRIGINT_DOCS_QUICK=1 runs the reduced versions."""
    out = HERE / "_generated" / "reproduction"
    if (out / "report.md").exists():
        return
    out.mkdir(parents=True, exist_ok=True)
    args = [sys.executable, "-m", "trigint.cli", "reproduce", "all", "--out", str(out)]
    if os.environ.get("TRIGINT_DOCS_QUICK"):
        args.append("--quick")
    subprocess.run(args, check=True)


_reproduction()


def _reproduction_page() -> None:
    """reproduction.md: each figure next to its measured claims, then the benchmark table."""
    out = HERE / "_generated" / "reproduction"
    report = (out / "report.md").read_text(encoding="utf-8").splitlines()
    header = [line for line in report if line.startswith("| figure") or line.startswith("|---")]
    summary = [line for line in report if line.startswith(("Run:", "Machine:")) or line.endswith("claims pass.")
               or "(MEASURED)" in line and not line.startswith("|")]
    titles = {f: trigint.experiments.load(f)["figure"]["title"] for f in trigint.experiments.FIGURES}
    parts = [
        "# Reproduction of the paper's figures\n",
        "Generated when these pages were built, by `trigint reproduce all` (the same as "
        "`make reproduce`): every figure of §4 of the paper at full resolution, and every claim the "
        "paper makes about it, measured on the data with its tolerance; then a wave-equation "
        "experiment beyond the paper (`wave1`) and the energy strata of a second wave paper (`strata`), "
        "each with its claims. " + " ".join(summary) + "\n",
        "Where the paper's statement had to be made precise to be measured, the claim's wording in "
        "the tables says how (Figure 3: the median over 9 realizations of the initial values where "
        "the deviation is a random walk; Figure 5: the growth rate fitted on the first quarter of "
        "the run). Each figure's spec states and explains these choices in its comments and "
        "caption: `trigint spec fig3` prints it.\n",
    ]
    for fig, title in titles.items():
        rows = [line for line in report if line.startswith(f"| {fig} ")]
        label = (f"Fig. {fig[3:]}" if fig.startswith("fig") else
                 "A second wave paper (Gauckler, Hairer, Lubich, Weiss 2012), strata" if fig == "strata" else
                 f"Beyond the paper, {fig}")
        parts += [f"## {label}: {title}\n", f"![{fig}](_generated/reproduction/{fig}.png)\n",
                  "\n".join(header + rows) + "\n"]
    bench = (HERE.parent / "benchmarks" / "results.md").read_text(encoding="utf-8")
    bench = bench.replace("](results.png)", "](../benchmarks/results.png)")
    parts += ["## Speed\n", "From `make bench` (`benchmarks/results.md`), measured on the machine named there; "
              "every timing next to the strongest baseline of the same run.\n",
              "![benchmarks](../benchmarks/results.png)\n", _demote(bench)]
    (HERE / "reproduction.md").write_text("\n".join(parts), encoding="utf-8")


def _demote(markdown: str) -> str:
    """Headings one level down, so an included page sits under a section."""
    return "\n".join("##" + line if line.startswith("#") else line for line in markdown.splitlines())


_reproduction_page()


def _escape_bars(app, what, name, obj, options, lines) -> None:
    """Docstrings write absolute values as |x|, which reStructuredText reads as a substitution:
    escape the bars outside doctest lines."""
    for i, line in enumerate(lines):
        stripped = line.lstrip()
        if "|" in line and not stripped.startswith((">>>", "...")):
            lines[i] = line.replace("|", r"\|")


def setup(app):
    app.connect("autodoc-process-docstring", _escape_bars, priority=400)
