"""Numerical resonances of a spectrally discretized wave equation (Cohen, Hairer, Lubich,
Numer. Math. 110 (2008), §3): the CFL number hK and the mode combinations where the step
size meets the nonlinearity's interactions.

A quadratic (three-wave) interaction couples modes with j = k + l; the numerical solution
drifts where ½h(ω_j ± ω_k ± ω_l) is near a multiple of π (the small denominators
sin(½h(ω_j ± ω_k ± ω_l)) of the modulated Fourier expansion), and a mode with hω_j near a
non-zero multiple of π is resonant on its own (sin(hω_j) → 0, the filters' singular points).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._check import real, step_size


@dataclass(frozen=True)
class WaveResonance:
    """One near-resonant combination of a wave problem's modes at a step size.

    Attributes
    ----------
    modes : tuple of tuple of int
        The wavevectors (j, k, l) with j = k + l, or (j,) for a mode alone.
    signs : tuple of int
        The signs of ω_j, ω_k, ω_l in the combination ((1,) for a mode alone).
    combination : float
        ω_j ± ω_k ± ω_l, or ω_j for a mode alone.
    distance : float
        |sin(½h · combination)| for a triple, |sin(hω_j)| for a mode alone.

    Examples
    --------
    >>> import trigint as ti
    >>> r = ti.resonance.wave_resonances(ti.problems.wave(16, rho=0.0), 3.14159 / 3)[0]
    >>> r.modes, r.signs
    (((3,),), (1,))
    """

    modes: tuple
    signs: tuple
    combination: float
    distance: float


def cfl_number(problem, h: float) -> float:
    """The CFL number hK, K = the largest wavenumber |j|_∞ = n/2 of the grid.

    Parameters
    ----------
    problem : WaveProblem
        From :func:`trigint.problems.wave`.
    h : float
        The step size.

    Examples
    --------
    >>> import trigint as ti
    >>> ti.resonance.cfl_number(ti.problems.wave(64), 0.05)
    1.6
    """
    return float(step_size(h) * max(problem.shape) / 2)


def wave_resonances(problem, h: float, tolerance: float = 0.05, max_modes: int = 64) -> list[WaveResonance]:
    """The near-resonant mode combinations of a wave problem at step size h, nearest first.

    Checks every mode alone (|sin(hω_j)| < tolerance, hω_j ≥ π/2) and every triple j = k + l
    among the `max_modes` lowest modes (|sin(½h(ω_j ± ω_k ± ω_l))| < tolerance with
    ½h|ω_j ± ω_k ± ω_l| ≥ π/2: near a non-zero multiple of π).

    Parameters
    ----------
    problem : WaveProblem
        From :func:`trigint.problems.wave`.
    h : float
        The step size.
    tolerance : float
        The threshold on the distance, in (0, 1).
    max_modes : int
        How many of the lowest modes enter the triples (the count grows as max_modes²).

    Examples
    --------
    >>> import numpy as np, trigint as ti
    >>> prob = ti.problems.wave(16, rho=0.0)
    >>> r = ti.resonance.wave_resonances(prob, np.pi / 3 - 1e-5)  # hω_3 ≈ π
    >>> r[0].modes, round(r[0].distance, 7)
    (((3,),), 3e-05)
    """
    h = step_size(h)
    tolerance = real(tolerance, "tolerance", positive=True)
    if tolerance >= 1:
        raise ValueError(f"tolerance: must be in (0, 1), got {tolerance}")
    modes, omega = problem.modes, problem.mode_frequencies
    found: list[WaveResonance] = []
    alone = np.abs(np.sin(h * omega))
    for b in np.flatnonzero((alone < tolerance) & (h * omega >= np.pi / 2)):
        found.append(WaveResonance(((tuple(int(c) for c in modes[b]),)), (1,), float(omega[b]), float(alone[b])))
    low = min(int(max_modes), modes.shape[0])
    index = {tuple(int(c) for c in m): b for b, m in enumerate(modes)}

    def lookup(j):
        """The block of wavevector j (stored as j or as −j) and the stored wavevector, or (None, None)."""
        for key in (tuple(int(c) for c in j), tuple(-int(c) for c in j)):
            if key in index:
                return index[key], key
        return None, None

    shape = np.asarray(problem.shape)
    for a in range(low):
        for b in range(a, low):
            for sign_l in (1, -1):
                j = (modes[a] + sign_l * modes[b] + shape // 2) % shape - shape // 2
                c, key = lookup(j)
                if c is None:
                    continue
                for s1 in (1, -1):
                    for s2 in (1, -1):
                        combo = omega[c] + s1 * omega[a] + s2 * omega[b]
                        # near a non-zero multiple of π only: near 0 the combination is a
                        # resonance of the equation itself, which every step size sees
                        if abs(0.5 * h * combo) < np.pi / 2:
                            continue
                        dist = abs(np.sin(0.5 * h * combo))
                        if dist < tolerance:
                            found.append(WaveResonance(
                                (key, tuple(int(x) for x in modes[a]),
                                 tuple(int(x) for x in sign_l * modes[b])), (1, s1, s2), float(combo), float(dist)))
    # one entry per combination (the loops meet each triple from both of its summands)
    unique = {(tuple(sorted(tuple(abs(c) for c in m) for m in r.modes)), round(abs(r.combination), 9)): r
              for r in reversed(found)}
    return sorted(unique.values(), key=lambda r: (r.distance, r.modes))
