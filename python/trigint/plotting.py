"""Figures. The only module that imports matplotlib (with the non-interactive Agg backend
unless one is already chosen)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ._curves import runaway_curves


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

    Parameters
    ----------
    solutions : Solution, list of Solution or xarray.Dataset
        The runs to plot: solutions from :func:`trigint.integrate`, or the Dataset of
        :func:`trigint.ensemble` run with ``save_every`` (one curve per trajectory).
    energy : str
        The energy (a name of ``Solution.energies``, or of the ensemble's ``energy``).
    ax : matplotlib Axes, optional
        Where to draw (default: a new figure).
    labels : str or list of str, optional
        One legend label per solution (per trajectory of an ensemble).
    title : str, optional
        The axes' title.

    Returns
    -------
    matplotlib Axes

    Examples
    --------
    >>> import numpy as np, trigint as ti
    >>> from trigint.plotting import plot_deviation
    >>> prob = ti.problems.fpu(); q0, p0 = ti.problems.fpu_initial()
    >>> sol = ti.integrate(prob, "B", q0, p0, h=2*np.pi/3/50, t_end=30.0)
    >>> ax = plot_deviation(sol)
    >>> ds = ti.ensemble(prob, "B", q0, p0, h=[0.04, 0.05], t_end=30.0, save_every=10, progress=False)
    >>> ax = plot_deviation(ds, labels=["h = 0.04", "h = 0.05"])
    """
    curves = _deviation_curves(solutions, energy)
    if labels is not None:
        labels = [labels] if isinstance(labels, str) else list(labels) if isinstance(labels, list | tuple) else None
        if labels is None or not all(isinstance(x, str) for x in labels):
            raise TypeError("labels: expected a list of strings, one per solution")
        if len(labels) != len(curves):
            raise ValueError(f"labels: {len(labels)} label(s) for {len(curves)} "
                             f"{'solution' if len(curves) == 1 else 'solutions'}; give one per solution")
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(7, 2.8), constrained_layout=True)
    for i, (t, dev) in enumerate(curves):
        style = dict(color="black", lw=0.8, zorder=3) if i == 0 else dict(color="0.6", lw=0.6)
        ax.plot(t, dev, label=labels[i] if labels else None, **style)
    ax.axhline(0.0, color="0.8", lw=0.5, zorder=0)
    ax.set_xlabel("t")
    ax.set_ylabel(f"{energy.replace('_', ' ')} energy: E(t) − E(0)")
    ax.set_xlim(min(t[0] for t, _ in curves), max(t[-1] for t, _ in curves))
    if title:
        ax.set_title(title, fontsize=10)
    if labels:
        ax.legend(fontsize=8, frameon=False)
    return ax


#: what plot_deviation takes, for its errors
DEVIATION_INPUTS = ("a Solution (from ti.integrate), a list of them, or the Dataset of ti.ensemble run with "
                    "save_every")


def _deviation_curves(solutions, energy: str) -> list[tuple[np.ndarray, np.ndarray]]:
    """(t, E(t) − E(0)) of each curve plot_deviation draws, from what it was given."""
    from .solution import Solution

    if isinstance(solutions, Solution):
        solutions = [solutions]
    if isinstance(solutions, list | tuple):
        if not solutions:
            raise ValueError("solutions: give at least one Solution")
        for i, sol in enumerate(solutions):
            if not isinstance(sol, Solution):
                raise TypeError(f"solutions: expected {DEVIATION_INPUTS}; item {i} is {type(sol).__name__}")
        return [(np.asarray(sol.t), np.asarray(sol.deviation(energy))) for sol in solutions]
    kind = type(solutions).__name__
    if kind == "DataArray":
        raise TypeError(f"solutions: expected {DEVIATION_INPUTS}, got an xarray DataArray (a scan's maximal "
                        "deviation per step size has no time axis: draw it with its own .plot())")
    if kind != "Dataset":
        raise TypeError(f"solutions: expected {DEVIATION_INPUTS}, got {kind}")
    ds = solutions
    if not {"energies", "t", "step", "initial_energies"} <= set(ds.variables) or "trajectory" not in ds.dims:
        raise TypeError(f"solutions: expected {DEVIATION_INPUTS}; this Dataset has no energies over time (an "
                        "ensemble run without save_every keeps only max_deviation: plot that against h, or run "
                        "it with save_every)")
    names = [str(n) for n in ds.energy.values]
    if energy not in names:
        main = [n for n in names if not n.startswith("oscillatory_")]
        blocks = [n for n in names if n.startswith("oscillatory_")]
        valid = main + (blocks if len(blocks) <= 2 else [f"{blocks[0]} … {blocks[-1]}"])
        raise KeyError(f"energy: unknown name {energy!r}; valid: {', '.join(valid)}")
    k = names.index(energy)
    curves = []
    for i in range(ds.sizes["trajectory"]):
        kept = ds.step.values[i] >= 0  # samples a shorter trajectory does not fill are padding
        curves.append((ds.t.values[i][kept], ds.energies.values[i][kept, k] - ds.initial_energies.values[i, k]))
    return curves


def save(fig_or_ax, path: str | Path, formats=("png", "pdf")) -> list[Path]:
    """Saves a figure (or an axis's figure) as PNG and PDF next to each other.

    Parameters
    ----------
    fig_or_ax : matplotlib Figure or Axes
        What to save.
    path : str or path
        The file name without its suffix.
    formats : sequence of str
        The suffixes to write.

    Returns
    -------
    list of path
        The files written.

    Examples
    --------
    >>> import tempfile, matplotlib
    >>> matplotlib.use("Agg")
    >>> from pathlib import Path
    >>> import matplotlib.pyplot as plt
    >>> from trigint.plotting import save
    >>> paths = save(plt.figure(), Path(tempfile.mkdtemp()) / "empty")
    >>> sorted(p.suffix for p in paths)
    ['.pdf', '.png']
    """
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


# --- the paper's figures -------------------------------------------------------------------

def figure(ds):
    """The figure of an experiment dataset (from :func:`trigint.experiments.run`), laid out like
    the paper's; returns a matplotlib Figure.

    Parameters
    ----------
    ds : xarray.Dataset
        A figure's data.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> from trigint import experiments
    >>> from trigint.plotting import figure
    >>> fig = figure(experiments.run(experiments.load("fig5", quick=True)))
    >>> type(fig).__name__
    'Figure'
    """
    from ._figure_kinds import KINDS, function

    kind = getattr(ds, "attrs", {}).get("kind") if type(ds).__name__ == "Dataset" else None
    if kind not in KINDS:
        got = "a Dataset without a figure kind" if type(ds).__name__ == "Dataset" else type(ds).__name__
        hint = "; a run's energies are drawn by plot_deviation" if type(ds).__name__ in ("Solution", "Dataset") else ""
        raise TypeError(f"ds: expected an experiment's Dataset, from trigint.experiments.run, got {got}{hint}")
    return function(kind, "plot")(ds)


#: the page width (inches) at which the figures' fonts have their nominal size: a figure
#: shown at the width of a page is scaled by PAGE_WIDTH / its width, so a wider figure gets
#: proportionally larger fonts (the five panels of Figure 3)
PAGE_WIDTH = 7.0
#: the caption's font size (points) on a figure PAGE_WIDTH wide
CAPTION_POINTS = 10.0


def _font_scale(fig) -> float:
    return max(1.0, fig.get_figwidth() / PAGE_WIDTH)


def _caption(fig, ds) -> None:
    """Lays the axes out above the spec's caption and draws it: the figure grows by the
    caption's height, and the caption's font scales with the figure's width, so that it stays
    as legible as the rest when the figure is shown at the width of a page."""
    import textwrap

    text = textwrap.fill(" ".join(ds.attrs.get("caption", "").split()), 95)
    if ds.attrs.get("quick"):
        text += "\n(reduced run: --quick)"
    size = CAPTION_POINTS * _font_scale(fig)
    lines = text.count("\n") + 1 if text.strip() else 0
    height = lines * size * 1.3 / 72 + 0.2  # inches: the lines and a margin
    width, old = fig.get_size_inches()
    fig.set_size_inches(width, old + height)
    fig.tight_layout(rect=(0, height / (old + height), 1, 1))
    if lines:
        fig.text(0.01, 0.1 / (old + height), text, fontsize=size, va="bottom", ha="left")


def _plot_families(ds):
    plt = _pyplot()
    n = ds.sizes["panel"]
    fig, axes = plt.subplots(n, 1, figsize=(7, 2.6 * n + 0.9), squeeze=False)
    labels = ds.attrs["panel_labels"].split("|")
    for i, ax in enumerate(axes[:, 0]):
        for c in range(ds.sizes["curve"]):
            if not np.isfinite(ds.omega.values[i, c]):
                continue
            shade = "black" if c == 0 else str(0.15 + 0.6 * c / ds.sizes["curve"])
            ax.plot(ds.t.values[i, c], ds.deviation.values[i, c], lw=0.7, color=shade,
                    label=f"ω = {ds.omega.values[i, c]:.1f} (l = {int(ds.l.values[i, c])})")
        ax.set_title(labels[i], fontsize=9)
        ax.set_xlabel("t")
        ax.set_ylabel("H_ω(t) − H_ω(0)")
        ax.set_xlim(0, float(ds.t_end.values[i]))
        ax.legend(fontsize=6, ncol=2, frameon=False, loc="upper left")
    fig.suptitle(ds.attrs["title"], fontsize=10)
    _caption(fig, ds)
    return fig


def _plot_perturbed(ds):
    plt = _pyplot()
    n = ds.sizes["panel"]
    fig, axes = plt.subplots(n, 1, figsize=(7, 2.3 * n + 0.9), squeeze=False)
    labels = ds.attrs["panel_labels"].split("|")
    for i, ax in enumerate(axes[:, 0]):
        rows = np.flatnonzero(np.isfinite(ds.delta.values[i]))
        for c in rows[1:]:
            ax.plot(ds.t.values[i, c], ds.deviation.values[i, c], lw=0.4, color="0.65")
        ax.plot(ds.t.values[i, 0], ds.deviation.values[i, 0], lw=0.6, color="black")
        ax.set_xlim(0, float(ds.t_end.values[i]))
        ax.set_title(f"{labels[i].replace('2*pi/3', '2π/3').replace('sqrt(12)', '√12')}, "
                     f"t_end = {float(ds.t_end.values[i]):,.0f}"
                     f"   (black: standard data; {rows.size - 1} gray: x₀,₁(0) = 1 ± δ)", fontsize=8)
        ax.set_ylabel("H_ω(t) − H_ω(0)")
        ax.axhline(0, color="0.85", lw=0.5, zorder=0)
        _frame_majority(ax, ds.deviation.values[i][rows])
    axes[-1, 0].set_xlabel("t")
    fig.suptitle(ds.attrs["title"], fontsize=10)
    _caption(fig, ds)
    return fig


def _frame_majority(ax, dev: np.ndarray, factor: float = 100.0) -> None:
    """Limits the y-range to the curves that stay in the regime, and says what leaves it."""
    away = runaway_curves(dev, factor)
    if not away:
        return
    keep = np.setdiff1d(np.arange(dev.shape[0]), away)
    top = 1.15 * float(np.nanmax(np.abs(dev[keep])))
    ax.set_ylim(-top, top)
    peak = float(np.nanmax(np.abs(dev[away])))
    ax.text(0.99, 0.97, f"{len(away)} curve(s) leave the frame (up to {peak:.3g})", transform=ax.transAxes,
            ha="right", va="top", fontsize=7, color="0.35")


def _plot_scan(ds):
    plt = _pyplot()
    n = ds.sizes["panel"]
    fig, axes = plt.subplots(1, n, figsize=(2.3 * n, 4.4), sharey=True, squeeze=False)
    f = _font_scale(fig)  # five panels are wider than a page: larger fonts, legible when shrunk
    labels = ds.attrs["centre_labels"].split("|")
    top = float(np.nanmax([np.nanmax(ds.max_deviation.values),
                           np.nanmax(ds.realizations.values) if "realizations" in ds and
                           np.isfinite(ds.realizations.values).any() else 0.0]))
    for i, ax in enumerate(axes[0]):
        for j in np.flatnonzero(ds.resonance_panel.values == i):
            x = ds.resonance_h_omega.values[j]
            k, r = int(ds.resonance_k.values[j]), int(ds.resonance_r.values[j])
            ax.axvline(x, color="tab:red", lw=0.6, ls="--", alpha=0.4 + 0.6 / k)
            if k <= 8:
                ax.text(x, 1.01, f"2π·{r}/{k}" if r > 1 else f"2π/{k}", fontsize=6 * f, ha="center", va="bottom",
                        color="tab:red", transform=ax.get_xaxis_transform())
        k, r = int(ds.centre_k.values[i]), int(ds.centre_r.values[i])
        if k:
            half = np.sqrt(ds.centre.values[i] / ds.attrs["omega"]) / k  # |k hω − 2πr| < √h
            ax.axvspan(ds.centre.values[i] - half, ds.centre.values[i] + half, color="tab:red", alpha=0.06, lw=0)
        x = ds.h_omega.values[i]
        real = ds.realizations.values[i] if "realizations" in ds else np.zeros((0, x.size))
        if np.isfinite(real).any():
            runs = np.concatenate([ds.max_deviation.values[i][None, :], real])
            ax.fill_between(x, np.nanmin(runs, axis=0), np.nanmax(runs, axis=0), color="0.8", lw=0,
                            label=f"range of {runs.shape[0]} realizations")
            ax.plot(x, ds.max_deviation.values[i], lw=0.4, color="0.45", label="standard data")
            ax.plot(x, np.nanmedian(runs, axis=0), lw=0.7, color="black", label="median")
            ax.legend(fontsize=5 * f, frameon=False, loc="upper left")
        else:
            ax.plot(x, ds.max_deviation.values[i], lw=0.6, color="black")
        ax.set_yscale("log")
        ax.set_title(f"centre {labels[i].replace('*', '').replace('pi', 'π')}", fontsize=9 * f, pad=14 * f)
        ax.set_xlabel("hω", fontsize=8 * f)
        ax.tick_params(labelsize=7 * f)
    axes[0, 0].set_ylabel(f"max |H_ω(t) − H_ω(0)|, 0 ≤ t ≤ {ds.attrs['t_end']:,.0f}", fontsize=8 * f)
    axes[0, 0].set_ylim(top=top * 1.5)
    fig.suptitle(ds.attrs["title"], fontsize=10 * f)
    _caption(fig, ds)
    return fig


def _plot_methods(ds):
    plt = _pyplot()
    methods = list(ds.method.values)
    fig, axes = plt.subplots(len(methods), 1, figsize=(7, 2.5 * len(methods) + 0.9), squeeze=False)
    for i, ax in enumerate(axes[:, 0]):
        for c in reversed(range(ds.sizes["curve"])):
            color = "black" if c == 0 else str(0.35 + 0.4 * c / ds.sizes["curve"])
            ax.plot(ds.t.values[i, c], ds.deviation.values[i, c], lw=0.7, color=color,
                    label=f"ω = {ds.omega.values[c]:g}")
        ax.set_title(f"method ({methods[i]})", fontsize=9)
        ax.set_ylabel("H_ω(t) − H_ω(0)")
        ax.set_xlim(0, ds.attrs["t_end"])
        ax.legend(fontsize=7, frameon=False)
    axes[-1, 0].set_xlabel("t")
    fig.suptitle(ds.attrs["title"], fontsize=10)
    _caption(fig, ds)
    return fig


def _plot_strata(ds):
    """The strata figure: E_k(t) at the largest ε (bands), max_t E_k against k for every ε with
    ε^{2k}, and the scan's largest rise over the bands against h, measured and predicted."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(12.0, 4.0))
    ax = axes[0]
    colors = plt.cm.viridis(np.linspace(0, 0.9, ds.k.size))
    e_max = float(ds.epsilon.max())
    for k in ds.k.values:
        ax.plot(ds.t.values, ds.mode_energy.sel(epsilon=e_max, k=k).values, color=colors[k], lw=0.8, label=f"k = {k}")
    ax.axhline(float(ds.floor.sel(epsilon=e_max)), color="grey", ls=":", lw=0.8)
    ax.set_yscale("log")
    ax.set_ylim(top=1e4)  # room for the legend above the bands
    ax.set_xlabel("t")
    ax.set_ylabel(f"E_k(t), ε = {e_max:g}")
    ax.legend(fontsize=6, ncol=5, frameon=False, loc="upper center")
    ax = axes[1]
    k = ds.k.values
    power = np.where(k == 0, 4, 2 * k).astype(float)  # the strata: ε^(2k), ε⁴ for mode 0
    for i, e in enumerate(ds.epsilon.values):
        (line,) = ax.plot(k, ds.mode_energy.isel(epsilon=i).max("t").values, "o-", ms=3, label=f"ε = {e:g}")
        ax.plot(k, e**power, ls="--", lw=0.7, color=line.get_color())
        ax.axhline(float(ds.floor.values[i]), color=line.get_color(), ls=":", lw=0.6)
    ax.plot([], [], "k--", lw=0.7, label="ε^(2k) (ε⁴ at k = 0)")
    ax.plot([], [], "k:", lw=0.6, label="round-off floor")
    ax.set_yscale("log")
    ax.set_xlabel("mode k")
    ax.set_ylabel("max over t of E_k")
    ax.legend(fontsize=7, frameon=False)
    ax = axes[2]
    h = ds.h.values
    ax.plot(h, ds.largest_predicted_rise.values, color="tab:red", lw=0.8, label="predicted (the tool)")
    ax.plot(h, ds.largest_rise.values, color="black", lw=0.8, label="measured")
    ax.axhline(ds.attrs["break_factor"], color="grey", ls="--", lw=0.7, label="a stratum breaks")
    ax.legend(fontsize=7, frameon=False, loc="upper left")
    ax.set_yscale("log")
    ax.set_xlabel("step size h")
    ax.set_ylabel(f"largest rise of a mode over its band, ε = {ds.attrs['scan_epsilon']:g}")
    fig.suptitle(ds.attrs["title"], fontsize=10)
    _caption(fig, ds)
    return fig


def _plot_wave(ds):
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    h = ds.h.values
    for x in h[np.isfinite(ds.resonance_distance.values)]:
        ax.axvline(x, color="tab:red", lw=0.5, alpha=0.5)
    ax.plot(h, ds.energy_deviation.values, color="black", lw=0.8, label="energy H")
    ax.plot(h, ds.action_deviation.values, color="tab:blue", lw=0.6, alpha=0.7, label="actions, 6 lowest modes")
    ax.set_yscale("log")
    ax.set_xlabel("step size h")
    ax.set_ylabel(f"max relative deviation, 0 ≤ t ≤ {ds.attrs['t_end']:,.0f}")
    top = ax.secondary_xaxis("top", functions=(lambda v: v * ds.attrs["n"] / 2, lambda v: v * 2 / ds.attrs["n"]))
    top.set_xlabel("CFL number hK")
    ax.legend(fontsize=7, frameon=False, loc="upper left")
    fig.suptitle(ds.attrs["title"], fontsize=10)
    _caption(fig, ds)
    return fig
