"""Potentials U(q): native FPU and sparse polynomials (evaluated in Rust), and Python callables.

The stepping kernel is generic over the potential. Native potentials run at full speed;
:class:`PythonPotential` calls back into Python at every step and is the slow path for
prototyping.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence

import numpy as np

from . import _core


class Potential(ABC):
    """Base class: a potential U with its gradient, evaluated row by row on arrays."""

    #: number of coordinates, or None when any number fits (Python callables)
    dim: int | None = None

    @abstractmethod
    def _spec(self, n: int) -> tuple:
        """The description handed to the core for a state of n coordinates."""

    def check_dim(self, n: int) -> None:
        if self.dim is not None and self.dim != n:
            raise ValueError(
                f"potential: {type(self).__name__} acts on {self.dim} coordinates, "
                f"but the problem has {n}"
            )

    def value(self, q) -> np.ndarray | float:
        """U(q) for q of shape (n,) (returns a float) or (m, n) (returns shape (m,))."""
        q2 = _rows(q)
        self.check_dim(q2.shape[1])
        values = _core.potential_value(self._spec(q2.shape[1]), q2)
        return float(values[0]) if np.ndim(q) == 1 else values

    def gradient(self, q) -> np.ndarray:
        """∇U(q) for q of shape (n,) or (m, n), same shape as q."""
        q2 = _rows(q)
        self.check_dim(q2.shape[1])
        grad = -_core.potential_force(self._spec(q2.shape[1]), q2)
        return grad[0] if np.ndim(q) == 1 else grad


def _rows(q) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    if q.ndim not in (1, 2) or q.shape[-1] == 0:
        raise ValueError(f"q: expected shape (n,) or (m, n) with n >= 1, got {q.shape}")
    return np.ascontiguousarray(q.reshape(-1, q.shape[-1]))


class FPUPotential(Potential):
    """The soft nonlinear springs of the Fermi–Pasta–Ulam chain [GNI §I.5], native in Rust.

    In the variables x = (x₀,₁ … x₀,ₘ, x₁,₁ … x₁,ₘ) (slow block first, stiff block second),

        U(x) = ¼[(x₀,₁ − x₁,₁)⁴ + Σᵢ₌₁^{m−1}(x₀,ᵢ₊₁ − x₁,ᵢ₊₁ − x₀,ᵢ − x₁,ᵢ)⁴ + (x₀,ₘ + x₁,ₘ)⁴].

    Examples
    --------
    >>> import trigint as ti
    >>> round(ti.FPUPotential(3).value([1, 0, 0, 0.02, 0, 0]), 8)
    0.50120008
    """

    def __init__(self, m: int = 3):
        if isinstance(m, bool) or not isinstance(m, int | np.integer) or m < 1:
            raise ValueError(f"m: the number of stiff springs must be an integer >= 1, got {m!r}")
        self.m = int(m)
        self.dim = 2 * self.m

    def _spec(self, n: int) -> tuple:
        return ("fpu", self.m)

    def __repr__(self) -> str:
        return f"FPUPotential(m={self.m})"


class PolynomialPotential(Potential):
    """A sparse polynomial U(q) = Σₜ cₜ Πᵢ qᵢ^{eₜᵢ}, value and gradient evaluated in Rust.

    Parameters
    ----------
    coefficients : sequence of float, length T
    exponents : array of non-negative int, shape (T, n)
        Row t holds the exponents of term t in each of the n coordinates.

    Examples
    --------
    U(q) = q³ + q⁴ (Experiment 1 of the paper):

    >>> import trigint as ti
    >>> U = ti.PolynomialPotential([1.0, 1.0], [[3], [4]])
    >>> U.value([2.0])
    24.0
    """

    def __init__(self, coefficients: Sequence[float], exponents):
        c = np.asarray(coefficients, dtype=float).reshape(-1)
        e = np.asarray(exponents)
        if e.ndim != 2 or e.shape[0] != c.size or e.shape[1] == 0:
            raise ValueError(
                f"exponents: expected shape (number of terms, n) = ({c.size}, n) with n >= 1, "
                f"got {e.shape}"
            )
        if not np.all(np.isfinite(c)):
            raise ValueError("coefficients: must be finite")
        if e.dtype.kind not in "iu" and not np.all(np.equal(np.mod(e, 1), 0)):
            raise ValueError("exponents: must be non-negative integers")
        e = e.astype(np.int64)
        if np.any(e < 0):
            raise ValueError("exponents: must be non-negative integers")
        self.coefficients = c
        self.exponents = e
        self.dim = int(e.shape[1])

    @classmethod
    def from_sympy(cls, expr, symbols) -> PolynomialPotential:
        """Builds the potential from a SymPy polynomial; coordinates in the order of `symbols`.

        >>> import sympy as sp, trigint as ti
        >>> q0, q1, q2 = sp.symbols("q0 q1 q2")
        >>> ti.PolynomialPotential.from_sympy(sp.Rational(1, 100) * q1 * q2, [q0, q1, q2]).dim
        3
        """
        import sympy

        symbols = list(symbols)
        if not symbols:
            raise ValueError("symbols: give at least one coordinate symbol")
        try:
            poly = sympy.Poly(sympy.sympify(expr), *symbols)
        except sympy.PolynomialError as exc:
            raise ValueError(f"expr: not a polynomial in {symbols}: {exc}") from None
        terms = poly.terms()
        free = sympy.sympify(expr).free_symbols - set(symbols)
        if free:
            raise ValueError(f"expr: has symbols {sorted(map(str, free))} that are not coordinates")
        if not terms:
            return cls(np.zeros(0), np.zeros((0, len(symbols)), dtype=np.int64))
        exponents = [list(monom) for monom, _ in terms]
        coefficients = [float(coeff) for _, coeff in terms]
        return cls(coefficients, exponents)

    def _spec(self, n: int) -> tuple:
        return ("polynomial", self.dim, self.coefficients.tolist(), self.exponents.ravel().tolist())

    def __repr__(self) -> str:
        return f"PolynomialPotential({self.coefficients.size} terms, dim={self.dim})"


class PythonPotential(Potential):
    """U and ∇U as Python callables of a 1-d array: the slow path, for prototyping.

    Each step calls back into Python (microseconds instead of nanoseconds per step).

    Examples
    --------
    >>> import numpy as np, trigint as ti
    >>> U = ti.PythonPotential(lambda q: float(np.sum(q**4)) / 4, lambda q: q**3)
    >>> U.gradient([2.0])
    array([8.])
    """

    def __init__(
        self,
        value: Callable[[np.ndarray], float],
        gradient: Callable[[np.ndarray], np.ndarray],
        dim: int | None = None,
    ):
        if not callable(value) or not callable(gradient):
            raise TypeError("value and gradient must be callables taking a 1-d array q")
        self._value, self._gradient = value, gradient
        self.dim = dim

    def _spec(self, n: int) -> tuple:
        def gradient(q):
            return np.ascontiguousarray(self._gradient(q), dtype=float)

        return ("python", n, lambda q: float(self._value(q)), gradient)

    def __repr__(self) -> str:
        return f"PythonPotential({getattr(self._value, '__name__', 'value')})"
