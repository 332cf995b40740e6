"""Turning a spec into data: one runner per kind of figure, each returning an xarray.Dataset."""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import xarray as xr

from .. import problems
from .._method_names import resolve_method
from ..ensemble import ensemble, scan
from ..integrate import integrate
from ..resonance import resonant_step_sizes
from .numbers import number


def run(spec: dict) -> xr.Dataset:
    """The data of one figure, from its spec.

    Parameters
    ----------
    spec : dict
        A spec from :func:`trigint.experiments.load`.

    Returns
    -------
    xarray.Dataset
        The figure's curves, with the spec's settings as attributes.

    Examples
    --------
    >>> from trigint import experiments
    >>> ds = experiments.run(experiments.load("fig5", quick=True))
    >>> ds.attrs["figure"], ds.attrs["kind"]
    ('fig5', 'methods')
    """
    from .._figure_kinds import function

    kind = spec["figure"]["kind"]
    ds = function(kind, "run")(spec["figure"])
    ds.attrs.update(figure=spec["figure"]["id"], kind=kind, title=spec["figure"].get("title", ""),
                    caption=" ".join(spec["figure"].get("caption", "").split()), quick=int(spec.get("quick", False)))
    return ds


def _pad(arrays: list[np.ndarray], width: int | None = None) -> np.ndarray:
    width = max(a.size for a in arrays) if width is None else width
    out = np.full((len(arrays), width), np.nan)
    for i, a in enumerate(arrays):
        out[i, : a.size] = a
    return out


def _save_every(n_steps: int, samples: int) -> int:
    return max(1, n_steps // max(1, int(samples)))


def _problem(fig: dict, omega: float):
    name = fig["problem"]
    if name == "fpu":
        m = int(fig.get("m", 3))
        return problems.fpu(m=m, omega=omega), problems.fpu_initial(m=m, omega=omega)
    if name in ("experiment1", "experiment3"):
        return getattr(problems, name)(omega), getattr(problems, f"{name}_initial")(omega)
    raise ValueError(f"spec: unknown problem {name!r}; valid: fpu, experiment1, experiment3")


def seeded(q0: np.ndarray, p0: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The initial values of realization set `seed`: 0 is the paper's data; seed s ≥ 1 adds
    s·10⁻¹⁰ to y₀,₁(0), so that every curve of a figure, the black one included, is another
    realization of the same experiment (a few units in the last place are not enough: they can
    round away in the first step)."""
    if seed == 0:
        return q0, p0
    p0 = np.array(p0, dtype=float)
    p0[0] += seed * 1e-10
    return q0, p0


def _problem_seeded(fig: dict, omega: float):
    prob, (q0, p0) = _problem(fig, omega)
    return prob, seeded(q0, p0, int(fig.get("seed", 0)))


def _curves(jobs: list[dict], energy: str) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Runs single trajectories in parallel threads (the core releases the interpreter lock);
    returns (t, E(t) − E(0), max over every step) per job."""
    def one(job):
        sol = integrate(job["problem"], job["method"], job["q0"], job["p0"], h=job["h"], n_steps=job["n_steps"],
                        save_every=job["save_every"], track_energies=job.get("track", True),
                        progress=job.get("progress", False))
        return sol.t, sol.deviation(energy).values, sol.max_deviation[energy]

    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        return list(pool.map(one, jobs))


def run_families(fig: dict) -> xr.Dataset:
    """Figure 1: a family of curves per panel, ω given as a function of l."""
    method = resolve_method(fig.get("method", "B"))
    panels = fig["panel"]
    t_all, dev_all, omegas, ls = [], [], [], []
    for panel in panels:
        jobs = []
        for l in panel["l"]:
            omega = number(panel["omega"], l=l)
            prob, (q0, p0) = _problem_seeded(fig, omega)
            h = number(panel["h_omega"]) / omega
            n = int(round(float(panel["t_end"]) / h))
            jobs.append(dict(problem=prob, method=method, q0=q0, p0=p0, h=h, n_steps=n,
                             save_every=_save_every(n, fig.get("samples", 2000))))
            omegas.append(omega)
        ls.append(list(panel["l"]))
        curves = _curves(jobs, fig.get("energy", "oscillatory"))
        t_all.append(_pad([c[0] for c in curves]))
        dev_all.append(_pad([c[1] for c in curves]))
    k = max(len(x) for x in ls)
    width = max(a.shape[1] for a in t_all)
    t = np.full((len(panels), k, width), np.nan)
    dev = np.full_like(t, np.nan)
    for i in range(len(panels)):
        t[i, : len(ls[i]), : t_all[i].shape[1]] = t_all[i]
        dev[i, : len(ls[i]), : dev_all[i].shape[1]] = dev_all[i]
    omega_arr = np.full((len(panels), k), np.nan)
    l_arr = np.full((len(panels), k), np.nan)
    j = 0
    for i, lv in enumerate(ls):
        omega_arr[i, : len(lv)] = omegas[j: j + len(lv)]
        l_arr[i, : len(lv)] = lv
        j += len(lv)
    return xr.Dataset(
        {"t": (("panel", "curve", "sample"), t), "deviation": (("panel", "curve", "sample"), dev)},
        coords={"omega": (("panel", "curve"), omega_arr), "l": (("panel", "curve"), l_arr),
                "h_omega": ("panel", [number(p["h_omega"]) for p in panels]),
                "t_end": ("panel", [float(p["t_end"]) for p in panels]),
                "expected_exponent": ("panel", [float(p.get("expected_exponent", np.nan)) for p in panels]),
                "tolerance": ("panel", [float(p.get("tolerance", 0.15)) for p in panels])},
        attrs={"panel_labels": "|".join(p.get("label", "") for p in panels), "energy": fig.get("energy", "oscillatory"),
               "method": repr(method)},
    )


def perturbations(count: int, delta_max: float, x: float = 1.0) -> np.ndarray:
    """The `count` doubles nearest to x with 0 < |x' − x| ≤ delta_max, alternating above and
    below (only a few doubles lie within 7·10⁻¹⁶ of 1: three above, six below)."""
    above, below = [], []
    up = down = x
    while True:
        up = np.nextafter(up, np.inf)
        if up - x > delta_max:
            break
        above.append(up - x)
    while True:
        down = np.nextafter(down, -np.inf)
        if x - down > delta_max:
            break
        below.append(down - x)
    merged = [d for pair in zip(below, above, strict=False) for d in pair]
    merged += below[len(above):] + above[len(below):]
    if count > len(merged):
        raise ValueError(f"spec: only {len(merged)} doubles differ from {x} by at most {delta_max:g}; "
                         f"asked for {count} perturbed curves")
    return np.array(merged[:count])


def run_perturbed(fig: dict) -> xr.Dataset:
    """Figures 2 and 4: a black curve and gray curves with x₀,₁(0) = 1 ± δ, per panel."""
    method = resolve_method(fig.get("method", "B"))
    omega = float(fig["omega"])
    prob, (q0, p0) = _problem_seeded(fig, omega)
    energy = fig.get("energy", "oscillatory")
    panels = fig.get("panel") or [{"t_end": t, "h_omega": fig["h_omega"], "perturbed": fig.get("perturbed", 8),
                                   "expected_power": fig.get("expected_power", 2),
                                   "spread_from": fig.get("spread_from", 0.0)} for t in fig["panels"]]
    samples = int(fig.get("samples", 3000))
    if "panel_t_end" in fig:  # a reduced run's end times
        panels = [dict(p, t_end=t) for p, t in zip(panels, fig["panel_t_end"], strict=True)]
    if "panel_spread_from" in fig:  # and where its spread is fitted
        panels = [dict(p, spread_from=t) for p, t in zip(panels, fig["panel_spread_from"], strict=True)]
    results = []
    for panel in panels:
        h = number(panel["h_omega"]) / omega
        t_end = float(panel["t_end"])
        n = int(round(t_end / h))
        deltas = np.r_[0.0, perturbations(int(panel.get("perturbed", 8)), float(fig.get("delta_max", 7e-16)))]
        Q0 = np.repeat(q0[None, :], deltas.size, axis=0)
        Q0[:, 0] += deltas
        every = _save_every(n, samples)
        if deltas.size >= 8:
            ds = ensemble(prob, method, Q0, p0, h=h, n_steps=n, save_every=every, track_energies=False)
            k = list(ds.energy.values).index(energy)
            t = ds.t.values
            dev = ds.energies.values[:, :, k] - ds.initial_energies.values[:, k][:, None]
        else:
            jobs = [dict(problem=prob, method=method, q0=Q0[i], p0=p0, h=h, n_steps=n, save_every=every,
                         track=False, progress=(i == 0 and n >= 10**8)) for i in range(deltas.size)]
            curves = _curves(jobs, energy)
            t = _pad([c[0] for c in curves])
            dev = _pad([c[1] for c in curves])
        results.append((t, dev, deltas, h, t_end, panel))
    # The early claim: the black curve's streamed max deviation on t ≤ ε^(−power), every step.
    eps = 1.0 / omega
    early, seen = [], {}
    for _, _, _, h, _, panel in results:
        power = float(panel.get("expected_power", fig.get("expected_power", 2)))
        if (h, power) not in seen:
            n_early = int(round(eps ** (-power) / h))
            sol = integrate(prob, method, q0, p0, h=h, n_steps=max(1, n_early), save_every=max(1, n_early))
            seen[h, power] = sol.max_deviation[energy]
        early.append(seen[h, power])
    width = max(r[0].shape[1] for r in results)
    curves = max(r[0].shape[0] for r in results)
    t = np.full((len(results), curves, width), np.nan)
    dev = np.full_like(t, np.nan)
    delta = np.full((len(results), curves), np.nan)
    for i, (ti_, di, de, *_rest) in enumerate(results):
        t[i, : ti_.shape[0], : ti_.shape[1]] = ti_
        dev[i, : di.shape[0], : di.shape[1]] = di
        delta[i, : de.size] = de
    return xr.Dataset(
        {"t": (("panel", "curve", "sample"), t), "deviation": (("panel", "curve", "sample"), dev),
         "early_max_deviation": ("panel", early)},
        coords={"delta": (("panel", "curve"), delta), "h": ("panel", [r[3] for r in results]),
                "t_end": ("panel", [r[4] for r in results]),
                "h_omega": ("panel", [number(p["h_omega"]) for p in panels]),
                "expected_power": ("panel", [float(p.get("expected_power", 2)) for p in panels]),
                "spread_from": ("panel", [float(p.get("spread_from", 0.0)) for p in panels])},
        attrs={"omega": omega, "method": repr(method), "energy": energy,
               "early_ratio_max": float(fig.get("early_ratio_max", 10.0)),
               "spread_exponent": float(fig.get("spread_exponent", 0.5)),
               "spread_tolerance": float(fig.get("spread_tolerance", 0.2)),
               "panel_labels": "|".join(p.get("label", f"ω = {omega:g}, hω = {_pretty(p['h_omega'])}")
                                        for p in panels)},
    )


def _pretty(expression) -> str:
    """'2*pi/3' → '2π/3', 'sqrt(12)' → '√12', for labels."""
    text = str(expression).replace("*", "").replace("pi", "π")
    return text.replace("sqrt(", "√").replace(")", "") if "sqrt(" in text else text


def run_scan(fig: dict) -> xr.Dataset:
    """Figure 3: max deviation over 0 ≤ t ≤ t_end against hω, one panel per centre. Panels whose
    centre has N ≤ `realizations_max_N` (where the deviation is a random walk) are also run for
    `realizations` perturbed initial values x₀,₁(0) = 1 + δ (|δ| ≤ `delta_max`, as in Figure 2)."""
    omega = float(fig["omega"])
    prob, (q0, p0) = _problem_seeded(fig, omega)
    centres = [number(c) for c in fig["centres"]]
    width, points = float(fig.get("width", 0.1)), int(fig.get("points", 591))
    grid = np.array([np.linspace(c - width / 2, c + width / 2, points) for c in centres])
    method, energy, t_end = fig.get("method", "B"), fig.get("energy", "oscillatory"), float(fig["t_end"])
    s = scan(prob, method, q0, p0, h_omega=grid.ravel(), omega_ref=omega, t_end=t_end, energy=energy)
    order = int(fig.get("resonance_order", 12))
    # What the theory says at each centre: N of (3.6), and the central resonance.
    from ..resonance import analyze

    centre_n = [analyze(c / omega, [omega], N_max=10).N for c in centres]
    # Realizations: every (panel point, δ) pair of the random-walk panels in one scan.
    count = int(fig.get("realizations", 0))
    deltas = perturbations(count, float(fig.get("delta_max", 7e-16))) if count else np.zeros(0)
    walk = [i for i, n in enumerate(centre_n) if n <= int(fig.get("realizations_max_N", 1))] if count else []
    real = np.full((len(centres), deltas.size, points), np.nan)
    if walk:
        h_omega = np.concatenate([np.repeat(grid[i][None, :], deltas.size, axis=0).ravel() for i in walk])
        Q0 = np.repeat(q0[None, :], h_omega.size, axis=0)
        Q0[:, 0] += np.tile(np.repeat(deltas, points), len(walk))
        r = scan(prob, method, Q0, p0, h_omega=h_omega, omega_ref=omega, t_end=t_end, energy=energy)
        real[walk] = r.values.reshape(len(walk), deltas.size, points)
    central = [min(resonant_step_sizes([omega], (c - 1e-9, c + 1e-9), order) or [None],
                   key=lambda r: r.order if r else 0) for c in centres]
    res = [(i, r.h_omega, r.k[0], r.r) for i, c in enumerate(centres)
           for r in resonant_step_sizes([omega], (c - width / 2, c + width / 2), order)]
    return xr.Dataset(
        {"max_deviation": (("panel", "point"), s.values.reshape(grid.shape)),
         "realizations": (("panel", "realization", "point"), real),
         "n_steps": (("panel", "point"), s.n_steps.values.reshape(grid.shape).astype(np.int32)),
         "resonance_panel": ("resonance", np.array([r[0] for r in res], dtype=np.int32)),
         "resonance_h_omega": ("resonance", np.array([r[1] for r in res])),
         "resonance_k": ("resonance", np.array([r[2] for r in res], dtype=np.int32)),
         "resonance_r": ("resonance", np.array([r[3] for r in res], dtype=np.int32))},
        coords={"h_omega": (("panel", "point"), grid), "centre": ("panel", centres),
                "delta": ("realization", deltas),
                "centre_N": ("panel", np.array(centre_n, dtype=np.int32)),
                "centre_k": ("panel", np.array([r.k[0] if r else 0 for r in central], dtype=np.int32)),
                "centre_r": ("panel", np.array([r.r if r else 0 for r in central], dtype=np.int32))},
        attrs={"omega": omega, "t_end": t_end, "method": method, "resonance_order": order,
               "centre_labels": "|".join(fig["centres"])},
    )


def run_methods(fig: dict) -> xr.Dataset:
    """Figure 5: several methods, a family of ω each, on the multi-frequency problem."""
    methods = [resolve_method(m) for m in fig["methods"]]
    omegas = [float(w) for w in fig["omegas"]]
    energy = fig.get("energy", "oscillatory")
    jobs = []
    for method in methods:
        for omega in omegas:
            prob, (q0, p0) = _problem_seeded(fig, omega)
            h = problems.experiment3_step(omega) if fig["problem"] == "experiment3" else number(fig["h_omega"]) / omega
            n = int(round(float(fig["t_end"]) / h))
            jobs.append(dict(problem=prob, method=method, q0=q0, p0=p0, h=h, n_steps=n,
                             save_every=_save_every(n, fig.get("samples", 2000))))
    curves = _curves(jobs, energy)
    width = max(c[0].size for c in curves)
    shape = (len(methods), len(omegas), width)
    t = _pad([c[0] for c in curves], width).reshape(shape)
    dev = _pad([c[1] for c in curves], width).reshape(shape)
    maxdev = np.array([c[2] for c in curves]).reshape(shape[:2])
    return xr.Dataset(
        {"t": (("method", "curve", "sample"), t), "deviation": (("method", "curve", "sample"), dev),
         "max_deviation": (("method", "curve"), maxdev)},
        coords={"omega": ("curve", omegas), "method": [m.name for m in methods]},
        attrs={"t_end": float(fig["t_end"]), "energy": energy},
    )
