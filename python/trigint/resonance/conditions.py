"""The assumptions and non-resonance conditions of Theorems 3.1/3.2 (paper §3), computed."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field

import numpy as np

from .. import _check
from .._method_names import resolve_method
from ..methods import AlphaMethod, Method, ModifiedTrigonometric
from ._lattice import check_size, half_ball, hermite_basis

TWO_PI = 2.0 * np.pi


@dataclass(frozen=True)
class Violation:
    """A near-resonance: |h k·ω − 2πr| (or |sin(½h k·ω)|) below √h.

    Attributes
    ----------
    k : tuple of int
        The integer vector k (its first non-zero entry positive).
    r : int
        The multiple of 2π that h k·ω is near.
    distance : float
        |h k·ω − 2πr| for condition (3.6), |sin(½h k·ω)| for (3.7).

    Examples
    --------
    >>> import numpy as np
    >>> from trigint.resonance import nonresonance_violations
    >>> v = nonresonance_violations(2 * np.pi / 3 / 50, np.array([50.0]), 3)[0]
    >>> v.k, v.r, v.distance < 1e-12
    ((3,), 1, True)
    """

    k: tuple[int, ...]
    r: int
    distance: float

    def to_dict(self) -> dict:
        """``{"k": [...], "r": r, "distance": d}``, for JSON."""
        return {"k": list(self.k), "r": self.r, "distance": self.distance}


def frequencies(omega) -> np.ndarray:
    """The distinct non-zero frequencies ω_1 … ω_ℓ, in order of first appearance; of an
    :class:`~trigint.OscillatoryProblem`, its block frequencies (those of its stiffness matrix)."""
    from ..problem import OscillatoryProblem

    if isinstance(omega, OscillatoryProblem) and not omega.stepper.has_spectrum:
        from .._stiffness import DENSE_MAX

        dense = ", or build the problem with path='dense'" if omega.dim <= DENSE_MAX else ""
        raise ValueError(
            f"omega: the resonance analysis needs the problem's frequencies, which a problem on the Krylov path "
            f"(path='krylov', a sparse stiffness matrix of n = {omega.dim}) never computes; give the frequencies "
            "themselves as omega (the square roots of the stiffness matrix's eigenvalues, e.g. from "
            f"scipy.sparse.linalg.eigsh){dense}")
    if hasattr(omega, "block_frequencies") and hasattr(omega, "potential"):
        w = np.asarray(omega.block_frequencies, dtype=float)
        if w.size == 0:
            raise ValueError("omega: the problem has no non-zero frequency")
        return w
    w = _check.real_array(omega, "omega", ndim=None, finite=False, nonempty=False).reshape(-1)
    if w.size == 0:
        raise ValueError("omega: give at least one frequency")
    if not np.all(np.isfinite(w)):
        raise ValueError(f"omega: frequencies must be finite, got {w[~np.isfinite(w)][0]}")
    if np.any(w < 0):
        raise ValueError(f"omega: frequencies must be >= 0, got {w[w < 0][0]}")
    if np.any(w > 1e150):
        raise ValueError(f"omega: frequencies up to 1e150 are allowed (omega**2 must stay finite), got {w.max():g}")
    distinct: list[float] = []
    for x in w:
        if x > 0 and x not in distinct:
            distinct.append(float(x))
    if not distinct:
        raise ValueError("omega: need at least one non-zero frequency")
    return np.array(distinct)


def too_many_for(omega, exc: ValueError) -> ValueError:
    """`exc`, an enumeration too large for the frequencies of `omega`; for a wave problem, with
    the analysis meant for its many modes."""
    if not hasattr(omega, "mode_frequencies"):  # (trigint.wave imports this package: no import back)
        return exc
    return ValueError(f"{exc}. This wave problem has {len(omega.modes)} mode frequencies: "
                      "ti.resonance.wave_resonances(problem, h) checks its modes and the triples j = k + l that the "
                      "nonlinearity couples (this analysis, which enumerates every integer combination of the "
                      "frequencies, is meant for an ODE problem with a few of them)")


def _power(h: float, e: float) -> float:
    """h**e, inf where it overflows (a tiny h)."""
    with np.errstate(over="ignore", divide="ignore"):
        return float(np.power(np.float64(h), float(e)))


def check_h_omega(h: float, w: np.ndarray) -> None:
    from ..methods import LARGEST_H_OMEGA

    if h * float(np.max(w)) > LARGEST_H_OMEGA:
        raise ValueError(f"h, omega: h*omega = {h * float(np.max(w)):.3g} is too large (at most {LARGEST_H_OMEGA:g}): "
                         "sin(h*omega) is rounding noise there")


#: the most pairs (k, r) nonresonance_violations may list
MAX_CANDIDATES = 1_000_000


def _check_n_max(N_max) -> int:
    return _check.integer(N_max, "N_max", low=1)


def _check_vectors(h, omega, radius, what: str = "radius", need_h: bool = True):
    """Validated (h, ω, radius) of the enumerations below."""
    h = _check.step_size(h) if need_h else None
    w = _check.real_array(omega, "omega", nonneg=True).reshape(-1)
    radius = _check.integer(radius, what, low=1)
    check_size(w.size, radius, what)
    return h, w, radius


def nonresonance_violations(h: float, omega: np.ndarray, radius: int) -> list[Violation]:
    """Every (k, r), ‖k‖₁ ≤ radius, r ≠ 0, with |h k·ω − 2πr| < √h (3.6).

    One of each pair ±(k, r) is listed (first non-zero entry of k positive); sorted by ‖k‖₁,
    then distance.

    Parameters
    ----------
    h : float
        Step size.
    omega : array of float
        The frequencies ω_j.
    radius : int
        The largest ‖k‖₁.

    Returns
    -------
    list of Violation

    Examples
    --------
    >>> import numpy as np
    >>> from trigint.resonance import nonresonance_violations
    >>> [(v.k, v.r) for v in nonresonance_violations(2 * np.pi / 3 / 50, np.array([50.0]), 3)]
    [((3,), 1)]
    """
    h, omega, radius = _check_vectors(h, omega, radius)
    ks = half_ball(omega.size, radius)
    x = h * (ks @ omega)
    root = np.sqrt(h)
    out = []
    lo = np.ceil((x - root) / TWO_PI).astype(np.int64)
    hi = np.floor((x + root) / TWO_PI).astype(np.int64)
    candidates = float(np.sum(np.maximum(hi - lo + 1, 0)))
    if candidates > MAX_CANDIDATES:
        raise ValueError(f"h: with h = {h:g} the band |h k.w - 2 pi r| < sqrt(h) = {root:.3g} holds {candidates:.3g} "
                         f"pairs (k, r), more than {MAX_CANDIDATES:.0e}; the condition is meant for small h "
                         "(sqrt(h) well below pi)")
    for i in np.flatnonzero(hi >= lo):
        for r in range(lo[i], hi[i] + 1):
            d = abs(x[i] - TWO_PI * r)
            if r != 0 and d < root:
                out.append(Violation(tuple(int(v) for v in ks[i]), int(r), float(d)))
    return sorted(out, key=lambda v: (sum(map(abs, v.k)), v.distance))


def resonance_module(omega: np.ndarray, radius: int, tol: float = 1e-10) -> list[list[int]]:
    """An integer (Hermite) basis of the module generated by the exact relations k·ω = 0,
    ‖k‖₁ ≤ radius; a relation counts as exact when |k·ω| ≤ tol · ‖k‖₁ · max ω.

    Parameters
    ----------
    omega : array of float
        The frequencies ω_j.
    radius : int
        The largest ‖k‖₁.
    tol : float
        The relative tolerance above.

    Returns
    -------
    list of list of int
        The basis vectors, rows of a Hermite normal form (empty: no relation).

    Examples
    --------
    >>> import numpy as np
    >>> from trigint.resonance import resonance_module
    >>> resonance_module(np.array([50.0, 100.0]), 3)  # 2·ω₁ − ω₂ = 0
    [[2, -1]]
    """
    _, omega, radius = _check_vectors(None, omega, radius, need_h=False)
    tol = _check.real(tol, "tol", nonneg=True)
    ks = half_ball(omega.size, radius)
    dots = ks @ omega
    exact = np.abs(dots) <= tol * np.abs(ks).sum(axis=1) * omega.max()
    return hermite_basis(ks[exact])


def _first_violating_norm(violations) -> int | None:
    return min((sum(map(abs, v.k)) for v in violations), default=None)


@dataclass
class ResonanceReport:
    """What the paper's theory says about step size h for frequencies ω (see :func:`analyze`).

    Printed, it is the table of ``trigint resonance``; :meth:`to_json` is its ``--json``.

    Attributes
    ----------
    h : float
        The step size.
    omega : list of float
        The frequencies as given (every coordinate's, slow ones included).
    method : str
        The method's representation.
    modified : bool
        Whether the method modifies the frequencies (then every condition is on hω̃).
    frequencies : list of float
        The distinct non-zero frequencies ω_1 … ω_ℓ.
    h_omega : list of float
        hω_j (hω̃_j for a modified method).
    epsilon, h_over_epsilon : float
        ε = 1/min_j ω_j and h/ε.
    kappa : float
        κ = min_j |sin(hω_j)| (3.2).
    kappa_ok : bool
        Whether κ ≥ √h.
    sigma : list of float
        σ(hω_j) = sinc·φ/ψ (3.3).
    assumption_B : bool
        Whether σ has one sign at every hω_j (then c₁ ≤ |σ| ≤ C₁).
    c1, C1 : float
        min_j |σ(hω_j)| and max_j |σ(hω_j)|.
    symplectic : bool
        Whether the method is symplectic at h (2.4).
    N : int
        The largest N ≤ N_max for which (3.6) holds (−1: a single frequency is resonant).
    N_max : int
        The largest N tested.
    violations : list of Violation
        The (k, r) that stop N + 1, with |h k·ω − 2πr| < √h.
    N_old : int
        The same N for the older condition (3.7).
    violations_old : list of Violation
        The k ∉ 𝓜 that stop N_old + 1, with |sin(½h k·ω)| < √h.
    module_basis : list of list of int
        An integer basis of the resonance module 𝓜 = {k : k·ω = 0}.
    time_scale : float
        h^(−N), the end of the interval of Theorem 3.1 (3.2).
    slow_error : float
        h^(1−δ), the size of the change of H_slow.
    oscillatory_error : float
        h^(1−δ)/κ, the size of the change of H*_ω.
    delta : float
        δ of the theorems.
    alpha : float or None
        α of an α-method.
    h_omega_limit : float or None
        An α-method's bound on hω (inf for α ≥ ¼).
    notes : list of str
        What else the analysis found (an undefined method, h ≥ 1, a resonant frequency).

    Examples
    --------
    >>> import numpy as np
    >>> from trigint.resonance import analyze
    >>> report = analyze(2 * np.pi / 3 / 50, [50.0])
    >>> report.N, report.kappa_ok, report.assumption_B
    (1, True, True)
    """

    h: float
    omega: list[float]
    method: str
    modified: bool
    frequencies: list[float]
    h_omega: list[float]
    epsilon: float
    h_over_epsilon: float
    kappa: float
    kappa_ok: bool
    sigma: list[float]
    assumption_B: bool
    c1: float
    C1: float
    symplectic: bool
    N: int
    N_max: int
    violations: list[Violation]
    N_old: int
    violations_old: list[Violation]
    module_basis: list[list[int]]
    time_scale: float
    slow_error: float
    oscillatory_error: float
    delta: float
    alpha: float | None = None
    h_omega_limit: float | None = None
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        """Every attribute, violations as dictionaries."""
        d = asdict(self)
        d["violations"] = [v.to_dict() for v in self.violations]
        d["violations_old"] = [v.to_dict() for v in self.violations_old]
        return d

    def to_json(self) -> str:
        """:meth:`to_dict` as JSON, with infinities as ``"inf"`` and NaN as ``null``."""

        def clean(x):
            if isinstance(x, float) and not np.isfinite(x):
                return None if np.isnan(x) else ("inf" if x > 0 else "-inf")
            if isinstance(x, dict):
                return {k: clean(v) for k, v in x.items()}
            if isinstance(x, list):
                return [clean(v) for v in x]
            return x

        return json.dumps(clean(self.to_dict()), indent=2)

    def __str__(self) -> str:
        freq = "h*omega_tilde" if self.modified else "h*omega"
        lines = [
            f"Resonance analysis: h = {self.h:.10g}, method {self.method}",
            f"  frequencies omega_j      {_fmt(self.frequencies)}",
            f"  {freq:<24} {_fmt(self.h_omega)}",
        ]
        if self.h_omega_limit is not None and np.isfinite(self.h_omega_limit):
            lines.append(f"  step restriction         h*omega < {self.h_omega_limit:.10g} (alpha = {self.alpha:g})")
        lines += [
            f"  h/eps                    {self.h_over_epsilon:.6g}",
            f"  kappa = min|sin(h w_j)|  {self.kappa:.6g}   {'>=' if self.kappa_ok else '<'} sqrt(h) = "
            f"{np.sqrt(self.h):.6g}  non-resonance (3.2) {'holds' if self.kappa_ok else 'FAILS'}",
            f"  sigma(h w_j)             {_fmt(self.sigma)}",
            f"  Assumption B             {'holds' if self.assumption_B else 'FAILS'} "
            f"(c1 = {self.c1:.6g}, C1 = {self.C1:.6g})",
            f"  symplectic               {'yes' if self.symplectic else 'no'}",
            f"  resonance module basis   {self.module_basis or 'none (no exact relation k.w = 0)'}",
            f"  numerical non-resonance |h k.w - 2 pi r| >= sqrt(h), eq. (3.6): holds up to N = {self.N}"
            + (" (N_max)" if self.N == self.N_max else ""),
        ]
        lines += _violation_table(self.violations, "|h k.w - 2 pi r|", self.N)
        lines.append(f"  older condition |sin(h k.w / 2)| >= sqrt(h), eq. (3.7): holds up to N = {self.N_old}"
                     + (" (N_max)" if self.N_old == self.N_max else ""))
        lines += _violation_table(self.violations_old, "|sin(h k.w / 2)|", self.N_old)
        lines += [
            f"  Theorem {'3.2' if self.modified else '3.1'} with N = {self.N}, delta = {self.delta:g}: "
            f"on 0 <= t <= h^-N = {self.time_scale:.4g}",
            f"    H_slow changes by O(h^(1-delta))       = O({self.slow_error:.3g})"
            "  (this one for any N, while H stays bounded)",
            f"    H*_omega changes by O(h^(1-delta)/kappa) = O({self.oscillatory_error:.3g})",
        ]
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)


def _fmt(values) -> str:
    return "[" + ", ".join(f"{v:.6g}" for v in values) + "]"


def _violation_table(violations, what: str, n: int, limit: int = 8) -> list[str]:
    if not violations:
        return []
    lines = [f"    violations that stop N = {n + 1} (||k||_1 <= {n + 2}), nearest first:  k, r, {what}"]
    for v in sorted(violations, key=lambda v: v.distance)[:limit]:
        lines.append(f"      k = {list(v.k)}, r = {v.r}, distance = {v.distance:.3e}")
    if len(violations) > limit:
        lines.append(f"      … {len(violations) - limit} more")
    return lines


def analyze(h: float, omega, *, method: Method | str | None = None, N_max: int = 10, delta: float = 0.25,
            tol: float = 1e-10) -> ResonanceReport:
    """The paper's assumptions and non-resonance conditions at step size h (paper §3).

    For the distinct non-zero frequencies ω_j of `omega` (for a modified method: the ω̃_j);
    `omega` may be an :class:`~trigint.OscillatoryProblem`, whose frequencies (those of its
    stiffness matrix, see ``problem.frequencies``) are used:

    - κ = min_j |sin(hω_j)| and whether κ ≥ √h (3.2); h/ε with ε = 1/min ω_j;
    - σ(hω_j) = sinc·φ/ψ, Assumption B (one sign, c₁ ≤ |σ| ≤ C₁) and symplecticity;
    - N, the largest N ≤ N_max with |h k·ω − 2πr| ≥ √h for all r ≠ 0, ‖k‖₁ ≤ N + 1
      (3.6), and the violations that stop N + 1, nearest first (N = −1 when
      already some hω_j is within √h of a non-zero multiple of 2π);
    - the same for the older condition |sin(½h k·ω)| ≥ √h for k ∉ 𝓜 (3.7),
      with an integer basis of the resonance module 𝓜 = {k : k·ω = 0} (relations counted as exact
      within the relative tolerance `tol`);
    - the time scale h^(−N) and the error sizes h^(1−δ) (H_slow) and h^(1−δ)/κ (H*_ω) of
      Theorem 3.1 (3.2 for modified methods).

    The method defaults to Deuflhard's (B), the paper's. Never steps an ODE.

    Parameters
    ----------
    h : float
        Step size.
    omega : array of float or OscillatoryProblem
        The frequencies (0 = slow), or a problem.
    method : Method or str, optional
        The method (default ``"B"``).
    N_max : int
        The largest N tested.
    delta : float
        δ of Theorem 3.1, in (0, ¼].
    tol : float
        The relative tolerance of an exact relation k·ω = 0 (see :func:`resonance_module`).

    Returns
    -------
    ResonanceReport

    Examples
    --------
    >>> import numpy as np
    >>> from trigint.resonance import analyze
    >>> r = analyze(2*np.pi/3/50, [50.0])
    >>> r.N, r.violations[0].k, r.violations[0].r
    (1, (3,), 1)
    """
    h = _check.step_size(h)
    N_max = _check_n_max(N_max)
    delta = _check.real(delta, "delta")
    if not 0 < delta <= 0.25:
        raise ValueError(f"delta: must be in (0, 1/4] as in Theorem 3.1, got {delta}")
    method = resolve_method(method if method is not None else "B")
    w = frequencies(omega)
    try:
        check_size(w.size, N_max + 1, "N_max")
    except ValueError as exc:
        raise too_many_for(omega, exc) from None
    check_h_omega(h, w)
    notes: list[str] = []
    modified = isinstance(method, ModifiedTrigonometric)
    alpha = limit = None
    if isinstance(method, AlphaMethod):
        alpha, limit = method.alpha, float(method.h_omega_limit)
        method.check_h_omega(h * w)
    effective = method.modified_h_omega(h * w) / h if modified else w
    xi = h * effective
    kappa = float(np.min(np.abs(np.sin(xi))))
    try:
        co = method.coefficients(h, w)
        sigma = co.sigma
        symplectic = co.symplectic
    except ValueError as exc:
        sigma = np.full(w.size, np.nan)
        symplectic = False
        notes.append(f"the method is undefined at this step size: {exc}")
    with np.errstate(invalid="ignore"):
        one_sign = bool(np.all(sigma > 0) or np.all(sigma < 0))
    c1, C1 = float(np.min(np.abs(sigma))), float(np.max(np.abs(sigma)))
    radius = N_max + 1
    # (3.6): N is two below the smallest norm of a violating k.
    all_new = nonresonance_violations(h, effective, radius + 1)
    first = _first_violating_norm(all_new)
    N = N_max if first is None or first > radius else first - 2
    violations = [v for v in all_new if sum(map(abs, v.k)) <= N + 2]
    if first is not None and first <= 1:
        notes.append("a single frequency is itself resonant (h*omega_j near 2 pi r): even N = 0 fails, "
                     "reported as N = -1")
    # (3.7) with the resonance module of exact relations.
    basis = resonance_module(effective, radius + 1, tol)
    old = _old_violations(h, effective, radius + 1, tol)
    first_old = _first_violating_norm(old)
    N_old = N_max if first_old is None or first_old > radius else first_old - 2
    violations_old = [v for v in old if sum(map(abs, v.k)) <= N_old + 2]
    if h >= 1:
        notes.append("the theory is asymptotic in h -> 0; for h >= 1 the error sizes are not small")
    eps = 1.0 / float(np.min(w))
    return ResonanceReport(
        h=h, omega=[float(x) for x in np.asarray(getattr(omega, "omega", omega), dtype=float).reshape(-1)],
        method=repr(method),
        modified=modified, frequencies=w.tolist(), h_omega=xi.tolist(), epsilon=eps, h_over_epsilon=h / eps,
        kappa=kappa, kappa_ok=bool(kappa >= np.sqrt(h)), sigma=[float(s) for s in sigma], assumption_B=one_sign,
        c1=c1, C1=C1, symplectic=bool(symplectic), N=int(N), N_max=N_max, violations=violations,
        N_old=int(N_old), violations_old=violations_old, module_basis=basis, time_scale=_power(h, -N),
        slow_error=float(h ** (1 - delta)), oscillatory_error=float(h ** (1 - delta) / kappa) if kappa else np.inf,
        delta=delta, alpha=alpha, h_omega_limit=limit, notes=notes,
    )


def _old_violations(h: float, omega: np.ndarray, radius: int, tol: float) -> list[Violation]:
    """|sin(½h k·ω)| < √h for k ∉ 𝓜 (k·ω ≠ 0), ‖k‖₁ ≤ radius; r is the nearest multiple."""
    ks = half_ball(omega.size, radius)
    dots = ks @ omega
    exact = np.abs(dots) <= tol * np.abs(ks).sum(axis=1) * omega.max()
    s = np.abs(np.sin(0.5 * h * dots))
    bad = np.flatnonzero(~exact & (s < np.sqrt(h)))
    out = [Violation(tuple(int(v) for v in ks[i]), int(np.rint(h * dots[i] / TWO_PI)), float(s[i])) for i in bad]
    return sorted(out, key=lambda v: (sum(map(abs, v.k)), v.distance))
