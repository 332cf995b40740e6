"""The energy-strata figure: u_tt = u_xx − ρu + u² on the torus with u(·, 0) = ε cos x, spectral
collocation and a symplectic trigonometric method. The mode energies stay in strata
E_k ~ ε^{2k} (E_0 ~ ε⁴) over long times (Gauckler, Hairer, Lubich, Weiss, Comm. PDE 37 (2012);
for the discretization, under a numerical non-resonance condition on h: Gauckler, Weiss,
DCDS-A 37 (2017)); a scan over h shows where they break, with the flags of
:func:`trigint.resonance.strata_resonances`. The figure is drawn by ``trigint.plotting``.

Mode energies: E_k = ω_k J_k = ½ Σ_{±k} (ω_k² |û_k|² + |v̂_k|²), û_k = (1/N) Σ_x u(x) e^{−ikx}
(one term for k = 0 and the Nyquist mode): what trigint streams as the wave's per-mode
oscillatory energies.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from .. import problems
from ..ensemble import ensemble
from ..integrate import integrate
from ..resonance.strata import combinations
from ._claim import Claim


def band_exponents(k: np.ndarray) -> np.ndarray:
    """The stratum's power of ε: 2k, and 4 for mode 0 (driven by u² of mode 1)."""
    k = np.asarray(k)
    return np.where(k == 0, 4, 2 * k)


def run_strata(fig: dict) -> xr.Dataset:
    """Mode energies over time for each ε at the step size `h`; the largest energy of each mode
    over a scan of step sizes for `scan_epsilon`, with the tool's predicted rises; and the same
    scan for a second ρ (`holdout_rho`), a check of the flags on frequencies they were not
    tuned on."""
    prob = _problem(fig, float(fig["rho"]))
    (x,) = prob.grid
    method, h, t_end = fig.get("method", "B"), float(fig["h"]), float(fig["t_end"])
    eps = np.asarray(fig["epsilons"], dtype=float)
    n_modes = int(fig.get("modes", 9))
    energies, floor = [], []
    for e in eps:
        E, t = _mode_energy_run(prob, method, e, h, t_end, int(fig.get("samples", 400)))
        energies.append(E[:, :n_modes])
        floor.append(float(E[:, -1].max()))  # the highest mode: its stratum ε^{2K} is far below round-off
    hs = np.linspace(float(fig["h_min"]), float(fig["h_max"]), int(fig["points"]))
    scan_eps, scan_t_end = float(fig["scan_epsilon"]), float(fig["scan_t_end"])
    scan_max, predicted, table = _scan(prob, fig, hs)
    ref = float(table.rises(h, method)[:n_modes].max())
    # the top-ranked step size of the scan, followed in time: when each mode leaves its band
    best = float(hs[int(np.argmax(predicted.max(axis=1)))])
    best_energy, t_top = _mode_energy_run(prob, method, scan_eps, best, scan_t_end, 2000)
    variables = {
        "mode_energy": (("epsilon", "t", "k"), np.stack(energies)), "floor": ("epsilon", np.array(floor)),
        "scan_max_energy": (("point", "k"), scan_max), "predicted_rise": (("point", "k"), predicted),
        "top_energy": (("t_top", "k"), best_energy[:, :n_modes])}
    holdout_rho = fig.get("holdout_rho")
    if holdout_rho is not None:
        other = _problem(fig, float(holdout_rho))
        band, _ = _mode_energy_run(other, method, scan_eps, h, scan_t_end, 400)
        other_max, other_predicted, _ = _scan(other, fig, hs)
        variables |= {"holdout_max_energy": (("point", "k"), other_max),
                      "holdout_predicted_rise": (("point", "k"), other_predicted),
                      "holdout_band": ("k", band[:, :n_modes].max(axis=0))}
    k = np.arange(n_modes)
    ds = xr.Dataset(
        variables,
        coords={"epsilon": eps, "t": t, "t_top": t_top, "k": k,
                "omega": ("k", prob.mode_frequencies[:n_modes]), "h": ("point", hs)},
        attrs={"method": str(method), "n": int(fig["n"]), "rho": float(fig["rho"]), "step": h, "t_end": t_end,
               "scan_epsilon": scan_eps, "scan_t_end": scan_t_end, "step_rise": ref, "top_step": best,
               "exponent_tolerance": float(fig.get("exponent_tolerance", 0.15)),
               "floor_factor": float(fig.get("floor_factor", 1e3)), "band_bound": float(fig.get("band_bound", 1.0)),
               "break_factor": float(fig.get("break_factor", 10.0)), "recall_min": float(fig.get("recall_min", 0.9)),
               "first_factor": float(fig.get("first_factor", 100.0)),
               "precision_min": float(fig.get("precision_min", 0.8)),
               "ladder_min": float(fig.get("ladder_min", 0.9))},
    )
    if holdout_rho is not None:
        ds.attrs["holdout_rho"] = float(holdout_rho)
    ds["largest_rise"] = ("point", np.nanmax(scan_rise(ds), axis=1))  # what panel (c) plots
    ds["largest_predicted_rise"] = ("point", top_prediction(ds)[1])  # panel (c)'s flags
    ds["first_pass"] = (("point", "k"), _first_passes(ds, prob, "main"))
    if holdout_rho is not None:
        ds["holdout_first_pass"] = (("point", "k"), _first_passes(ds, other, "holdout"))
    return ds


def _first_passes(ds: xr.Dataset, prob, scan: str) -> np.ndarray:
    """At each step size of a scan with a predicted rise ≥ `first_factor`, followed in time: the
    first sample time at which each mode's energy passes `first_factor` × its band (inf where
    it never does; NaN at the step sizes not followed)."""
    a = ds.attrs
    band = _band(ds, scan)
    out = np.full((ds.point.size, ds.k.size), np.nan)
    for i in np.flatnonzero(top_prediction(ds, scan)[1] >= a["first_factor"]):
        energy, t = _mode_energy_run(prob, a["method"], a["scan_epsilon"], float(ds.h.values[i]), a["scan_t_end"],
                                     3000)
        over = energy[:, : ds.k.size] >= a["first_factor"] * band
        out[i] = np.where(over.any(axis=0), t[np.argmax(over, axis=0)], np.inf)
    return out


def _band(ds: xr.Dataset, scan: str) -> np.ndarray:
    """Each mode's band for a scan: max_t E_k at the non-resonant step size, same ε."""
    if scan == "main":
        return ds.mode_energy.sel(epsilon=ds.attrs["scan_epsilon"]).max("t").values
    return ds.holdout_band.values


def _problem(fig: dict, rho: float):
    return problems.wave(int(fig["n"]), rho=rho, potential=fig.get("potential", "-u**3/3"))


def _mode_energy_run(prob, method, eps: float, h: float, t_end: float, samples: int):
    """E_k(t) (time, mode) of u = ε cos x, v = 0 up to `t_end`, about `samples` samples."""
    (x,) = prob.grid
    n_steps = int(round(t_end / h))
    sol = integrate(prob, method, eps * np.cos(x), np.zeros_like(x), h=h, n_steps=n_steps,
                    save_every=max(1, n_steps // samples))
    return _mode_energies(sol.energies["action"]), sol.energies.t.values


def _scan(prob, fig: dict, hs: np.ndarray):
    """One ensemble lane per step size: max_t E_k per (point, mode), and the tool's predicted
    energy rise of each mode at each step size (:meth:`Combinations.rises`)."""
    (x,) = prob.grid
    method, n_modes = fig.get("method", "B"), int(fig.get("modes", 9))
    eps = float(fig["scan_epsilon"])
    u0 = eps * np.cos(x)
    ds = ensemble(prob, method, u0, np.zeros_like(u0), h=hs, t_end=float(fig["scan_t_end"]), progress=False)
    dev = ds.action_max_deviation
    start = _initial_mode_energies(prob, eps, x)
    scan_max = (dev * dev.omega).values[:, :n_modes] + start[:n_modes]  # max_t E_k ≤ E_k(0) + max |ΔE_k|
    table = combinations(prob, start, order=int(fig.get("order", 4)))
    predicted = np.array([table.rises(float(v), method)[:n_modes] for v in hs])
    return scan_max, predicted, table


def _mode_energies(action: xr.DataArray) -> np.ndarray:
    """E_k = ω_k J_k over (t, mode)."""
    return (action * action.omega).values


def _initial_mode_energies(prob, eps: float, x: np.ndarray) -> np.ndarray:
    """E_k of u = ε cos x, v = 0 from the problem's Fourier map (one value per mode)."""
    q = prob.fourier(eps * np.cos(x))
    blocks = prob.blocks
    out = np.zeros(len(prob.modes))
    for b in range(len(prob.modes)):
        sel = blocks == b + 1
        out[b] = 0.5 * float(np.sum(prob.omega[sel] ** 2 * q[sel] ** 2))
    return out


def counted_modes(ds: xr.Dataset) -> np.ndarray:
    """The modes whose largest energy is `floor_factor` above the round-off floor at every ε."""
    peak = ds.mode_energy.max("t").values  # (epsilon, k)
    return np.flatnonzero(np.all(peak >= ds.attrs["floor_factor"] * ds.floor.values[:, None], axis=0))


def exponents(ds: xr.Dataset) -> np.ndarray:
    """The power of ε in max_t E_k, fitted across ε (least squares in log-log), per mode."""
    peak = ds.mode_energy.max("t").values
    logs = np.log(ds.epsilon.values)
    return np.array([np.polyfit(logs, np.log(peak[:, k]), 1)[0] for k in range(peak.shape[1])])


def scan_rise(ds: xr.Dataset, scan: str = "main") -> np.ndarray:
    """max_t E_k over a scan divided by the mode's band, max_t E_k at the non-resonant step
    size for the same ε, per (point, k), for the counted modes other than the excited mode 1
    (NaN elsewhere). `scan` is "main" or "holdout" (the scan at the second ρ)."""
    measured = ds.scan_max_energy.values if scan == "main" else ds.holdout_max_energy.values
    return np.where(_kept(ds), measured / _band(ds, scan), np.nan)


def top_prediction(ds: xr.Dataset, scan: str = "main") -> tuple[np.ndarray, np.ndarray]:
    """Per scan point: the mode with the largest predicted rise among the counted modes other
    than the excited one, and that rise (what a flag is: a rise ≥ `break_factor`)."""
    predicted = ds.predicted_rise.values if scan == "main" else ds.holdout_predicted_rise.values
    predicted = np.where(_kept(ds), predicted, 0.0)
    mode = np.argmax(predicted, axis=1)
    return mode, predicted[np.arange(mode.size), mode]


def _kept(ds: xr.Dataset) -> np.ndarray:
    keep = np.zeros(ds.k.size, dtype=bool)
    keep[counted_modes(ds)] = True
    keep[1] = False
    return keep


def flag_match(ds: xr.Dataset, scan: str = "main") -> tuple[float, int, float, int]:
    """How the flags match the breaks over a scan: the share of flagged step sizes whose
    top-ranked stratum rises ≥ `break_factor` × its band (of how many flagged), and the share
    of step sizes where some stratum breaks that are flagged at h or a grid neighbour (of how
    many broken)."""
    factor = ds.attrs["break_factor"]
    rise = scan_rise(ds, scan)
    mode, predicted = top_prediction(ds, scan)
    flagged = predicted >= factor
    risen = np.nan_to_num(rise[np.arange(mode.size), mode], nan=0.0)
    broken = np.nanmax(rise, axis=1) >= factor
    near = flagged | np.r_[flagged[1:], False] | np.r_[False, flagged[:-1]]
    precision = float(np.mean(risen[flagged] >= factor)) if flagged.any() else np.nan
    recall = float(np.mean(near[broken])) if broken.any() else np.nan
    return precision, int(flagged.sum()), recall, int(broken.sum())


def ladder_share(ds: xr.Dataset, scan: str = "main") -> tuple[float, int]:
    """At the step sizes followed in time (predicted rise ≥ `first_factor`) where a counted
    stratum passes `first_factor` × its band: the share where the first to pass is the
    top-ranked mode j or a mode above it (k > j, which a broken j drives), and how many."""
    first = ds.first_pass.values if scan == "main" else ds.holdout_first_pass.values
    mode, _ = top_prediction(ds, scan)
    kept = _kept(ds)
    hits = []
    for i in np.flatnonzero(np.isfinite(np.where(kept, first, np.inf)).any(axis=1)):
        times = np.where(kept, first[i], np.inf)
        hits.append(int(np.argmin(times)) >= mode[i])
    return (float(np.mean(hits)) if hits else np.nan), len(hits)


def first_breaks(ds: xr.Dataset) -> np.ndarray:
    """At the top-ranked step size of the scan: the first sample time at which each mode's
    energy exceeds `first_factor` × its band (inf where it never does)."""
    over = ds.top_energy.values >= ds.attrs["first_factor"] * _band(ds, "main")
    t = ds.t_top.values
    return np.array([t[np.argmax(over[:, k])] if over[:, k].any() else np.inf for k in range(over.shape[1])])


def strata_claims(ds: xr.Dataset) -> list[Claim]:
    """The strata's exponents in ε, their bound at the non-resonant step size, and how the
    resonance tool's flags match where the strata break in the scans."""
    fig, a = ds.attrs["figure"], ds.attrs
    counted = counted_modes(ds)
    expected = band_exponents(ds.k.values)
    slopes = exponents(ds)
    worst = float(np.max(np.abs(slopes[counted] - expected[counted])))
    eps = ds.epsilon.values
    ratio = ds.mode_energy.values / eps[:, None, None] ** expected[None, None, :]
    bound = float(np.max(ratio[:, :, counted]))
    factor = a["break_factor"]
    mode, predicted = top_prediction(ds)
    best = int(np.argmax(predicted))
    j = int(mode[best])
    best_rise = float(np.nan_to_num(scan_rise(ds)[best, j], nan=0.0))
    first = first_breaks(ds)
    others = [first[m] for m in counted if m not in (1, j)]
    after = float(np.nanmin(others)) if np.isfinite(others).any() else np.inf
    modes = ", ".join(str(int(m)) for m in counted)
    claims = [
        Claim(fig, f"E_k ~ eps^(2k) (eps^4 for k = 0): largest |fitted exponent - 2k| over modes {modes} "
              "(those 1e3 above the round-off floor at every eps)", worst, "0",
              f"≤ {a['exponent_tolerance']:g}", bool(worst <= a["exponent_tolerance"])),
        Claim(fig, f"the strata hold over the whole run at h = {a['step']:g}, which the tool does not flag: "
              "max over t, eps and counted k of E_k / eps^(2k)", bound, f"≤ {a['band_bound']:g} (stated in advance)",
              f"predicted rise {a['step_rise']:.3g}", bool(bound <= a["band_bound"] and a["step_rise"] < factor)),
        Claim(fig, f"the step size of the scan with the largest predicted rise (h = {ds.h.values[best]:.4f}, "
              f"{predicted[best]:.2g}) breaks the predicted stratum, mode {j}: max_t E_j over its band "
              f"(max_t E_j at h = {a['step']:g})", best_rise, f"≥ {factor:g}", "the predicted mode",
              bool(best_rise >= factor)),
        Claim(fig, "at that step size the predicted stratum is the first to leave its band "
              f"(≥ {a['first_factor']:g} ×, a level set after looking: see the spec; followed in time): "
              f"mode {j} at t = {first[j]:.4g}, the next at t = {after:.4g}", first[j],
              f"mode {j} first", "earliest of the counted modes", bool(np.isfinite(first[j]) and first[j] < after)),
    ]
    scans = [("main", f"rho = {a['rho']:g} (the flag rule was chosen on this scan)")]
    if "holdout_rho" in a:
        scans.append(("holdout", f"rho = {a['holdout_rho']:g} (held out: first run after the thresholds were set)"))
    for scan, label in scans:
        precision, flagged, recall, broken = flag_match(ds, scan)
        claims += [
            Claim(fig, f"scan at {label}: at the step sizes the tool flags (predicted energy rise ≥ {factor:g}), "
                  f"the top-ranked stratum rises ≥ {factor:g} × its band: share of {flagged}", precision,
                  f"≥ {a['precision_min']:g}", "share", bool(precision >= a["precision_min"])),
            Claim(fig, f"scan at {label}: the step sizes where a stratum breaks (≥ {factor:g} × its band) that "
                  f"the tool flags (at h or a neighbour): share of {broken}", recall,
                  f"≥ {a['recall_min']:g}", "share", bool(recall >= a["recall_min"])),
        ]
        # A measurement, not a claim: stated in advance as a share ≥ `ladder_min` and tested on
        # the held-out scan, where it was not met (0.88 on 2026-11-27; see the spec).
        ladder, followed = ladder_share(ds, scan)
        held = ladder_share(ds, "holdout")[0] if "holdout_rho" in a else ladder
        claims.append(
            Claim(fig, f"scan at {label}: followed in time at the step sizes with a predicted rise ≥ "
                  f"{a['first_factor']:g} where a stratum passes {a['first_factor']:g} × its band, the first "
                  f"to pass is the top-ranked mode j or one above it (k > j, driven by j): share of {followed}",
                  ladder, f"≥ {a['ladder_min']:g} was stated in advance for the held-out scan",
                  f"{'met' if held >= a['ladder_min'] else 'not met'} there ({held:.2f}): withdrawn as a claim",
                  True, measurement=True))
    return claims
