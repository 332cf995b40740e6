"""The methods: trigonometric integrators (2.2) and modified trigonometric integrators
(2.5), (2.6) of Cohen, Gauckler, Hairer, Lubich (BIT 2015), §2.2–2.3.

Methods are data: each evaluates its filter functions once per run at the values hω_i and
returns per-coordinate :class:`Coefficients`; one kernel in the core steps them all.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable

import numpy as np

from . import _check
from ._filters import FILTERS, evaluate, lookup, one, sinc
from .coefficients import Coefficients

#: |χ(hω̃)| below this counts as zero: p_n = (q_{n+1} − q_{n−1})/(2hχ) would lose every digit.
SINGULAR_CHI = 1e-10
# Beyond this hω the doubles are spaced more than 1e-4 apart: sin(hω), cos(hω) and the
# position of hω relative to the multiples of π carry no information any more.
LARGEST_H_OMEGA = 1e12


class Method(ABC):
    """A method of the form (2.5): its per-coordinate coefficients at (h, ω).

    Examples
    --------
    >>> import trigint as ti
    >>> isinstance(ti.Trigonometric("B"), ti.Method), isinstance(ti.IMEX(), ti.Method)
    (True, True)
    """

    name: str = "method"

    @abstractmethod
    def _filters(self, xi: np.ndarray, h: float) -> dict:
        """At the oscillatory values xi = hω > 0: xi_tilde, one_minus_cos, sin, chi, psi, phi."""

    def _check_step(self, xi: np.ndarray, omega: np.ndarray, h: float) -> None:  # noqa: B027
        """Method-specific step-size restrictions (raises ValueError); none by default."""

    def _at_chi_zero(self, xi_tilde: np.ndarray) -> dict | None:
        """Where χ(hω̃) = 0: ψ/χ, sin²(hω̃)/(hχ)·h and σ in forms without the division by χ
        (NaN where undefined), or None if the method does not know them."""
        return None

    def coefficients(self, h: float, omega, form: str = "two-step") -> Coefficients:
        """The per-coordinate coefficients at step size h for frequencies omega.

        Parameters
        ----------
        h : float
            Step size, > 0.
        omega : array of float, shape (n,)
            Frequencies ω_i ≥ 0 (0: slow).
        form : {"two-step", "one-step"}
            The form the coefficients are for (they differ only where χ(hω̃) = 0).

        Returns
        -------
        Coefficients

        Raises
        ------
        ValueError
            Where the method is undefined: in the two-step form wherever χ(hω̃_j) = 0 (for the
            trigonometric methods hω_j a non-zero multiple of π: the momentum divides by χ); in
            the one-step form only where ψ/χ has no finite limit there (for methods B and C it
            is φ, for E sinc; A and D need an even multiple of π); or a step-size restriction.
        """
        h = _check.step_size(h)
        omega = np.asarray(omega, dtype=float).reshape(-1)
        if omega.size == 0 or not np.all(np.isfinite(omega)) or np.any(omega < 0):
            raise ValueError("omega: need n >= 1 finite frequencies >= 0")
        return self._pointwise(np.full(omega.size, h), omega, h, form=form)

    def pointwise(self, h, omega, form: str = "two-step") -> Coefficients:
        """The coefficients at pairs (h_i, ω_i), elementwise: one coordinate of one step size each.

        Ensembles evaluate every trajectory's step size in one call this way; the numbers equal
        those of :meth:`coefficients` for each step size, bit for bit.

        Parameters
        ----------
        h : array of shape (n,)
            Step sizes, > 0.
        omega : array of shape (n,)
            Frequencies, >= 0.
        form : {"two-step", "one-step"}
            As in :meth:`coefficients`.

        Returns
        -------
        Coefficients

        Examples
        --------
        >>> import numpy as np, trigint as ti
        >>> co = ti.Trigonometric("B").pointwise(np.array([0.01, 0.02]), np.array([50.0, 50.0]))
        >>> bool(co.chi[1] == ti.Trigonometric("B").coefficients(0.02, [50.0]).chi[0])
        True
        """
        h = np.asarray(h, dtype=float).reshape(-1)
        omega = np.asarray(omega, dtype=float).reshape(-1)
        if h.shape != omega.shape or h.size == 0 or not np.all((h > 0) & np.isfinite(h)):
            raise ValueError("h, omega: need arrays of the same length >= 1, h finite and > 0")
        if not np.all(np.isfinite(omega)) or np.any(omega < 0):
            raise ValueError("omega: need finite frequencies >= 0")
        return self._pointwise(h, omega, form=form)

    def _pointwise(self, h: np.ndarray, omega: np.ndarray, h_report=None, form: str = "two-step") -> Coefficients:
        """The coefficients at the pairs (h_i, ω_i), elementwise: one coordinate of one step
        size each. Ensembles evaluate every trajectory's step size in one call this way."""
        xi = h * omega
        if np.any(~(xi <= LARGEST_H_OMEGA)):
            j = int(np.flatnonzero(~(xi <= LARGEST_H_OMEGA))[0])
            raise ValueError(
                f"h: h*omega[{j}] = {xi[j]:.6g} is too large: above {LARGEST_H_OMEGA:g} the doubles near "
                "h*omega are spaced more than 1e-4 apart, so sin(h*omega) and cos(h*omega), on which every "
                "method depends, are rounding noise. Take a smaller step size or a smaller frequency."
            )
        self._check_step(xi, omega, h_report if h_report is not None else h)
        n = omega.size
        c = {k: np.ones(n) for k in ("chi", "psi", "phi")}
        c.update({k: np.zeros(n) for k in ("xi_tilde", "one_minus_cos", "sin")})
        fast = omega > 0
        if np.any(fast):
            # Evaluate once per distinct hω, then scatter to the coordinates.
            distinct, inverse = np.unique(xi[fast], return_inverse=True)
            values = self._filters(distinct, h_report if h_report is not None else h)
            for key in ("xi_tilde", "one_minus_cos", "sin", "chi", "psi", "phi"):
                c[key][fast] = np.asarray(values[key], dtype=float)[inverse]
        singular = fast & (np.abs(c["chi"]) <= SINGULAR_CHI)
        at_zero = self._limits_where_chi_vanishes(c, xi, omega, singular, form) if np.any(singular) else None
        sinc_t = sinc(c["xi_tilde"])
        with np.errstate(divide="ignore", invalid="ignore"):
            sigma = np.where(fast, sinc_t * c["phi"] / c["psi"], 0.0)
            chi_over_sinc = np.where(fast, c["chi"] / sinc_t, 0.0)
            psi_over_chi = np.where(fast, c["psi"] / c["chi"], 1.0)
            sin2_over_h_chi = np.where(fast, c["sin"] ** 2 / (h * c["chi"]), 0.0)
        undefined_sigma = np.zeros(n, dtype=bool)
        if at_zero is not None:
            # one-step form at hω̃ = kπ: the limits (for the trigonometric methods χ = sinc)
            psi_over_chi[singular] = at_zero["psi_over_chi"]
            sin2_over_h_chi[singular] = at_zero["h_sin2_over_h_chi"] / h[singular]
            sigma[singular] = at_zero["sigma"]
            chi_over_sinc[singular] = 1.0
            undefined_sigma[singular] = ~np.isfinite(at_zero["sigma"])
        defined = ~undefined_sigma
        if not np.all(np.isfinite(sigma[defined])) or not np.all(np.isfinite(chi_over_sinc)):
            j = int(np.flatnonzero(~(np.isfinite(sigma) | undefined_sigma) | ~np.isfinite(chi_over_sinc))[0])
            raise ValueError(
                f"h: at coordinate {j} (h*omega = {xi[j]:.12g}) psi or sinc(h*omega_tilde) vanishes, "
                "so sigma and the modified oscillatory energy are undefined; choose another h"
            )
        # ω̃ = ω exactly where the method does not modify the frequency ((hω)/h is not ω in
        # floating point, and "H*_ω = H_ω" should be recognized as such)
        omega_tilde = np.where(c["xi_tilde"] == xi, omega, c["xi_tilde"] / h)
        return Coefficients(
            h=h_report if h_report is not None else h, omega=omega, xi=xi, sigma=sigma,
            cos=1.0 - c["one_minus_cos"], modified_p=sigma * chi_over_sinc**2,
            modified_q=sigma * omega_tilde**2, psi_over_chi=psi_over_chi, sin2_over_h_chi=sin2_over_h_chi, **c,
        )

    def _limits_where_chi_vanishes(self, c: dict, xi, omega, singular, form: str) -> dict:
        """The one-step form's numbers where χ(hω̃) = 0 (at hω̃ = kπ), or the error that says
        which quantity is undefined there (the two-step momentum always is)."""
        if form != "one-step" or np.any(np.abs(c["sin"][singular]) > 1e-6):
            self._check_chi(c["chi"], xi, omega, form)
        at_zero = self._at_chi_zero(c["xi_tilde"][singular])
        ratio = None if at_zero is None else at_zero["psi_over_chi"]
        if ratio is None or not np.all(np.isfinite(ratio)):
            where = np.flatnonzero(singular)
            j = int(where[0] if ratio is None else where[~np.isfinite(ratio)][0])
            raise ValueError(
                f"h: h*omega[{j}] = {xi[j]:.15g} is {xi[j] / np.pi:.6g}*pi, where chi(h*omega_tilde) vanishes; "
                f"the one-step form of method {self.name!r} needs psi/chi there, which is undefined "
                f"(psi = {c['psi'][j]:.3g} does not vanish with chi){'' if ratio is not None else ' or unknown'}. "
                f"Choose h with h*omega[{j}] away from multiples of pi."
            )
        return at_zero

    def _check_chi(self, chi: np.ndarray, xi: np.ndarray, omega: np.ndarray, form: str = "two-step") -> None:
        bad = np.flatnonzero(np.abs(chi) <= SINGULAR_CHI)
        if bad.size:
            j = int(bad[0])
            r = xi[j] / np.pi
            if abs(np.sin(xi[j])) > 1e-6:
                # not near a multiple of π: sinc(hω) = sin(hω)/hω is small because hω is large
                cause = (f"h*omega[{j}] = {xi[j]:.6g} is so large that chi(h*omega_tilde) = {chi[j]:.3g} "
                         f"(for trigonometric methods sinc(h*omega), at most 1/(h*omega)) is below {SINGULAR_CHI:g}")
                advice = f"Take h*omega[{j}] below about {1 / SINGULAR_CHI:g}"
            else:
                cause = (f"h*omega[{j}] = {xi[j]:.15g} is {r:.6g}*pi; chi(h*omega_tilde) = {chi[j]:.3g} "
                         "vanishes there (for trigonometric methods: sinc(h*omega) = 0 at non-zero multiples of pi)")
                advice = f"Choose h with h*omega[{j}] away from multiples of pi"
                if form != "one-step" and self._at_chi_zero(np.array([xi[j]])) is not None:
                    advice += (" (or use form='one-step' in integrate(), ensemble() or scan() without lyapunov=, "
                               "which needs no division by chi)")
            raise ValueError(
                f"h: {cause}, so the momentum p_n = (q_(n+1) - q_(n-1)) / (2 h chi) is undefined. {advice}."
            )

    def is_symplectic(self, h: float, omega) -> bool:
        """Whether the method is symplectic at step size h for these frequencies: ψ = χφ at
        every hω̃_j (paper (2.4)).

        Parameters
        ----------
        h : float
            Step size.
        omega : array of float
            Frequencies.
        """
        return self.coefficients(h, omega).symplectic

    def sigma(self, h: float, omega) -> np.ndarray:
        """σ(hω̃_i) = sinc(hω̃_i) φ/ψ per coordinate (paper (3.3)); 0 on slow coordinates.

        Parameters
        ----------
        h : float
            Step size.
        omega : array of float
            Frequencies.
        """
        return self.coefficients(h, omega).sigma

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


class Trigonometric(Method):
    """Trigonometric integrator (2.2) with filter functions ψ, φ.

        q_{n+1} − 2cos(hΩ) q_n + q_{n−1} = h² Ψ g(Φ q_n),   2h sinc(hΩ) p_n = q_{n+1} − q_{n−1},
        q_1 = cos(hΩ) q_0 + h sinc(hΩ) p_0 + ½h² Ψ g(Φ q_0)                         (2.3)

    with Ψ = ψ(hΩ), Φ = φ(hΩ). Second order, symmetric (time-reversible); symplectic iff
    ψ(hω_j) = sinc(hω_j) φ(hω_j) for all j (paper (2.4)). Cohen, Gauckler, Hairer,
    Lubich, BIT 55 (2015) §2.2; Hairer, Lubich, Wanner, *Geometric Numerical Integration*,
    §XIII.2.

    Named filters [GNI §XIII.2.2]: ``"A"``/``"gautschi"`` (ψ = sinc²(ξ/2), φ = 1),
    ``"B"``/``"deuflhard"`` (ψ = sinc ξ, φ = 1; symplectic), ``"C"``/``"gss"``
    (ψ = sinc²ξ, φ = sinc ξ; symplectic), ``"D"``/``"hochbruck-lubich"``
    (ψ = sinc²(ξ/2), φ = sinc ξ (1 + ⅓sin²(ξ/2))), ``"E"``/``"hairer-lubich"`` (ψ = sinc²ξ, φ = 1).

    Parameters
    ----------
    filter : str, optional
        A name above. Give either a name or `psi` and `phi`.
    psi, phi : callable, optional
        Even functions of ξ = hω with ψ(0) = φ(0) = 1, evaluated once per run at the hω_j.
    name : str, optional
        The name shown in reports and plots (default: the filter's letter, or ``"custom"``).

    Examples
    --------
    >>> import trigint as ti
    >>> ti.Trigonometric("deuflhard").is_symplectic(0.01, [0.0, 50.0])
    True
    >>> ti.Trigonometric("A").is_symplectic(0.03, [0.0, 50.0])
    False
    """

    def __init__(self, filter: str | None = None, *, psi: Callable | None = None,
                 phi: Callable | None = None, name: str | None = None):
        if filter is not None and (psi is not None or phi is not None):
            raise ValueError("filter: give a filter name or psi/phi callables, not both")
        if filter is not None:
            f = lookup(filter)
            self._filter = f
            self.psi, self.phi = f.psi, f.phi
            self.name = name or f.key
            self.reference = f.reference
        else:
            if psi is None and phi is None:
                raise ValueError(f"filter: give a name ({', '.join(FILTERS)}) or psi= and phi=")
            for arg, fn in (("psi", psi), ("phi", phi)):
                if fn is not None and not callable(fn):
                    raise TypeError(f"{arg}: expected a callable of xi = h*omega, got {type(fn).__name__}")
            self.psi, self.phi = psi or one, phi or one
            self._filter = None
            for arg, fn in (("psi", self.psi), ("phi", self.phi)):
                at0 = float(evaluate(fn, np.zeros(1), arg)[0])
                if abs(at0 - 1.0) > 1e-12:
                    raise ValueError(f"{arg}: filter functions must satisfy {arg}(0) = 1, got {at0!r}")
            self.name = name or "custom"
            self.reference = "user filters"

    @property
    def named_filter(self) -> str | None:
        """The letter A–E of a named filter pair (None for user filters): the Krylov path has
        these in closed form in the core."""
        return None if self._filter is None else self._filter.key

    def _filters(self, xi: np.ndarray, h: float) -> dict:
        return dict(xi_tilde=xi, one_minus_cos=2 * np.sin(xi / 2) ** 2, sin=np.sin(xi), chi=sinc(xi),
                    psi=evaluate(self.psi, xi, "psi"), phi=evaluate(self.phi, xi, "phi"))

    def _at_chi_zero(self, xi_tilde: np.ndarray) -> dict | None:
        # χ = sinc: sin²(ξ)/(h sinc ξ) = ξ sin(ξ)/h; ψ/χ and σ from the filter's closed forms
        if self._filter is None:
            return None
        x = np.asarray(xi_tilde, dtype=float)
        return dict(psi_over_chi=np.asarray(self._filter.psi_over_sinc(x), dtype=float) * np.ones_like(x),
                    h_sin2_over_h_chi=x * np.sin(x),
                    sigma=np.asarray(self._filter.sigma(x), dtype=float) * np.ones_like(x))


class ModifiedTrigonometric(Method):
    """Modified trigonometric integrator (2.5) with modified frequencies ω̃.

        q_{n+1} − 2cos(hΩ̃) q_n + q_{n−1} = h² Ψ̃ g(Φ̃ q_n),   2h χ̃ p_n = q_{n+1} − q_{n−1},
        q_1 = cos(hΩ̃) q_0 + h χ̃ p_0 + ½h² Ψ̃ g(Φ̃ q_0),

    Ψ̃ = ψ(hΩ̃), Φ̃ = φ(hΩ̃), χ̃ = χ(hΩ̃), ω̃_0 = 0. Symplectic iff ψ = χφ at every hω̃_j.
    Paper §2.3 (2.5); McLachlan–Stern's choice χ̃ = Ω⁻¹Ω̃ sinc(hΩ̃) is ``chi="mclachlan-stern"``.

    Parameters
    ----------
    omega_tilde : callable
        ξ = hω ↦ ξ̃ = hω̃ (increasing, with 0 ↦ 0).
    psi, phi : callable, optional
        Functions of ξ̃; default ψ = sinc, φ = 1.
    chi : callable or "mclachlan-stern", optional
        χ(ξ̃); default sinc.
    omega_tilde_inverse : callable, optional
        ξ̃ ↦ ξ; found by bisection if omitted.
    name : str
        The name shown in reports and plots.

    Examples
    --------
    >>> import numpy as np, trigint as ti
    >>> m = ti.ModifiedTrigonometric(lambda x: 2 * np.arctan(x / 2), chi="mclachlan-stern")
    >>> float(m.modified_h_omega(2.0))  # doctest: +ELLIPSIS
    1.5707963267948...
    """

    def __init__(self, omega_tilde: Callable, *, psi: Callable | None = None, phi: Callable | None = None,
                 chi: Callable | str | None = None, omega_tilde_inverse: Callable | None = None,
                 name: str = "modified"):
        if not callable(omega_tilde):
            raise TypeError("omega_tilde: expected a callable xi = h*omega -> h*omega_tilde")
        for arg, fn in (("psi", psi), ("phi", phi), ("omega_tilde_inverse", omega_tilde_inverse)):
            if fn is not None and not callable(fn):
                raise TypeError(f"{arg}: expected a callable of h*omega_tilde, got {type(fn).__name__}")
        if not isinstance(name, str):
            raise TypeError(f"name: expected a string, got {type(name).__name__}")
        self._omega_tilde = omega_tilde
        self._inverse = omega_tilde_inverse
        self.psi = psi if psi is not None else sinc
        self.phi = phi if phi is not None else one
        if isinstance(chi, str):
            if chi.lower().replace("_", "-") not in ("mclachlan-stern", "mclachlan", "ms"):
                raise ValueError(f"chi: unknown name {chi!r}; the named choice is 'mclachlan-stern'")
            chi = "mclachlan-stern"
        elif chi is not None and not callable(chi):
            raise TypeError("chi: expected a callable of h*omega_tilde or 'mclachlan-stern'")
        self.chi = chi or sinc
        self.name = name
        self._check_frequency_map()

    def _check_frequency_map(self) -> None:
        """hω ↦ hω̃ must map 0 to 0 and increase (paper §2.3); checked on [0, 1]."""
        xi = np.linspace(0.0, 1.0, 65)
        try:
            xt = self.modified_h_omega(xi)
        except (TypeError, ValueError, ArithmeticError) as exc:
            raise ValueError(f"omega_tilde: could not be evaluated on [0, 1]: {exc}") from None
        if abs(xt[0]) > 1e-12:
            raise ValueError(f"omega_tilde: must map 0 to 0, got omega_tilde(0) = {xt[0]:.6g}")
        steps = np.diff(xt)
        if not np.all(steps > 0):
            j = int(np.flatnonzero(~(steps > 0))[0])
            raise ValueError(
                "omega_tilde: must be increasing (h*omega -> h*omega_tilde, paper §2.3); it is not between "
                f"{xi[j]:.4g} and {xi[j + 1]:.4g} ({xt[j]:.6g} -> {xt[j + 1]:.6g})"
            )

    def modified_h_omega(self, xi):
        """hω ↦ hω̃, vectorized.

        Parameters
        ----------
        xi : float or array
            Values of hω ≥ 0.
        """
        x = np.asarray(xi, dtype=float)
        return evaluate(self._omega_tilde, x.reshape(-1), "omega_tilde").reshape(x.shape)

    def h_omega_from_modified(self, xi_tilde):
        """The inverse map hω̃ ↦ hω, vectorized.

        Parameters
        ----------
        xi_tilde : float or array
            Values of hω̃ ≥ 0 in the range of :meth:`modified_h_omega`: for the α-methods
            [0, π) (IMEX, α = ¼), [0, π] for α < ¼, [0, 2 arcsin(1/(2√α))) for α > ¼.
        """
        y = np.asarray(xi_tilde, dtype=float)
        if self._inverse is not None:
            return evaluate(self._inverse, y.reshape(-1), "omega_tilde_inverse", at="xi_tilde").reshape(y.shape)
        return _invert_increasing(self.modified_h_omega, y)

    def _filters(self, xi: np.ndarray, h: float) -> dict:
        xt = self.modified_h_omega(xi)
        if self.chi == "mclachlan-stern":
            chi = np.sin(xt) / xi  # χ̃ = Ω⁻¹Ω̃ sinc(hΩ̃) = sin(hω̃)/(hω)
        else:
            chi = evaluate(self.chi, xt, "chi")
        return dict(xi_tilde=xt, one_minus_cos=2 * np.sin(xt / 2) ** 2, sin=np.sin(xt), chi=chi,
                    psi=evaluate(self.psi, xt, "psi"), phi=evaluate(self.phi, xt, "phi"))


class AlphaMethod(ModifiedTrigonometric):
    """The symplectic α-family (2.6) of modified trigonometric methods.

        q_{n+1} − 2q_n + q_{n−1} + h²Ω² q_n + α h²Ω² (q_{n+1} − 2q_n + q_{n−1}) = h² g(q_n),
        2h p_n = (I + α h²Ω²)(q_{n+1} − q_{n−1}).

    It is (2.5) with sin(½hω̃) = ½hω/√(1 + αh²ω²), hω̃ ∈ [0, π], φ = 1 and
    ψ = χ = 1 − 4α sin²(½hω̃) = 1/(1 + αh²ω²). Second order, symmetric, symplectic.
    For α < ¼ it needs hω < 2/√(1 − 4α). α = 0 is Störmer–Verlet, α = ¼ the IMEX method
    of Zhang–Skeel and Stern–Grinspun. Paper §2.3 and Theorem 3.2.

    Parameters
    ----------
    alpha : float
        α ≥ 0.
    name : str, optional
        The name shown in reports and plots (default ``"alpha=<α>"``).

    Examples
    --------
    >>> import numpy as np, trigint as ti
    >>> round(float(ti.IMEX().modified_h_omega(np.sqrt(12)) / (2 * np.pi / 3)), 12)
    1.0
    """

    def __init__(self, alpha: float, name: str | None = None):
        alpha = _check.real(alpha, "alpha")
        self.alpha = alpha
        super().__init__(self._xi_tilde, psi=None, phi=None, chi=None,
                         omega_tilde_inverse=self._xi_from_tilde, name=name or f"alpha={alpha:g}")

    def _check_frequency_map(self) -> None:
        """2 arcsin(½ξ/√(1 + αξ²)) maps 0 to 0 and increases wherever it is defined."""

    @property
    def h_omega_limit(self) -> float:
        """The bound hω < 2/√(1 − 4α) for α < ¼ (inf for α ≥ ¼)."""
        return float(2.0 / np.sqrt(1.0 - 4.0 * self.alpha)) if self.alpha < 0.25 else float("inf")

    def _xi_tilde(self, xi):
        s = 0.5 * xi / np.sqrt(1.0 + self.alpha * xi**2)
        if np.any(s > 1.0):
            raise ValueError(self._limit_message(np.max(xi)))
        return 2.0 * np.arcsin(s)

    def _xi_from_tilde(self, xt):
        xt = np.asarray(xt, dtype=float)
        # the range of ξ ↦ ξ̃: [0, π] for α < ¼ (π at the step-size limit), [0, π) for α = ¼ (π as
        # ξ → ∞), [0, 2 arcsin(1/(2√α))) for α > ¼
        closed = self.alpha < 0.25
        top = np.pi if self.alpha <= 0.25 else 2.0 * float(np.arcsin(0.5 / np.sqrt(self.alpha)))
        inside = (xt >= 0) & ((xt <= top) if closed else (xt < top))
        if not np.all(inside):
            got = float(xt.reshape(-1)[np.flatnonzero(~inside.reshape(-1))[0]])
            bound = ("pi]" if closed else "pi)" if self.alpha == 0.25 else
                     f"2 arcsin(1/(2 sqrt(alpha))) = {top:.12g})")
            where = (f"reaches pi at the step-size limit h*omega = {self.h_omega_limit:.12g}" if closed else
                     "reaches pi only as h*omega -> inf" if self.alpha == 0.25 else
                     "approaches the bound as h*omega -> inf")
            who = ("the IMEX method (alpha = 1/4)" if self.alpha == 0.25 else
                   f"the alpha-method with alpha = {self.alpha:g}")
            raise ValueError(f"xi_tilde: h*omega_tilde must be in [0, {bound} for {who}, which {where}; got {got!r}")
        s = np.sin(0.5 * xt)
        with np.errstate(divide="ignore", invalid="ignore"):  # rounding at the bound: evaluate() says so
            return 2.0 * s / np.sqrt(1.0 - 4.0 * self.alpha * s**2)

    def _limit_message(self, xi_max: float) -> str:
        return (
            f"h: the alpha-method with alpha = {self.alpha:g} needs h*omega < 2/sqrt(1 - 4 alpha) = "
            f"{self.h_omega_limit:.12g} for every frequency, got h*omega = {xi_max:.12g}"
        )

    def _check_step(self, xi, omega, h):
        self.check_h_omega(xi)

    def check_h_omega(self, h_omega) -> None:
        """Refuses products hω at or beyond the method's limit hω < 2/√(1 − 4α) (α < ¼).

        Parameters
        ----------
        h_omega : array_like
            The products hω_j.

        Raises
        ------
        ValueError
            Naming the limit and the largest hω.
        """
        xi = np.asarray(h_omega, dtype=float)
        if self.alpha < 0.25 and np.any(xi >= self.h_omega_limit):
            raise ValueError(self._limit_message(float(np.max(xi))))

    def _filters(self, xi: np.ndarray, h: float) -> dict:
        d = 1.0 + self.alpha * xi**2
        half = 0.5 * xi / np.sqrt(d)  # sin(½hω̃)
        cos_half = np.sqrt(np.maximum(0.0, 1.0 - half**2))
        # 1 − cos(hω̃) = ½h²ω²/(1 + αh²ω²), from (2.6) directly.
        return dict(xi_tilde=2.0 * np.arcsin(half), one_minus_cos=0.5 * xi**2 / d,
                    sin=2.0 * half * cos_half, chi=1.0 / d, psi=1.0 / d, phi=np.ones_like(xi))

    def __repr__(self) -> str:
        return f"{type(self).__name__}(alpha={self.alpha!r})"


class StormerVerlet(AlphaMethod):
    """Störmer–Verlet, the α-method with α = 0: sin(½hω̃) = ½hω, stable for hω < 2.

    Examples
    --------
    >>> import trigint as ti
    >>> ti.StormerVerlet().h_omega_limit
    2.0
    """

    def __init__(self):
        super().__init__(0.0, name="stormer-verlet")

    def __repr__(self) -> str:
        return "StormerVerlet()"


class IMEX(AlphaMethod):
    """The IMEX method of Zhang–Skeel and Stern–Grinspun, the α-method with α = ¼:
    tan(½hω̃) = ½hω, no step-size restriction; H*_ω̃ = Σ_j (ω̃_j/ω_j) I_j (paper §3.2).

    One-step form: p⁺ = p_n + ½h g(q_n); (I + ¼h²Ω²) q_{n+1} = (I − ¼h²Ω²) q_n + h p⁺;
    p_{n+1} = p⁺ − ½hΩ²(q_n + q_{n+1}) + ½h g(q_{n+1}).

    Examples
    --------
    >>> import trigint as ti
    >>> round(float(ti.IMEX().modified_h_omega(2.0)), 12)  # π/2
    1.570796326795
    """

    def __init__(self):
        super().__init__(0.25, name="imex")

    def __repr__(self) -> str:
        return "IMEX()"


def _invert_increasing(f: Callable, y: np.ndarray) -> np.ndarray:
    """Solves f(x) = y for x ≥ 0 by bisection, f increasing with f(0) = 0."""
    flat = y.reshape(-1)
    lo = np.zeros_like(flat)
    hi = np.maximum(flat, 1.0)
    for _ in range(200):  # bracket
        grow = f(hi) < flat
        if not np.any(grow):
            break
        hi = np.where(grow, 2 * hi, hi)
    else:
        raise ValueError("xi_tilde: outside the range of omega_tilde")
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        below = f(mid) < flat
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        if np.all(hi - lo <= 4 * np.finfo(float).eps * np.maximum(hi, 1e-300)):
            break
    return (0.5 * (lo + hi)).reshape(y.shape)
