"""The wave figure: the energy error of a spectrally discretized wave equation against the step
size, with the step sizes the resonance tool flags (Cohen, Hairer, Lubich, Numer. Math. 110
(2008), §3: numerical resonances ½h(ω_j ± ω_k ± ω_l) ∈ πℤ \\ {0})."""

from __future__ import annotations

import numpy as np
import xarray as xr

from .. import problems
from ..ensemble import ensemble
from ..resonance import cfl_number, wave_resonances


def run_wave(fig: dict) -> xr.Dataset:
    """Max relative deviation of H (and of the lowest modes' actions) over 0 ≤ t ≤ t_end for
    each step size of the scan, with the nearest flagged resonance of each step size."""
    prob = problems.wave(int(fig["n"]), rho=float(fig.get("rho", 0.5)), potential=fig.get("potential", "u**3/3"))
    (x,) = prob.grid
    u0 = float(fig.get("amplitude", 0.01)) * (x - np.pi) ** 2 * np.sin(x) ** 2
    h = np.linspace(float(fig["h_min"]), float(fig["h_max"]), int(fig.get("points", 481)))
    t_end = float(fig["t_end"])
    ds = ensemble(prob, fig.get("method", "B"), u0, np.zeros_like(u0), h=h, t_end=t_end, save_every=2**40,
                  progress=False)
    names = list(ds.energy.values)
    dev, initial = ds.max_deviation.values, ds.initial_energies.values
    energy = dev[:, names.index("total")] / np.abs(initial[:, names.index("total")])
    lowest = [names.index(f"oscillatory_{b + 1}") for b in range(min(6, prob.modes.shape[0]))]
    actions = (dev[:, lowest] / initial[:, lowest].max(axis=1, keepdims=True)).max(axis=1)
    tolerance = float(fig.get("tolerance", 0.005))
    nearest = np.full(h.size, np.nan)
    combination = np.full(h.size, "", dtype=object)
    for i, hi in enumerate(h):
        found = wave_resonances(prob, float(hi), tolerance=tolerance)
        if found:
            nearest[i] = found[0].distance
            combination[i] = " ".join(str(m[0]) for m in found[0].modes)
    return xr.Dataset(
        {"energy_deviation": ("point", energy), "action_deviation": ("point", actions),
         "resonance_distance": ("point", nearest), "resonance_modes": ("point", combination.astype(str))},
        coords={"h": ("point", h), "cfl": ("point", np.array([cfl_number(prob, float(v)) for v in h]))},
        attrs={"t_end": t_end, "method": str(fig.get("method", "B")), "n": int(fig["n"]),
               "tolerance": tolerance, "order": float(fig.get("order", 2.0)),
               "order_tolerance": float(fig.get("order_tolerance", 0.3)),
               "peak_factor": float(fig.get("peak_factor", 10.0)),
               "action_bound": float(fig.get("action_bound", 0.05)),
               "action_factor": float(fig.get("action_factor", 5.0))},
    )


def flagged(ds: xr.Dataset) -> np.ndarray:
    """The step sizes next to a flagged resonance (the point itself or a neighbour on the grid)."""
    hit = np.isfinite(ds.resonance_distance.values)
    return hit | np.r_[hit[1:], False] | np.r_[False, hit[:-1]]
