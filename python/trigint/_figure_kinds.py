"""Every kind of figure the experiments know, registered once: the function that runs a spec
into data, the one that measures its claims and the one that draws it, each named as
``"module:function"`` and imported when first used. ``trigint.experiments.schema.KEYS`` holds
each kind's spec keys (checked against this table by the tests).

A new kind of figure: its keys in ``schema.KEYS`` / ``schema.REQUIRED``, a row here, and its
module (a runner, claims and a plot; see ``experiments/strata_runner.py``).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass


@dataclass(frozen=True)
class FigureKind:
    """Where one kind of figure's code lives.

    Attributes
    ----------
    run : str
        ``"module:function"`` taking the spec's ``[figure]`` table, returning an xarray.Dataset.
    claims : str
        ``"module:function"`` taking that Dataset, returning the measured claims.
    plot : str
        ``"module:function"`` taking that Dataset, returning a matplotlib Figure.
    """

    run: str
    claims: str
    plot: str


_EXP = "trigint.experiments"
KINDS: dict[str, FigureKind] = {
    "families": FigureKind(f"{_EXP}.runners:run_families", f"{_EXP}.claims:_families",
                           "trigint.plotting:_plot_families"),
    "perturbed": FigureKind(f"{_EXP}.runners:run_perturbed", f"{_EXP}.claims:_perturbed",
                            "trigint.plotting:_plot_perturbed"),
    "scan": FigureKind(f"{_EXP}.runners:run_scan", f"{_EXP}.claims:_scan", "trigint.plotting:_plot_scan"),
    "methods": FigureKind(f"{_EXP}.runners:run_methods", f"{_EXP}.claims:_methods", "trigint.plotting:_plot_methods"),
    "wave": FigureKind(f"{_EXP}.wave_runner:run_wave", f"{_EXP}.claims:_wave", "trigint.plotting:_plot_wave"),
    "strata": FigureKind(f"{_EXP}.strata_runner:run_strata", f"{_EXP}.strata_runner:strata_claims",
                         "trigint.plotting:_plot_strata"),
}


def function(kind: str, role: str):
    """The function of `kind` for `role` ("run", "claims" or "plot").

    Examples
    --------
    >>> from trigint._figure_kinds import function
    >>> function("methods", "run").__name__
    'run_methods'
    """
    if kind not in KINDS:
        raise ValueError(f"figure kind {kind!r} is not one of {', '.join(KINDS)}")
    module, name = getattr(KINDS[kind], role).split(":")
    return getattr(importlib.import_module(module), name)
