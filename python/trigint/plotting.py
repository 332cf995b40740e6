"""Figures. The only module that imports matplotlib (with the non-interactive Agg backend
unless one is already chosen)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _pyplot():
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "pdf", "svg") and not _interactive():
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _interactive() -> bool:
    import sys

    return hasattr(sys, "ps1") or "ipykernel" in sys.modules


def plot_deviation(solutions, energy: str = "oscillatory", *, ax=None, labels=None, title=None):
    """E(t) − E(0) against t for one or several solutions (first black, the others grey).

    Examples
    --------
    >>> import numpy as np, trigint as ti
    >>> from trigint.plotting import plot_deviation
    >>> prob = ti.problems.fpu(); q0, p0 = ti.problems.fpu_initial()
    >>> sol = ti.integrate(prob, "B", q0, p0, h=2*np.pi/3/50, t_end=30.0)
    >>> ax = plot_deviation(sol)
    """
    plt = _pyplot()
    solutions = list(solutions) if isinstance(solutions, list | tuple) else [solutions]
    if ax is None:
        _, ax = plt.subplots(figsize=(7, 2.8), constrained_layout=True)
    for i, sol in enumerate(solutions):
        dev = sol.deviation(energy)
        style = dict(color="black", lw=0.8, zorder=3) if i == 0 else dict(color="0.6", lw=0.6)
        ax.plot(sol.t, dev, label=labels[i] if labels else None, **style)
    ax.axhline(0.0, color="0.8", lw=0.5, zorder=0)
    ax.set_xlabel("t")
    ax.set_ylabel(f"{energy.replace('_', ' ')} energy: E(t) − E(0)")
    ax.set_xlim(solutions[0].t[0], solutions[0].t[-1])
    if title:
        ax.set_title(title, fontsize=10)
    if labels:
        ax.legend(fontsize=8, frameon=False)
    return ax


def save(fig_or_ax, path: str | Path, formats=("png", "pdf")) -> list[Path]:
    """Saves a figure (or an axis's figure) as PNG and PDF next to each other."""
    fig = getattr(fig_or_ax, "figure", fig_or_ax)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    written = []
    for fmt in formats:
        target = path.with_suffix(f".{fmt}")
        fig.savefig(target, dpi=200)
        written.append(target)
    _pyplot().close(fig)
    return written


def max_abs(values) -> float:
    """max |x| of an array-like (a helper for axis limits)."""
    return float(np.max(np.abs(np.asarray(values))))
