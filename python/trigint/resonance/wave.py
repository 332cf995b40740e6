"""Numerical resonances of a spectrally discretized wave equation (Cohen, Hairer, Lubich,
Numer. Math. 110 (2008), §3): the CFL number hK and the mode combinations where the step
size meets the nonlinearity's interactions.

A quadratic (three-wave) interaction couples modes with j = k + l; the numerical solution
drifts where ½h(ω_j ± ω_k ± ω_l) is near a multiple of π (the small denominators
sin(½h(ω_j ± ω_k ± ω_l)) of the modulated Fourier expansion), and a mode with hω_j near a
non-zero multiple of π is resonant on its own (sin(hω_j) → 0, the filters' singular points).
"""

from __future__ import annotations

import math
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
    affected : tuple of int or None
        From :func:`energy_resonances`: the wavevector predicted to gain energy.
    weight : float
        From :func:`energy_resonances`: the ranking weight (0 otherwise).

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
    affected: tuple | None = None
    weight: float = 0.0


def wave_problem(problem, function: str):
    """`problem` if it is a wave problem (:func:`trigint.problems.wave`); a TypeError naming
    `function` and, for an ODE problem, the analysis that takes it, otherwise."""
    # by what the analyses read (trigint.wave imports this module: no import of it back)
    if hasattr(problem, "modes") and hasattr(problem, "mode_frequencies"):
        return problem
    got = type(problem).__name__
    hint = ("; for an ODE problem, ti.resonance.analyze(h, problem) checks the non-resonance conditions of its "
            "frequencies" if hasattr(problem, "omega") and hasattr(problem, "potential") else "")
    raise TypeError(f"problem: {function} needs a wave problem, from ti.problems.wave(...), got {got}{hint}")


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
    return float(step_size(h) * max(wave_problem(problem, "cfl_number").shape) / 2)


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
    problem = wave_problem(problem, "wave_resonances")
    h = step_size(h)
    tolerance = check_tolerance(tolerance)
    modes, omega = problem.modes, problem.mode_frequencies
    found: list[WaveResonance] = []
    alone = np.abs(np.sin(h * omega))
    for b in np.flatnonzero((alone < tolerance) & (h * omega >= np.pi / 2)):
        found.append(WaveResonance(((tuple(int(c) for c in modes[b]),)), (1,), float(omega[b]), float(alone[b])))
    low = min(int(max_modes), modes.shape[0])
    for _, _, _, wavevectors, signs, combo, dist in _triples(problem, h, tolerance, range(low)):
        found.append(WaveResonance(wavevectors, signs, combo, dist))
    # one entry per combination (the loops meet each triple from both of its summands)
    unique = {_combination(r): r for r in reversed(found)}
    return sorted(unique.values(), key=lambda r: (r.distance, r.modes))


def check_tolerance(tolerance) -> float:
    """A threshold on a distance |sin(…)|: a number in (0, 1)."""
    tolerance = real(tolerance, "tolerance", positive=True)
    if tolerance >= 1:
        raise ValueError(f"tolerance: must be in (0, 1), got {tolerance}")
    return tolerance


def _combination(r: WaveResonance) -> tuple:
    """What identifies a combination whichever of its summands it was met from."""
    return tuple(sorted(tuple(abs(c) for c in m) for m in r.modes)), round(abs(r.combination), 9)


def mode_index(problem) -> dict:
    """{wavevector: block} of a wave problem's modes, made once per problem (a 2¹⁶-point grid has
    32 769 modes: building it took 38 ms, on every run that checks resonances)."""
    index = problem.__dict__.get("_mode_index")
    if index is None:
        index = {m: b for b, m in enumerate(mode_list(problem))}
        problem.__dict__["_mode_index"] = index
    return index


def mode_list(problem) -> list:
    """The wavevector of each mode (block) of a wave problem as a tuple of ints, made once per
    problem: the triples' sums in Python integers (a NumPy sum of two wavevectors took 10 µs)."""
    modes = problem.__dict__.get("_mode_list")
    if modes is None:
        modes = problem.__dict__["_mode_list"] = [tuple(m) for m in problem.modes.tolist()]
    return modes


def _triples(problem, h: float, tolerance: float, blocks):
    """The triples j = k ± l of modes k, l in `blocks` (each pair once) whose ½h(ω_j ± ω_k ± ω_l)
    is within `tolerance` (|sin|) of a non-zero multiple of π: (block of j, block of k, block of l,
    the three wavevectors, the signs, the combination, the distance)."""
    modes, omega = mode_list(problem), problem.mode_frequencies
    shape = [int(n) for n in problem.shape]
    half = [n // 2 for n in shape]
    index = mode_index(problem)
    blocks = list(blocks)
    for i, a in enumerate(blocks):
        for b in blocks[i:]:
            for sign_l in (1, -1):
                # the wavevector k ± l wrapped into the grid's frequencies (-n/2 … n/2 − 1)
                j = tuple((x + sign_l * y + m) % n - m
                          for x, y, n, m in zip(modes[a], modes[b], shape, half, strict=True))
                c = index.get(j, index.get(tuple(-x for x in j)))  # stored as j or as −j
                if c is None:
                    continue
                # (Python floats and math.sin: the same sums as NumPy's scalars, at a tenth of
                # their cost; a sine within an ulp of NumPy's, for a threshold and a ranking)
                wc, wa, wb = float(omega[c]), float(omega[a]), float(omega[b])
                for s1 in (1, -1):
                    for s2 in (1, -1):
                        combo = wc + s1 * wa + s2 * wb
                        # near a non-zero multiple of π only: near 0 the combination is a
                        # resonance of the equation itself, which every step size sees
                        if abs(0.5 * h * combo) < math.pi / 2:
                            continue
                        dist = abs(math.sin(0.5 * h * combo))
                        if dist < tolerance:
                            wavevectors = (modes[c], modes[a], tuple(sign_l * x for x in modes[b]))
                            yield c, a, b, wavevectors, (1, s1, s2), float(combo), float(dist)


#: a mode carries energy when it holds at least this fraction of the oscillatory energy (far above
#: the round-off of the energies, about 1e-32 of the total, and below the smallest stratum the
#: warnings care about)
CARRIES_ENERGY = 1e-10


def energy_resonances(problem, h: float, mode_energies, tolerance: float = 0.05, floor: float = CARRIES_ENERGY,
                      max_modes: int = 64) -> list[WaveResonance]:
    """The near-resonant combinations of :func:`wave_resonances` that can move energy, ranked.

    A mode alone counts when it carries energy (E_j ≥ `floor` · Σ E); a triple j = k ± l when at
    least two of its modes do: the third is the one predicted to gain energy (``affected``, the
    combination's mode with the least energy). Ranked by ``weight`` = (product of the amplitudes
    √E of the two most energetic modes, or E_j alone, relative to Σ E) / distance: the small
    denominator of the modulated Fourier expansion times what drives it (Cohen, Hairer, Lubich,
    Numer. Math. 110 (2008), §3).

    Parameters
    ----------
    problem : WaveProblem
    h : float
        The step size.
    mode_energies : array, shape (ℓ,)
        The energy of each mode (block) of `problem`, in the order of ``problem.modes``, e.g.
        ``[sol.initial_energies[f"oscillatory_{b + 1}"] for b in range(len(problem.modes))]``.
    tolerance, max_modes
        As in :func:`wave_resonances`.
    floor : float
        The fraction of the total below which a mode is taken to carry no energy.

    Examples
    --------
    >>> import numpy as np, trigint as ti
    >>> prob = ti.problems.wave(16, rho=0.0)
    >>> e = np.zeros(len(prob.modes)); e[2] = 1.0          # mode 3 alone carries energy
    >>> r = ti.resonance.energy_resonances(prob, np.pi / 3 - 1e-5, e)  # hω_3 ≈ π
    >>> r[0].modes, r[0].affected
    (((3,),), (3,))
    """
    problem = wave_problem(problem, "energy_resonances")
    energies = np.abs(np.asarray(mode_energies, dtype=float).reshape(-1))
    if energies.size != len(problem.modes):
        raise ValueError(f"mode_energies: expected {len(problem.modes)} values (one per mode), got {energies.size}")
    # (the finite energies' sum; where all are finite, the plain sum is that sum, without the
    # mask and the copy it makes: one array of 2¹⁵ numbers fewer after every wave run)
    total = float(np.sum(energies))
    if not np.isfinite(total):
        total = float(np.sum(energies[np.isfinite(energies)]))
    if total <= 0.0:
        return []
    relative = np.divide(energies, total, out=energies)  # (energies, a new array, are not read again)
    carrying = relative >= floor
    h = step_size(h)
    omega, modes = problem.mode_frequencies, mode_list(problem)
    ranked: dict = {}

    def keep(r: WaveResonance):
        key = _combination(r)
        if key not in ranked or ranked[key].weight < r.weight:
            ranked[key] = r

    # (only the modes that carry energy are looked at: a 2¹⁶-point grid's sin(hω) over all
    # 32 769 modes took most of a run's check)
    drivers = np.flatnonzero(carrying)
    alone = np.abs(np.sin(h * omega[drivers]))
    for b, d in zip(drivers, alone, strict=True):
        if d < tolerance and h * omega[b] >= np.pi / 2:
            m = modes[b]
            keep(WaveResonance((m,), (1,), float(omega[b]), float(d), m, float(relative[b]) / max(float(d), 1e-300)))
    # Triples j = k ± l driven by two modes that carry energy (the most energetic max_modes).
    drivers = drivers[np.argsort(-relative[drivers], kind="stable")][: int(max_modes)]
    for c, a, b, wavevectors, signs, combo, dist in _triples(problem, h, tolerance, drivers):
        e = relative[[c, a, b]]
        least = (c, a, b)[int(np.argmin(e))]
        top = np.sort(e)[-2:]
        keep(WaveResonance(wavevectors, signs, combo, dist, modes[least],
                           float(np.sqrt(top[0] * top[1])) / max(dist, 1e-300)))
    ranked = list(ranked.values())
    return sorted(ranked, key=lambda r: -r.weight)
