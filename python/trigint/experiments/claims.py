"""The paper's claims about each figure, measured on the data: a number, what the paper leads
one to expect, a tolerance, and PASS or FAIL."""

from __future__ import annotations

import numpy as np
import xarray as xr

from .._curves import runaway_curves
from ._claim import Claim


def measure(ds: xr.Dataset) -> list[Claim]:
    """The claims of a figure's data set (from :func:`trigint.experiments.run`), measured.

    Parameters
    ----------
    ds : xarray.Dataset
        A figure's data, as :func:`trigint.experiments.run` returns it.

    Returns
    -------
    list of Claim

    Examples
    --------
    >>> from trigint import experiments
    >>> ds = experiments.run(experiments.load("fig5", quick=True))
    >>> all(c.passed for c in experiments.measure(ds))
    True
    """
    from .._figure_kinds import function

    return function(ds.attrs["kind"], "claims")(ds)


def _slope_through_origin(t: np.ndarray, y: np.ndarray) -> float:
    ok = np.isfinite(t) & np.isfinite(y)
    return float(np.sum(t[ok] * y[ok]) / np.sum(t[ok] ** 2))


def _families(ds: xr.Dataset) -> list[Claim]:
    """Fig. 1: deviation ≈ C t ε^p; p from the slopes of the seven curves; their even spacing."""
    fig, out = ds.attrs["figure"], []
    labels = ds.attrs["panel_labels"].split("|")
    for i in range(ds.sizes["panel"]):
        omega = ds.omega.values[i]
        ok = np.isfinite(omega)
        slopes = np.array([_slope_through_origin(ds.t.values[i, c], ds.deviation.values[i, c])
                           for c in np.flatnonzero(ok)])
        eps = 1.0 / omega[ok]
        p = float(np.polyfit(np.log(eps), np.log(np.abs(slopes)), 1)[0])
        want, tol = float(ds.expected_exponent.values[i]), float(ds.tolerance.values[i])
        out.append(Claim(fig, f"{labels[i]}: exponent p in deviation ≈ C t ε^p (fit over {ok.sum()} curves)",
                         p, f"{want:g}", f"±{tol:g}", abs(p - want) <= tol))
        gaps = np.diff(slopes)
        spread = float(np.max(np.abs(gaps / np.mean(gaps) - 1)))
        out.append(Claim(fig, f"{labels[i]}: spacing of consecutive curves, max |gap/mean gap − 1|",
                         spread, "0 (nearly constant)", "≤ 0.25", spread <= 0.25))
    return out


def spread_exponent(t: np.ndarray, dev: np.ndarray, t_from: float) -> tuple[float, float]:
    """Exponent a and constant C of spread(t) ≈ C t^a, the spread being the standard deviation
    over the curves that stay in the regime (see :func:`runaway_curves`: one curve that runs
    away does not decide it), fitted on t ≥ t_from (time-averaged in logarithmic bins)."""
    keep = np.setdiff1d(np.arange(dev.shape[0]), runaway_curves(dev))
    t, dev = t[keep], dev[keep]
    times = t[0]
    ok = np.isfinite(times) & (times >= max(t_from, times[np.isfinite(times)][1]))
    spread = np.nanstd(dev[:, ok], axis=0)
    tt = times[ok]
    edges = np.geomspace(tt[0], tt[-1], 13)
    centre, value = [], []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        sel = (tt >= a) & (tt < b)
        if sel.any() and np.mean(spread[sel]) > 0:
            centre.append(np.sqrt(a * b))
            value.append(np.sqrt(np.mean(spread[sel] ** 2)))
    slope, intercept = np.polyfit(np.log(centre), np.log(value), 1)
    return float(slope), float(np.exp(intercept))


def _perturbed(ds: xr.Dataset) -> list[Claim]:
    """Figs. 2 and 4: O(ε) up to t = ε^(−k+1)·…; then a random walk spreading like ε^k √t."""
    fig, out = ds.attrs["figure"], []
    eps = 1.0 / ds.attrs["omega"]
    labels = ds.attrs["panel_labels"].split("|")
    limit = float(ds.attrs.get("early_ratio_max", 10.0))
    seen = set()
    for i in range(ds.sizes["panel"]):
        power = float(ds.expected_power.values[i])
        key = (float(ds.h.values[i]), power)
        if key in seen:
            continue
        seen.add(key)
        ratio = float(ds.early_max_deviation.values[i]) / eps
        what = (f"hω = {ds.h_omega.values[i]:.6g}: max |deviation| over every step with t ≤ ε^-{power:g} "
                f"= {eps ** -power:g}, in units of ε = {eps:g}")
        out.append(Claim(fig, what, ratio, "O(1)", f"≤ {limit:g}", ratio <= limit))
    # The spread law on the panel with enough curves whose fit spans the most decades (the
    # longest on a tie), and the ω² rescaling between panels.
    long = [i for i in range(ds.sizes["panel"]) if np.isfinite(ds.delta.values[i]).sum() >= 5]
    if long:
        def decades(j):
            span = float(ds.t_end.values[j]) / max(float(ds.spread_from.values[j]), 1e-300)
            return round(np.log10(span), 6), float(ds.t_end.values[j])

        i = max(long, key=decades)
        t, dev = ds.t.values[i], ds.deviation.values[i]
        rows = np.isfinite(ds.delta.values[i])
        a, c = spread_exponent(t[rows], dev[rows], float(ds.spread_from.values[i]))
        power = float(ds.expected_power.values[i])
        want = float(ds.attrs.get("spread_exponent", 0.5))
        tol = float(ds.attrs.get("spread_tolerance", 0.2))
        out.append(Claim(fig, f"{labels[i]}: spread of the perturbed curves ∝ t^a on t ≥ {ds.spread_from.values[i]:g}"
                         f" ({rows.sum()} curves)", a, f"{want:g} (random walk)", f"±{tol:g}", abs(a - want) <= tol))
        out.append(Claim(fig, f"{labels[i]}: C in spread ≈ C ε^{power:g} √t (information)", c / eps**power,
                         "O(1)", "0.01–100", 0.01 <= c / eps**power <= 100))
    for i in range(ds.sizes["panel"]):
        rows = np.flatnonzero(np.isfinite(ds.delta.values[i]))
        away = runaway_curves(ds.deviation.values[i][rows])
        if away:
            deltas = ", ".join(f"{ds.delta.values[i][rows[c]]:+.3g}" for c in away)
            out.append(Claim(fig, f"{labels[i]}: curves whose max |deviation| exceeds 100× the median curve's "
                             f"(δ = {deltas}; information: a long random walk can leave the regime)",
                             float(len(away)), "information", f"of {rows.size}", True))
    if ds.sizes["panel"] == 2 and ds.expected_power.values[1] == ds.expected_power.values[0] + 1:
        # Fig. 4: with one more power of ε, the same deviations on an ω² times longer interval:
        # the bottom panel over the second half of its run against the top panel over the same
        # window divided by ω². A single random walk's size varies tenfold between realizations,
        # so each panel's size is the median over its curves of the per-curve RMS (a runaway
        # curve does not decide it).
        t_bottom = float(ds.t_end.values[1])
        windows = ((0.5 * t_bottom * eps**2, t_bottom * eps**2), (0.5 * t_bottom, t_bottom))
        rms = []
        for i, (a, b) in zip((0, 1), windows, strict=True):
            rows = np.flatnonzero(np.isfinite(ds.delta.values[i]))
            t = ds.t.values[i][rows]
            sel = (t >= a * (1 - 1e-9)) & (t <= b * (1 + 1e-9))
            dev = np.where(sel, ds.deviation.values[i][rows], np.nan)
            rms.append(float(np.median(np.sqrt(np.nanmean(dev**2, axis=1)))))
        r = rms[1] / rms[0]
        out.append(Claim(fig, f"bottom on [{windows[1][0]:g}, {windows[1][1]:g}] vs top on [{windows[0][0]:g}, "
                         f"{windows[0][1]:g}] (ω² shorter): median over the curves of the RMS deviation "
                         "(ε^3 √t vs ε^2 √t)", r, "1", "1/3–3", 1 / 3 <= r <= 3))
    return out


def realization_count(ds: xr.Dataset, panel: int) -> int:
    """Initial values run at each hω of a panel: the standard data and its perturbations."""
    if "realizations" not in ds:
        return 1
    return 1 + int(np.isfinite(ds.realizations.values[panel, :, 0]).sum())


def scan_statistic(ds: xr.Dataset) -> np.ndarray:
    """Per panel and hω: the median over the realizations (standard data included) where a
    panel has them, else the standard data's max deviation. One random walk's peak does not
    decide a claim."""
    y = ds.max_deviation.values.copy()
    if "realizations" in ds:
        for i in range(ds.sizes["panel"]):
            if realization_count(ds, i) > 1:
                runs = np.concatenate([ds.max_deviation.values[i][None, :], ds.realizations.values[i]])
                y[i] = np.nanmedian(runs, axis=0)
    return y


def _scan(ds: xr.Dataset) -> list[Claim]:
    """Fig. 3. Each panel is centred at a resonance hω = 2πr/k. Where (3.6) holds
    only for N = 1 (k = 3), the deviation must grow on t ≤ 10⁵: peaks inside the near-resonance
    band |k hω − 2πr| < √h, far above the rest; where N ≥ 2 the panel stays at the level of the
    O(ε) oscillation of Theorem 3.1, without peaks."""
    fig, out = ds.attrs["figure"], []
    labels = [lab.replace("*", "").replace("pi", "π") for lab in ds.attrs["centre_labels"].split("|")]
    curves = scan_statistic(ds)
    maxima = np.nanmax(curves, axis=1)
    for i in range(ds.sizes["panel"]):
        h_omega, y = ds.h_omega.values[i], curves[i]
        k, r, n = int(ds.centre_k.values[i]), int(ds.centre_r.values[i]), int(ds.centre_N.values[i])
        ratio = float(np.nanmax(y) / np.nanmedian(y))
        runs = realization_count(ds, i)
        where = f"panel {labels[i]} (2π·{r}/{k}, N = {n})" + (f", median of {runs} realizations" if runs > 1 else "")
        if n <= 1:
            peak = h_omega[int(np.nanargmax(y))]
            h = peak / ds.attrs["omega"]
            band = abs(k * peak - 2 * np.pi * r) / np.sqrt(h)
            out.append(Claim(fig, f"{where}: highest peak (hω = {peak:.4f}) inside the near-resonance band, "
                             "|k hω − 2πr| / √h", band, "< 1", "< 1", band < 1))
            out.append(Claim(fig, f"{where}: peak height / median of the panel", ratio, "≫ 1", "≥ 10", ratio >= 10))
            others = np.delete(maxima, i)
            if others.size:
                lead = float(maxima[i] / np.max(others))
                out.append(Claim(fig, f"{where}: its peak / the highest point of the panels with N ≥ 2", lead,
                                 "≫ 1", "≥ 10", lead >= 10))
        else:
            out.append(Claim(fig, f"{where}: no peak, max / median of the panel", ratio, "≈ 1", "≤ 2", ratio <= 2))
    return out


def _methods(ds: xr.Dataset) -> list[Claim]:
    """Fig. 5: (B) grows like t ε; (A) stays far below it."""
    fig, out = ds.attrs["figure"], []
    methods = list(ds.method.values)
    eps = 1.0 / ds.omega.values
    if "B" in methods:
        b = methods.index("B")
        # the rate of the linear growth, fitted on the first quarter (later it turns quadratic)
        early = ds.t.values[b] <= ds.attrs["t_end"] / 4
        rates = np.array([abs(_slope_through_origin(np.where(early[c], ds.t.values[b, c], np.nan),
                                                    ds.deviation.values[b, c])) for c in range(ds.sizes["curve"])])
        p = float(np.polyfit(np.log(eps), np.log(rates), 1)[0])
        out.append(Claim(fig, "(B): exponent p in deviation ≈ C t ε^p, rate fitted on t ≤ t_end/4 (linear growth "
                         "O(t ε))", p, "1", "±0.15", abs(p - 1) <= 0.15))
        t, y = ds.t.values[b, 0], ds.deviation.values[b, 0]
        ok = np.isfinite(t) & (t <= ds.attrs["t_end"] / 4)
        lin = np.polyfit(t[ok], y[ok], 1)
        resid = float(np.std(y[ok] - np.polyval(lin, t[ok])) / np.max(np.abs(y[ok])))
        out.append(Claim(fig, "(B), ω = max: growth linear on the first quarter (residual / size)", resid, "0",
                         "≤ 0.1", resid <= 0.1))
    if "A" in methods and "B" in methods:
        a, b = methods.index("A"), methods.index("B")
        ratio = float(np.max(ds.max_deviation.values[a] / ds.max_deviation.values[b]))
        out.append(Claim(fig, "max |deviation| of (A) / that of (B), worst ω", ratio, "≪ 1 (paper: scale 6e-5)",
                         "≤ 0.01", ratio <= 0.01))
    return out


def _wave(ds: xr.Dataset) -> list[Claim]:
    """Away from the flagged step sizes the energy error is O(h^order) and the harmonic actions
    of the lowest modes move by at most action_bound, the same at every such step size (the
    near-conservation of actions of Cohen, Hairer, Lubich 2008); the largest energy error of the
    scan is a peak (peak_factor × the median) at a flagged step size, and so is the largest
    action deviation (action_factor × the largest away from the flags)."""
    from .wave_runner import flagged

    fig, a = ds.attrs["figure"], ds.attrs
    near = flagged(ds)
    h, dev = ds.h.values, ds.energy_deviation.values
    calm = ~near & np.isfinite(dev) & (dev > 0)
    slope = float(np.polyfit(np.log(h[calm]), np.log(dev[calm]), 1)[0]) if np.count_nonzero(calm) > 2 else np.nan
    finite = np.where(np.isfinite(dev), dev, np.inf)
    top = int(np.argmax(finite))
    factor = float(finite[top] / np.nanmedian(dev))
    return [
        Claim(fig, "energy error O(h^2) at the step sizes the resonance tool does not flag", slope,
              f"exponent {a['order']:g}", f"± {a['order_tolerance']:g}",
              bool(abs(slope - a["order"]) <= a["order_tolerance"])),
        Claim(fig, "the largest energy error of the scan is a resonance peak the tool flags",
              factor, f"≥ {a['peak_factor']:g} × the median, at a flagged h (h = {h[top]:.4f})",
              "flagged: " + ("yes" if near[top] else "no"), bool(near[top] and factor >= a["peak_factor"])),
        *_wave_actions(ds, near),
    ]


def _wave_actions(ds: xr.Dataset, near: np.ndarray) -> list[Claim]:
    """The actions' claims of the wave figure (see `_wave`)."""
    fig, a = ds.attrs["figure"], ds.attrs
    h, act = ds.h.values, ds.action_deviation.values
    calm = ~near & np.isfinite(act)
    worst_calm = float(np.max(act[calm])) if calm.any() else np.nan
    finite = np.where(np.isfinite(act), act, np.inf)
    top = int(np.argmax(finite))
    factor = float(finite[top] / worst_calm)
    return [
        Claim(fig, "the lowest modes' actions are nearly kept at every step size the tool does not flag",
              worst_calm, f"≤ {a['action_bound']:g} (relative, largest over those step sizes)",
              f"≤ {a['action_bound']:g}", bool(worst_calm <= a["action_bound"])),
        Claim(fig, "the largest action deviation of the scan is at a flagged step size", factor,
              f"≥ {a['action_factor']:g} × the largest away from the flags (h = {h[top]:.4f})",
              "flagged: " + ("yes" if near[top] else "no"), bool(near[top] and factor >= a["action_factor"])),
    ]
