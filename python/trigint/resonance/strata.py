"""Energy strata of a weakly nonlinear wave equation and the step sizes that break them.

For u_tt = Δu − ρu + u² (a quadratic nonlinearity) with small initial data in a few Fourier
modes, mode j is driven by products of the excited modes whose wavevectors add up to j: its
energy stays of the size the cheapest such product gives, over long times. With one mode
excited, u(·, 0) = ε cos x, that is E_k ~ ε^{2|k|} (mode 0: ε⁴), the *metastable energy
strata* of Gauckler, Hairer, Lubich, Weiss, Comm. PDE 37 (2012). A spectral collocation with a
symplectic trigonometric integrator keeps them when the step size is non-resonant (Gauckler,
Weiss, DCDS-A 37 (2017)); near ½h(ω_j ± ω_{k_1} ± … ± ω_{k_r}) ∈ πℤ \\ {0} with
j = ±k_1 ± … ± k_r (modulo the grid: collocation aliases) the small denominator
sin(½h(…)) of the modulated Fourier expansion lets mode j grow out of its stratum.

:func:`predicted_strata` computes the strata from initial mode energies; :func:`strata_resonances`
ranks the near-resonant combinations of modes above round-off by how far they are predicted to
lift the mode they drive above its stratum.
"""

from __future__ import annotations

import itertools

import numpy as np

from .._check import step_size
from .wave import WaveResonance, check_tolerance, mode_index, wave_problem

#: relative energies below this are round-off (double precision: about 1e-32 of the total for the
#: energies of a state known to 1e-16 relative); a stratum below it cannot be seen
ROUND_OFF = 1e-30


def predicted_strata(problem, mode_energies, degree: int = 2) -> np.ndarray:
    """The energy strata the initial mode energies set up: for each mode, the largest energy
    a product of the excited modes can drive into it.

    With amplitudes A = √E, a nonlinearity of `degree` d (u² in the equation: d = 2) couples
    mode j to every d-fold product whose signed wavevectors add up to j (modulo the grid). Their
    closure, A_j = max(A_j, max over j = ±k_1 ± … ± k_d of A_{k_1}⋯A_{k_d}), taken to its fixed
    point, is the stratum: E_j = A_j². For u(·, 0) = ε cos x this gives E_k ∝ ε^{2|k|} and
    E_0 ∝ ε⁴ (Gauckler, Hairer, Lubich, Weiss 2012); constants of order one are not predicted.

    Parameters
    ----------
    problem : WaveProblem
        From :func:`trigint.problems.wave`.
    mode_energies : array, shape (ℓ,)
        The initial energy of each mode (block), in the order of ``problem.modes``.
    degree : int
        The degree of the nonlinearity's leading term (2 for u², 3 for u³).

    Returns
    -------
    array, shape (ℓ,)
        The predicted energy of each mode (at least its initial energy).

    Examples
    --------
    >>> import numpy as np, trigint as ti
    >>> prob = ti.problems.wave(16, rho=0.5)
    >>> e = np.zeros(len(prob.modes)); e[1] = 1e-4          # mode 1 alone, ε = 1e-2
    >>> s = ti.resonance.predicted_strata(prob, e)
    >>> [f"{v:.0e}" for v in s[:5]]                       # modes 0, 1, 2, 3, 4
    ['1e-08', '1e-04', '1e-08', '1e-12', '1e-16']
    """
    energies = _energies(wave_problem(problem, "predicted_strata"), mode_energies)
    degree = int(degree)
    if degree < 2:
        raise ValueError(f"degree: the nonlinearity's degree must be at least 2, got {degree}")
    amplitude = np.sqrt(energies)
    index, shape, modes = mode_index(problem), np.asarray(problem.shape), problem.modes
    for _ in range(4 * len(modes)):  # each pass lengthens the products by one factor
        excited = np.flatnonzero(amplitude > 0)
        new = amplitude.copy()
        for pick in itertools.combinations_with_replacement(excited, degree):
            drive = float(np.prod(amplitude[list(pick)]))
            for signs in itertools.product((1, -1), repeat=degree - 1):
                j = modes[pick[0]] + sum(s * modes[k] for s, k in zip(signs, pick[1:], strict=True))
                b = _block(index, j, shape)
                if b is not None and drive > new[b]:
                    new[b] = drive
        if np.array_equal(new, amplitude):
            break
        amplitude = new
    return amplitude**2


def strata_resonances(problem, h: float, mode_energies, method="B", *, order: int = 4,
                      tolerance: float = 0.05, floor: float = ROUND_OFF, degree: int = 2) -> list[WaveResonance]:
    """The near-resonant combinations that can lift a mode out of its energy stratum, ranked.

    A combination is a mode j driven by r ≤ `order` modes k_i, all with predicted strata
    (:func:`predicted_strata`) above `floor` × the total, with j = ±k_1 ± … ± k_r (modulo the
    grid) and ½h(ω_j + s), s = ±ω_{k_1} ± … ± ω_{k_r}, within `tolerance` (|sin|) of a non-zero
    multiple of π. The drive, of frequency s, moves mode j by the solution z of
    2(cos hs − cos hω̃_j) z = h²ψ(hω̃_j) F in the method, of (ω_j² − s²) z = F in the equation:
    the method amplifies it by

        a = |h²ψ(hω̃_j)(ω_j² − s²) / (4 sin(½h(ω̃_j + s)) sin(½h(ω̃_j − s)))| · Πφ(hω̃_{k_i}),

    the small denominator of the modulated Fourier expansion with the method's filters (ψ → 0
    at hω̃_j ∈ πℤ for method B, which mutes those resonances). ``weight`` =
    (a · A_{k_1}⋯A_{k_r} / A_j)² (A = √E of the strata) is the predicted rise of mode j's
    *energy* above its stratum; ``affected`` is j. Largest weight first: the first entry is the
    stratum predicted to break first. :meth:`Combinations.rises` gives every mode's predicted
    rise from every combination, near a resonance or not (the amplification a carries the
    distance).

    Parameters
    ----------
    problem : WaveProblem
        From :func:`trigint.problems.wave`.
    h : float
        The step size.
    mode_energies : array, shape (ℓ,)
        The initial energy of each mode (block), in the order of ``problem.modes``.
    method : Method or str
        The method whose filters ψ, φ and frequencies ω̃ enter the amplification.
    order : int
        The most modes k_i in a combination (2: three-wave interactions, as
        :func:`wave_resonances`; 3 also catches j = k_1 + k_2 + k_3, two steps of u²).
    tolerance : float
        The threshold on the distance |sin(½h(ω_j + s))|, in (0, 1).
    floor : float
        Modes whose predicted stratum is below this fraction of the total energy are left out:
        round-off hides them.
    degree : int
        The nonlinearity's degree, as in :func:`predicted_strata`.

    Returns
    -------
    list of WaveResonance
        With ``affected`` (the mode j) and ``weight`` (the predicted rise of its energy).

    Examples
    --------
    u_tt = u_xx − u/2 + u² with u(·, 0) = 10⁻³ cos x on 32 points: at h = 0.9775,
    ½h(ω_3 + ω_1 + ω_2) is 2·10⁻⁴ from π, and mode 3 is predicted to leave its stratum ε⁶:

    >>> import numpy as np, trigint as ti
    >>> prob = ti.problems.wave(32, rho=0.5, potential="-u**3/3")
    >>> e = np.zeros(len(prob.modes)); e[1] = 1e-6
    >>> top = ti.resonance.strata_resonances(prob, 0.9775, e)[0]
    >>> top.affected, top.modes, round(top.distance, 4)
    ((3,), ((3,), (1,), (2,)), 0.0002)
    """
    wave_problem(problem, "strata_resonances")
    h = step_size(h)
    tolerance = check_tolerance(tolerance)
    table = combinations(problem, mode_energies, order=order, floor=floor, degree=degree)
    return table.resonances(h, method, tolerance)


class Combinations:
    """The mode combinations of :func:`strata_resonances` for one problem and initial state, built
    once and evaluated at any step size (a scan over h re-uses them).

    Attributes
    ----------
    target : array of int
        The block j each combination drives.
    drivers : list of tuple of int
        The blocks k_1, …, k_r of each combination.
    frequency_signs : array of int, shape (combinations, order)
        The signs of ω_{k_i} in s (0 where a combination has fewer than `order` modes).
    s : array
        The drive's frequency ±ω_{k_1} ± … ± ω_{k_r}.
    ratio : array
        A_{k_1}⋯A_{k_r} / A_j of the strata.
    """

    def __init__(self, problem, target, drivers, frequency_signs, s, ratio):
        self.problem, self.target, self.drivers = problem, target, drivers
        self.frequency_signs, self.s, self.ratio = frequency_signs, s, ratio
        pad = len(problem.modes)  # the index of the padding's |φ| = 1
        self._driver_table = np.full((len(drivers), frequency_signs.shape[1]), pad)
        for c, d in enumerate(drivers):
            self._driver_table[c, : len(d)] = d

    def resonances(self, h: float, method="B", tolerance: float = 0.05) -> list[WaveResonance]:
        """The combinations near a resonance at step size `h`, largest predicted rise first
        (see :func:`strata_resonances`).

        Parameters
        ----------
        h : float
            The step size.
        method : Method or str
            The method whose filters enter the amplification.
        tolerance : float
            The threshold on |sin(½h(ω_j + s))|.
        """
        omega, modes = self.problem.mode_frequencies, self.problem.modes
        j = self.target
        combo = omega[j] + self.s
        dist = np.abs(np.sin(0.5 * h * combo))
        near = np.flatnonzero((dist < tolerance) & (np.abs(0.5 * h * combo) >= np.pi / 2))
        if near.size == 0:
            return []
        weights = self._weights(h, method, near)
        found: dict = {}
        for c, weight in zip(near, weights, strict=True):
            b, weight = j[c], float(weight)
            vectors = (_wavevector(modes[b]),) + tuple(_wavevector(modes[k]) for k in self.drivers[c])
            key = (vectors, round(abs(float(combo[c])), 9))
            if key not in found or found[key].weight < weight:
                signs = (1, *(int(x) for x in self.frequency_signs[c, : len(self.drivers[c])]))
                found[key] = WaveResonance(vectors, signs, float(combo[c]), float(dist[c]), _wavevector(modes[b]),
                                           weight)
        return sorted(found.values(), key=lambda x: (-x.weight, x.modes))

    def rises(self, h: float, method="B") -> np.ndarray:
        """Every mode's predicted energy rise above its stratum at step size `h`: the largest
        ``weight`` of :func:`strata_resonances` over *every* combination that drives it, near a
        resonance or not (1 for a mode no combination drives). Where it reaches 10 the stratum
        is predicted to break; the amplification itself says how near the resonance is, so no
        distance threshold is applied.

        Parameters
        ----------
        h : float
            The step size.
        method : Method or str
            The method whose filters enter the amplification.

        Returns
        -------
        array, shape (ℓ,)
            One value per mode (block).

        Examples
        --------
        >>> import numpy as np, trigint as ti
        >>> prob = ti.problems.wave(32, rho=0.5, potential="-u**3/3")
        >>> e = np.zeros(len(prob.modes)); e[1] = 1e-6
        >>> rise = ti.resonance.combinations(prob, e).rises(0.965)
        >>> int(np.argmax(rise)), f"{rise.max():.0e}"         # mode 4 = 1 + 1 + 1 + 1
        (4, '9e+06')
        """
        h = step_size(h)
        out = np.ones(len(self.problem.modes))
        if self.target.size:
            np.maximum.at(out, self.target, self._weights(h, method, np.arange(self.target.size)))
        return out

    def _weights(self, h: float, method, chosen: np.ndarray) -> np.ndarray:
        """(a · A_{k_1}⋯A_{k_r} / A_j)² of the `chosen` combinations (see :func:`strata_resonances`)."""
        from .._method_names import resolve_method

        omega = self.problem.mode_frequencies
        coef = resolve_method(method).coefficients(h, omega)
        omega_tilde, psi, phi = coef.xi_tilde / h, coef.psi, coef.phi
        b, s = self.target[chosen], self.s[chosen]
        gain = np.abs(h * h * psi[b] * (omega[b] ** 2 - s * s) / (
            4 * np.sin(0.5 * h * (omega_tilde[b] + s)) * np.sin(0.5 * h * (omega_tilde[b] - s))))
        # Πφ(hω̃_{k_i}) over each combination's drivers: a padded index table, |φ| = 1 in the padding
        factors = np.abs(np.append(phi, 1.0))[self._driver_table[chosen]]
        return (gain * self.ratio[chosen] * np.prod(factors, axis=1)) ** 2

    def largest_rise(self, h: float, method="B", tolerance: float = 0.05) -> float:
        """The largest predicted rise at `h` (0 where nothing is near a resonance).

        Parameters
        ----------
        h : float
            The step size.
        method : Method or str
            The method whose filters enter the amplification.
        tolerance : float
            The threshold on |sin(½h(ω_j + s))|.
        """
        found = self.resonances(h, method, tolerance)
        return found[0].weight if found else 0.0


def combinations(problem, mode_energies, *, order: int = 4, floor: float = ROUND_OFF,
                 degree: int = 2) -> Combinations:
    """Every combination j = ±k_1 ± … ± k_r (r ≤ `order`) of modes above `floor`, with its signs
    of frequencies, for :func:`strata_resonances` and scans over step sizes.

    Parameters
    ----------
    problem : WaveProblem
        From :func:`trigint.problems.wave`.
    mode_energies : array, shape (ℓ,)
        The initial energy of each mode (block).
    order, floor, degree
        As in :func:`strata_resonances`.

    Returns
    -------
    Combinations
        Evaluate with ``.resonances(h, method, tolerance)``.

    Examples
    --------
    >>> import numpy as np, trigint as ti
    >>> prob = ti.problems.wave(32, rho=0.5, potential="-u**3/3")
    >>> e = np.zeros(len(prob.modes)); e[1] = 1e-6
    >>> table = ti.resonance.combinations(prob, e)
    >>> [r.affected for r in table.resonances(0.9775)[:1]]
    [(3,)]
    """
    wave_problem(problem, "combinations")
    order = int(order)
    if order < 2:
        raise ValueError(f"order: a combination drives a mode by at least 2 others, got {order}")
    strata = predicted_strata(problem, mode_energies, degree)
    total = float(strata.sum())
    amplitude = np.sqrt(strata)
    seen = np.flatnonzero(strata >= floor * total) if total > 0 else np.array([], dtype=int)
    omega, modes, shape = problem.mode_frequencies, problem.modes, np.asarray(problem.shape)
    index = mode_index(problem)
    in_view = set(int(b) for b in seen)
    target, drivers, signs, freq, ratio = [], [], [], [], []
    for r in range(2, order + 1):
        for pick in itertools.combinations_with_replacement(seen, r):
            drive = float(np.prod(amplitude[list(pick)]))
            targets = set()
            for wave_signs in itertools.product((1, -1), repeat=r - 1):
                b = _block(index, modes[pick[0]] + sum(w * modes[k] for w, k in zip(wave_signs, pick[1:], strict=True)),
                           shape)
                if b is not None and b in in_view and b not in pick:
                    targets.add(b)
            for b in sorted(targets):
                for freq_signs in itertools.product((1, -1), repeat=r):
                    target.append(b)
                    drivers.append(tuple(int(k) for k in pick))
                    signs.append(list(freq_signs) + [0] * (order - r))
                    freq.append(sum(f * omega[k] for f, k in zip(freq_signs, pick, strict=True)))
                    ratio.append(drive / amplitude[b])
    return Combinations(problem, np.asarray(target, dtype=np.int64), drivers,
                        np.asarray(signs, dtype=np.int64).reshape(-1, order), np.asarray(freq, dtype=float),
                        np.asarray(ratio, dtype=float))


def _energies(problem, mode_energies) -> np.ndarray:
    energies = np.abs(np.asarray(mode_energies, dtype=float).reshape(-1))
    if energies.size != len(problem.modes):
        raise ValueError(f"mode_energies: expected {len(problem.modes)} values (one per mode), got {energies.size}")
    if not np.all(np.isfinite(energies)):
        raise ValueError("mode_energies: every value must be finite")
    return energies


def _wavevector(m) -> tuple:
    return tuple(int(c) for c in m)


def _block(index: dict, j, shape: np.ndarray):
    """The block of wavevector j (aliased onto the grid), stored as j or as −j; None if absent."""
    j = tuple(int(x) for x in (np.asarray(j) + shape // 2) % shape - shape // 2)
    return index.get(j, index.get(tuple(-x for x in j)))
