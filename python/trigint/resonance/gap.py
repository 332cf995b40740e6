"""The gap lemma (Lemma 5.1) and the modified frequencies (Lemma 5.2) of paper §5, constructive."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import _check
from ._lattice import check_size, half_ball, hermite_basis, in_lattice
from .conditions import check_h_omega, frequencies, too_many_for

TWO_PI = 2.0 * np.pi


@dataclass
class ModifiedFrequencies:
    """The construction of Lemmas 5.1 and 5.2 and the checks of its conclusions.

    Returned by :func:`modified_frequencies`.

    Attributes
    ----------
    h, N, delta : float, int, float
        The step size, N and δ of the construction.
    omega : list of float
        The distinct frequencies ω_j.
    alpha, mu : float
        Lemma 5.1: no |sin(½h k·ω)| with ‖k‖₁ ≤ N+1 lies in [h^(1−α+μ), h^(1−α−μ)].
    gap : tuple of float
        That interval, (h^(1−α+μ), h^(1−α−μ)).
    near_resonant : list of list of int
        The k with |sin(½h k·ω)| ≤ h^(1−α+μ), one of each ±k (the set (5.4)).
    module_basis : list of list of int
        An integer (Hermite) basis of the module 𝓜 they generate.
    multiples : list of int
        m_i with |½h k^i·ω − πm_i| minimal, for the basis vectors.
    vartheta, varpi : list of float
        The minimal-norm ϑ with k^i·(ω + ϑ) = 2πm_i/h, and ϖ = ω + ϑ.
    lczero_residual : float
        (5.1): max |sin(½h k·ϖ)| over k ∈ 𝓜 with ‖k‖₁ ≤ N+1 (0 up to rounding).
    lcbound_min, lcbound_required : float
        (5.2): min |sin(½h k·ϖ)| over k ∉ 𝓜 with ‖k‖₁ ≤ N+1, and the bound ½h^(1−α−μ).
    max_shift : float
        (5.3): max_j |ϖ_j − ω_j|.
    gamma : float
        γ = max_shift · h^(α−μ), the constant of (5.3) for this ϖ.
    kappa : float
        κ = min_j |sin(hω_j)|.
    premise : bool
        The lemma's premise (3.2), κ ≥ √h.
    proof_condition : float
        h^(2μ) γ (N+1): the proof derives (5.2) from the gap when this is ≤ 1.
    unit_condition : float
        γ h^(1/2−α+μ): with (3.2), the proof excludes unit vectors and their doubles from 𝓜
        when this is < 1.
    checks : dict of str → bool
        Each conclusion of the lemmas, checked on the computed ϖ and 𝓜.
    verified : bool
        Whether every check holds.
    within_proof : bool
        Whether (3.2) and both conditions of the proof hold, so that every conclusion is
        guaranteed.

    Examples
    --------
    >>> from trigint.resonance import modified_frequencies
    >>> mf = modified_frequencies(0.02, [50.0, 100.0], N=2)
    >>> type(mf).__name__, mf.module_basis
    ('ModifiedFrequencies', [[2, -1]])
    """

    h: float
    N: int
    delta: float
    omega: list[float]
    alpha: float
    mu: float
    gap: tuple[float, float]
    near_resonant: list[list[int]]
    module_basis: list[list[int]]
    multiples: list[int]
    vartheta: list[float]
    varpi: list[float]
    lczero_residual: float
    lcbound_min: float
    lcbound_required: float
    max_shift: float
    gamma: float
    kappa: float
    premise: bool
    proof_condition: float
    unit_condition: float
    checks: dict = field(default_factory=dict)

    @property
    def verified(self) -> bool:
        """All conclusions of Lemma 5.2 hold for the computed ϖ and 𝓜."""
        return all(self.checks.values())

    @property
    def within_proof(self) -> bool:
        """Whether h is small enough for the proof of Lemma 5.2 to guarantee all its conclusions
        for these ϖ and 𝓜: (3.2) holds, h^(2μ) γ (N+1) ≤ 1 and γ h^(1/2−α+μ) < 1. The lemma
        holds for h ≤ h₀; beyond, a conclusion may fail (``checks`` says which) without
        contradicting it."""
        return self.premise and self.proof_condition <= 1 and self.unit_condition < 1

    def __str__(self) -> str:
        lines = [
            f"Modified frequencies (Lemmas 5.1, 5.2): h = {self.h:.10g}, N = {self.N}, delta = {self.delta:g}",
            f"  alpha = {self.alpha:.6g}, mu = {self.mu:.4g}: no |sin(h k.w/2)| in "
            f"[{self.gap[0]:.4g}, {self.gap[1]:.4g}]",
            f"  near-resonant k          {self.near_resonant or 'none'}",
            f"  module basis             {self.module_basis or 'none'}",
            f"  omega                    {self.omega}",
            f"  varpi                    {self.varpi}",
            f"  max |varpi_j - omega_j|  {self.max_shift:.4g} (gamma = {self.gamma:.4g})",
            f"  (5.1) max |sin(h k.varpi/2)| on M       = {self.lczero_residual:.3g}",
            f"  (5.2) min |sin(h k.varpi/2)| off M      = {self.lcbound_min:.4g} "
            f"{'>=' if self.lcbound_min >= self.lcbound_required else '<'} {self.lcbound_required:.4g}",
        ]
        lines.append(f"  premise (3.2)           kappa = {self.kappa:.4g} {'>=' if self.premise else '<'} sqrt(h)"
                     + ("" if self.premise else ": the lemma does not apply, its conclusions may fail"))
        ok = self.proof_condition <= 1
        lines.append(f"  h^(2 mu) gamma (N+1)    = {self.proof_condition:.4g} {'<=' if ok else '>'} 1"
                     + (": (5.2) follows from the gap" if ok else
                        ": h is beyond what the proof guarantees for (5.2) (the lemma holds for h <= h0)"))
        ok = self.unit_condition < 1
        lines.append(f"  gamma h^(1/2-alpha+mu)  = {self.unit_condition:.4g} {'<' if ok else '>='} 1"
                     + (": no unit vector or double in M" if ok else
                        ": h is beyond what the proof guarantees for the unit vectors"))
        lines += [f"  check {k:<31} {'holds' if v else 'FAILS'}" for k, v in self.checks.items()]
        return "\n".join(lines)


def gap(h: float, omega, N: int, delta: float = 0.25) -> tuple[float, float]:
    """Lemma 5.1: (α, μ) with δ/2 ≤ α ≤ δ and 0 < μ ≤ δ/2 such that no |sin(½h k·ω)| with
    ‖k‖₁ ≤ N+1 lies in [h^(1−α+μ), h^(1−α−μ)].

    μ depends only on N, ℓ, δ: with M the number of values (one per ±k), μ = δ/(4(M+1)), so by
    pigeonhole one of M + 1 equal sub-intervals of the exponents 1 − α ∈ [1 − δ, 1 − δ/2] is free;
    α is the centre of the widest free stretch.

    Parameters
    ----------
    h : float
        Step size, 0 < h < 1.
    omega : array of float or OscillatoryProblem
        The frequencies.
    N : int
        N ≥ 1 of the lemma: the k with ‖k‖₁ ≤ N + 1 count.
    delta : float
        δ in (0, ¼].

    Returns
    -------
    alpha, mu : float

    Examples
    --------
    >>> from trigint.resonance import gap
    >>> gap(0.01, [50.0], N=2)
    (0.1875, 0.015625)
    """
    h = _check.step_size(h)
    if h >= 1:
        raise ValueError(f"h: Lemma 5.1 is stated for 0 < h < 1, got {h}")
    w = frequencies(omega)
    check_h_omega(h, w)
    try:
        N = _check_N(N, w.size)
    except ValueError as exc:
        raise too_many_for(omega, exc) from None
    delta = _check_delta(delta)
    ks = half_ball(w.size, N + 1)
    values = np.abs(np.sin(0.5 * h * (ks @ w)))
    mu = delta / (4 * (len(ks) + 1))
    with np.errstate(divide="ignore"):
        exponents = np.log(values) / np.log(h)  # |s| = h^e; |s| = 0 gives e = inf
    lo, hi = 1 - delta, 1 - delta / 2  # the range of the centre 1 − α
    inside = np.sort(exponents[(exponents > lo - mu) & (exponents < hi + mu)])
    # Candidate free stretches between consecutive exponents, the window's ends included.
    edges = np.r_[lo - mu, inside, hi + mu]
    widths = np.diff(edges)
    best = int(np.argmax(widths))
    centre = float(np.clip(0.5 * (edges[best] + edges[best + 1]), lo, hi))
    # Shrink to the free stretch around the centre (half-width at least μ by pigeonhole).
    if np.any(np.abs(exponents - centre) < mu):
        raise RuntimeError("no gap found; this contradicts Lemma 5.1's pigeonhole argument")
    return 1 - centre, mu


def modified_frequencies(h: float, omega, N: int, delta: float = 0.25) -> ModifiedFrequencies:
    """Lemma 5.2: the module 𝓜 of near-resonant k and the modified frequencies ϖ = ω + ϑ.

    𝓜 is generated by the k with ‖k‖₁ ≤ N+1 and |sin(½h k·ω)| ≤ h^(1−α+μ) (α, μ from
    :func:`gap`); its integer basis k¹ … k^d is the Hermite normal form of those vectors. ϑ is the
    minimal-norm solution of k^i·(ω + ϑ) = 2πm_i/h with m_i the nearest integers to h k^i·ω/(2π).
    The conclusions (5.1), (5.2), (5.3) and that 𝓜 holds no unit vector
    and no double of one are checked on the result (``.checks``, ``.verified``).

    The lemma assumes (3.2), κ ≥ √h (``.premise``), and h ≤ h₀, some h₀ < 1 it does not
    state. Its proof shows how small h must be: with γ = max_j |ϖ_j − ω_j| h^(α−μ) (the
    constant of (5.3) for this ϖ), (5.2) follows from the gap when h^(2μ) γ (N+1) ≤ 1
    (``.proof_condition``), and 𝓜 holds no unit vector and no double of one when
    γ h^(1/2−α+μ) < 1 (``.unit_condition``). ``.within_proof`` says whether all three hold:
    then every conclusion is guaranteed. The conditions are sufficient, not necessary, and with
    μ as small as Lemma 5.1 makes it (about δ/(4M), M the number of values |sin(½h k·ω)|),
    h^(2μ) is close to 1, so any module with γ(N+1) > 1 is outside them: the h₀ of the lemma
    can be very small. Beyond, a failed check does not contradict the lemma: at h = 0.01995,
    ω = (50, 77, 181), N = 3, γ = 1.10 and μ ≈ 10⁻³ give h^(2μ) γ (N+1) = 4.38, and (5.2)
    misses (0.0213 < 0.0231); at h = 0.001 (5.2) holds with 1.45.

    Parameters
    ----------
    h : float
        Step size, 0 < h < 1.
    omega : array of float or OscillatoryProblem
        The frequencies.
    N : int
        N ≥ 1 of the lemma.
    delta : float
        δ in (0, ¼].

    Returns
    -------
    ModifiedFrequencies

    Examples
    --------
    >>> import numpy as np
    >>> from trigint.resonance import modified_frequencies
    >>> mf = modified_frequencies(2*np.pi/(3*50) * 1.0001, [50.0], N=3)
    >>> mf.module_basis, mf.verified
    ([[3]], True)
    """
    h = _check.step_size(h)
    w = frequencies(omega)
    check_h_omega(h, w)
    try:
        N = _check_N(N, w.size)
    except ValueError as exc:
        raise too_many_for(omega, exc) from None
    delta = _check_delta(delta)
    alpha, mu = gap(h, w, N, delta)
    upper, lower = h ** (1 - alpha + mu), h ** (1 - alpha - mu)
    ks = half_ball(w.size, N + 1)
    values = np.abs(np.sin(0.5 * h * (ks @ w)))
    near = ks[values <= upper]
    basis = hermite_basis(near)
    if basis:
        K = np.array(basis, dtype=float)
        multiples = [int(np.rint(h * (np.array(k) @ w) / TWO_PI)) for k in basis]
        rhs = TWO_PI * np.array(multiples) / h - K @ w
        vartheta = np.linalg.lstsq(K, rhs, rcond=None)[0]
    else:
        multiples, vartheta = [], np.zeros_like(w)
    varpi = w + vartheta
    kappa = float(np.min(np.abs(np.sin(h * w))))
    member = np.array([in_lattice(k, basis) for k in ks], dtype=bool) if basis else np.zeros(len(ks), bool)
    s_mod = np.abs(np.sin(0.5 * h * (ks @ varpi)))
    lczero = float(np.max(s_mod[member])) if member.any() else 0.0
    lcbound = float(np.min(s_mod[~member])) if (~member).any() else np.inf
    shift = float(np.max(np.abs(vartheta)))
    gamma = shift * h ** (alpha - mu)
    units = [np.eye(w.size, dtype=int)[j] * m for j in range(w.size) for m in (1, 2)]
    checks = {
        "gap (Lemma 5.1)": bool(not np.any((values > upper) & (values < lower))),
        "(5.1) resonances in M exact": lczero <= 1e-9,
        "(5.2) the rest bounded away": lcbound >= 0.5 * lower,
        "no unit vector or double in M": not any(in_lattice(u, basis) for u in units) if basis else True,
    }
    return ModifiedFrequencies(
        h=h, N=N, delta=delta, omega=w.tolist(), alpha=alpha, mu=mu, gap=(upper, lower),
        near_resonant=[list(map(int, k)) for k in near], module_basis=basis, multiples=multiples,
        vartheta=vartheta.tolist(), varpi=varpi.tolist(), lczero_residual=lczero, lcbound_min=lcbound,
        lcbound_required=0.5 * lower, max_shift=shift, gamma=gamma, kappa=kappa,
        premise=bool(kappa >= np.sqrt(h)), proof_condition=float(h ** (2 * mu) * gamma * (N + 1)),
        unit_condition=float(gamma * h ** (0.5 - alpha + mu)), checks=checks,
    )


def _check_N(N, ell: int) -> int:
    N = _check.integer(N, "N", low=1)
    check_size(ell, N + 1, "N")
    return N


def _check_delta(delta) -> float:
    delta = _check.real(delta, "delta")
    if not 0 < delta <= 0.25:
        raise ValueError(f"delta: must be in (0, 1/4], got {delta}")
    return delta
