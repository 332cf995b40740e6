"""Potentials U(q): compiled (evaluated in Rust at native speed) or Python callables.

- :class:`FPUPotential`: the Fermi–Pasta–Ulam chain, written out in Rust (the reference);
- :class:`ExpressionPotential`: any expression in SymPy (or a string), compiled once into a
  native program for U and its exact gradient (reverse-mode differentiation of the program);
- :class:`ChainPotential`: U(q) = Σ_b V_b((Lq)_b), univariate functions of sparse linear forms,
  the structured form of long chains (springs, FPU, Toda, Morse, on-site potentials);
- :class:`PolynomialPotential`: sparse polynomials (a compiled program too);
- :class:`PythonPotential`: Python callables, per trajectory or vectorized over a block.

Every potential hands the core a typed description (``_spec``); one dispatch in the binding
runs them all, and every kind gives the same bits in ``integrate()`` and in each lane of an
ensemble.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from . import _check, _native, _tape
from ._fpu_forms import fpu_linear_forms, fpu_original_basis, fpu_tape  # noqa: F401  (re-exported)


class Potential(ABC):
    """Base class: a potential U with its gradient, evaluated row by row on arrays.

    Subclasses describe U to the core; users build one of :class:`FPUPotential`,
    :class:`ExpressionPotential`, :class:`ChainPotential`, :class:`PolynomialPotential` or
    :class:`PythonPotential`.

    Attributes
    ----------
    dim : int or None
        The number of coordinates U acts on; None when any number fits (Python callables).

    Examples
    --------
    >>> import trigint as ti
    >>> U = ti.FPUPotential(1)
    >>> round(U.value([0.1, 0.2]), 8), U.gradient([0.1, 0.2]).round(8).tolist()
    (0.00205, [0.026, 0.028])
    """

    #: number of coordinates, or None when any number fits (Python callables)
    dim: int | None = None

    @abstractmethod
    def describe(self, n: int) -> dict:
        """The description the core builds the potential from (``{"kind": …}``), for a state of
        n coordinates in their own order; plain data (and, for Python potentials, the callables).

        Parameters
        ----------
        n : int
            The number of coordinates.
        """

    def own_coordinates(self) -> tuple[np.ndarray, dict] | None:
        """(T, description): an orthogonal T (q = T x) in whose coordinates x this potential is
        native, with its description in x; None for most potentials. When T diagonalizes a
        problem's stiffness matrix it is taken as the modal basis, and the kernel evaluates the
        potential in x with no map at all."""
        return None

    def check_dim(self, n: int) -> None:
        """Raises ValueError unless U acts on n coordinates.

        Parameters
        ----------
        n : int
            The problem's number of coordinates.
        """
        if self.dim is not None and self.dim != n:
            raise ValueError(
                f"potential: {type(self).__name__} acts on {self.dim} coordinates, "
                f"but the problem (omega or stiffness, q) has {n}"
            )

    def _evaluate(self, q) -> tuple[np.ndarray, np.ndarray, bool]:
        q2 = _rows(q)
        self.check_dim(q2.shape[1])
        values, forces = _native.evaluate(self, q2)
        return values, forces, np.ndim(q) == 1

    def value(self, q) -> np.ndarray | float:
        """U(q) for q of shape (n,) (returns a float) or (m, n) (returns shape (m,)).

        Parameters
        ----------
        q : array of float, shape (n,) or (m, n)
            One state, or m states as rows.
        """
        values, _, one = self._evaluate(q)
        return float(values[0]) if one else values

    def gradient(self, q) -> np.ndarray:
        """∇U(q) for q of shape (n,) or (m, n), same shape as q.

        Parameters
        ----------
        q : array of float, shape (n,) or (m, n)
            One state, or m states as rows.
        """
        _, forces, one = self._evaluate(q)
        return -forces[0] if one else -forces


def _rows(q) -> np.ndarray:
    try:
        q = np.asarray(q, dtype=float)
    except OverflowError:
        raise ValueError("q: a value is too large for a double (at most about 1.8e308 in magnitude)") from None
    except (TypeError, ValueError):
        raise TypeError("q: expected an array of floats of shape (n,) or (m, n)") from None
    if q.ndim not in (1, 2) or q.shape[-1] == 0:
        raise ValueError(f"q: expected shape (n,) or (m, n) with n >= 1, got {q.shape}")
    return np.ascontiguousarray(q.reshape(-1, q.shape[-1]))


def _count(value, name: str, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"{name}: expected an integer >= {minimum}, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name}: must be >= {minimum}, got {value}")
    return int(value)


class FPUPotential(Potential):
    """The soft nonlinear springs of the Fermi–Pasta–Ulam chain [GNI §I.5], native in Rust.

    In the variables x = (x₀,₁ … x₀,ₘ, x₁,₁ … x₁,ₘ) (slow block first, stiff block second),

        U(x) = ¼[(x₀,₁ − x₁,₁)⁴ + Σᵢ₌₁^{m−1}(x₀,ᵢ₊₁ − x₁,ᵢ₊₁ − x₀,ᵢ − x₁,ᵢ)⁴ + (x₀,ₘ + x₁,ₘ)⁴].

    With ``coordinates="original"`` the same springs as a function of the particles'
    positions q₁ … q₂ₘ: U(q) = Σᵢ₌₀^m (q₂ᵢ₊₁ − q₂ᵢ)⁴ with q₀ = q₂ₘ₊₁ = 0, evaluated as U(x(q))
    through the orthogonal map x = Tᵀq of :func:`trigint.problems.fpu_original_basis`.

    Parameters
    ----------
    m : int
        The number of stiff springs (≥ 1); U acts on 2m coordinates.
    coordinates : {"diagonal", "original"}
        The variables x of the modal (diagonal) form, or the particles' positions q.

    Examples
    --------
    >>> import trigint as ti
    >>> round(ti.FPUPotential(3).value([1, 0, 0, 0.02, 0, 0]), 8)
    0.50120008
    >>> round(ti.FPUPotential(1, coordinates="original").value([0.0, 0.5]), 12)  # 0.5**4
    0.0625
    """

    def __init__(self, m: int = 3, coordinates: str = "diagonal"):
        if not _check.is_integer(m):
            raise _check.IntegerTypeError(f"m: the number of stiff springs must be an integer >= 1, got {m!r}")
        if m < 1:
            raise ValueError(f"m: the number of stiff springs must be an integer >= 1, got {m!r}")
        if not isinstance(coordinates, str) or coordinates not in ("diagonal", "original"):
            raise ValueError(f"coordinates: expected 'diagonal' or 'original', got {coordinates!r}")
        self.m = int(m)
        self.dim = _check.coordinates(2 * self.m, "m", "coordinates (2m)")
        self.coordinates = coordinates

    def _map(self) -> dict | None:
        """x = Tᵀq as the core's sparse map (None in the diagonal coordinates)."""
        if self.coordinates == "diagonal":
            return None
        return _csr_map(fpu_original_basis(self.m).T, self.dim)

    def describe(self, n: int) -> dict:
        return {"kind": "fpu", "m": self.m, "map": self._map()}

    def own_coordinates(self) -> tuple[np.ndarray, dict] | None:
        if self.coordinates == "diagonal":
            return None
        return fpu_original_basis(self.m), {"kind": "fpu", "m": self.m, "map": None}

    def program_description(self) -> dict:
        """The same U as a compiled program (for coordinate orders the native code does not
        know)."""
        return {"kind": "program", **fpu_tape(self.m), "map": self._map()}

    def __repr__(self) -> str:
        extra = ", coordinates='original'" if self.coordinates == "original" else ""
        return f"FPUPotential(m={self.m}{extra})"


def _csr_map(dense: np.ndarray, n: int) -> dict:
    rows, cols = np.nonzero(dense)
    ptr = np.searchsorted(rows, np.arange(dense.shape[0] + 1))
    return {"rows": int(dense.shape[0]), "cols": n, "ptr": [int(x) for x in ptr],
            "idx": [int(x) for x in cols], "vals": np.ascontiguousarray(dense[rows, cols], dtype=float)}


class ExpressionPotential(Potential):
    """U given as an expression, compiled once into a native program for U and ∇U.

    The expression keeps its structure (nothing is expanded: the FPU stays four fourth powers
    of linear forms), common subexpressions are computed once, and the gradient is the exact
    reverse-mode derivative of the program. No Python runs while stepping, and every lane of
    an ensemble gets the bits of ``integrate()``.

    Parameters
    ----------
    expr : sympy.Expr or str
        U in the symbols `coordinates` (and the names in `params`). Supported: + − × ÷,
        integer and rational powers, sqrt, exp, log, sin, cos, tan, sinh, cosh, tanh, Abs and
        numbers. A string is read as data, never run as Python: only numbers, the declared
        names, pi, E, these functions, ``+ - * / ** ^`` and parentheses are accepted (sums of
        any length), anything else is refused naming the token.
    coordinates : sequence of sympy.Symbol or str
        The coordinates q₁ … qₙ, in the problem's order.
    params : dict of str → float, optional
        Numeric values of the other symbols of `expr`.

    Examples
    --------
    A pendulum chain with stiff springs between the pendulums (a problem not in the paper):

    >>> import trigint as ti
    >>> U = ti.ExpressionPotential("g*(2 - cos(a) - cos(b))", ["a", "b"], params={"g": 9.81})
    >>> round(U.value([0.1, -0.2]), 8)
    0.24455601
    >>> U.gradient([0.0, 0.0])
    array([0., 0.])
    """

    def __init__(self, expr, coordinates, params: Mapping | None = None):
        coords = _tape.symbols(coordinates)
        self.params = _tape.parameters(params)
        clash = sorted(set(self.params) & {str(s) for s in coords})
        if clash:
            raise ValueError(f"params: {clash} are coordinates, not parameters")
        self.expr = _tape.parse(expr, [*map(str, coords), *self.params])
        self.coordinates = coords
        self._tape = _tape.tape(self.expr, coords, self.params)
        self.dim = len(coords)
        # Compiled here, so that an invalid program fails at construction, not at the first step.
        self.instructions = _native.instructions(self, self.dim)

    def describe(self, n: int) -> dict:
        return {"kind": "program", **self._tape, "map": None}

    def __repr__(self) -> str:
        text = str(self.expr)
        text = text if len(text) <= 60 else text[:57] + "..."
        params = f", params={dict(self.params)!r}" if self.params else ""
        return f"ExpressionPotential({text!r}, dim={self.dim}{params})"


class PolynomialPotential(Potential):
    """A sparse polynomial U(q) = Σₜ cₜ Πᵢ qᵢ^{eₜᵢ}, compiled like an expression.

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
        c = _check.real_array(coefficients, "coefficients").reshape(-1)
        try:
            e = np.asarray(exponents)
        except (TypeError, ValueError, OverflowError):
            raise TypeError("exponents: expected an array of non-negative integers, shape (terms, n)") from None
        if e.ndim != 2 or e.shape[1] == 0:
            raise ValueError(f"exponents: expected shape (number of terms, n) with n >= 1, got {e.shape}")
        if e.shape[0] != c.size:
            raise ValueError(f"coefficients, exponents: {c.size} coefficient(s) but {e.shape[0]} row(s) of "
                             "exponents; give one row per term")
        if e.dtype.kind not in "iuf" or (e.dtype.kind == "f" and not np.all(np.equal(np.mod(e, 1), 0))):
            raise ValueError("exponents: must be non-negative integers")
        if np.any(e < 0) or np.any(e > 2**20):
            raise ValueError("exponents: must be non-negative integers of at most 2**20")
        e = e.astype(np.int64)
        self.coefficients = c
        self.exponents = e
        self.dim = int(e.shape[1])
        self._tape = _polynomial_tape(c, e)

    @classmethod
    def from_sympy(cls, expr, symbols) -> ExpressionPotential:
        """The potential of a SymPy polynomial, coordinates in the order of `symbols`.

        Nothing is expanded: this is an :class:`ExpressionPotential` of `expr` as written (a
        fourth power of a linear form stays one), so it runs at the speed of the expression.

        Parameters
        ----------
        expr : sympy.Expr or str
            A polynomial in `symbols` (and no other symbol).
        symbols : sequence of sympy.Symbol or str
            The coordinates q₁ … qₙ, in the problem's order.

        Returns
        -------
        ExpressionPotential

        >>> import sympy as sp, trigint as ti
        >>> q0, q1, q2 = sp.symbols("q0 q1 q2")
        >>> ti.PolynomialPotential.from_sympy(sp.Rational(1, 100) * q1 * q2, [q0, q1, q2]).dim
        3
        """
        coords = _tape.symbols(symbols, "symbols")
        e = _tape.parse(expr, [str(s) for s in coords])
        free = e.free_symbols - set(coords)
        if free:
            raise ValueError(f"expr: has symbols {sorted(map(str, free))} that are not coordinates")
        if not e.is_polynomial(*coords):
            raise ValueError(f"expr: not a polynomial in {[str(s) for s in coords]}")
        return ExpressionPotential(e, coords)

    def describe(self, n: int) -> dict:
        return {"kind": "program", **self._tape, "map": None}

    def __repr__(self) -> str:
        return f"PolynomialPotential({self.coefficients.size} terms, dim={self.dim})"


def _polynomial_tape(c: np.ndarray, e: np.ndarray) -> dict:
    n = e.shape[1]
    ops: list[tuple] = [("input", i) for i in range(n)]
    total = None
    for coef, row in zip(c, e, strict=True):
        acc = len(ops)
        ops.append(("const", float(coef)))
        for i, k in enumerate(row):
            if k:
                ops.append(("powi", i, int(k)))
                ops.append(("mul", acc, len(ops) - 1))
                acc = len(ops) - 1
        if total is None:
            total = acc
        else:
            ops.append(("add", total, acc))
            total = len(ops) - 1
    if total is None:
        ops.append(("const", 0.0))
        total = len(ops) - 1
    return {"n": n, "ops": ops, "output": total}


#: a chain of at most this many terms in all runs as one compiled program (`_tape.chain_tape`):
#: its per-term overhead would dominate (Toda, m = 3: 110.6 ns per step as a chain, 47.3 as one
#: program, against C's 41.3)
ONE_PROGRAM_TERMS = 32


class ChainPotential(Potential):
    """U(q) = Σ_b V_b((Lq)_b): univariate functions of sparse linear forms of q.

    The structured form of chains and lattices of many particles (nearest-neighbour springs,
    FPU, Toda, Morse, on-site potentials): each group of terms is one function V of one
    variable, compiled once, applied to every row of a sparse matrix L. The cost per step is
    that of the terms, with no expression of size m to build; a short chain (at most
    ``ONE_PROGRAM_TERMS`` terms in all) is compiled as one program instead.

    Parameters
    ----------
    n : int
        Number of coordinates.

    Notes
    -----
    A new chain has no terms: add groups of terms with :meth:`add`, which returns the chain,
    so that calls can be chained.

    Examples
    --------
    A Toda chain of 4 particles with fixed ends, plus an on-site 1 − cos(q) term:

    >>> import trigint as ti
    >>> U = (ti.ChainPotential(4)
    ...      .add("exp(y) - 1 - y", "y", pairs=[(0, 1), (1, 2), (2, 3)])
    ...      .add("1 - cos(y)", "y", sites=range(4)))
    >>> round(U.value([0.1, 0.0, -0.1, 0.2]), 8)
    0.08945874
    """

    def __init__(self, n: int):
        self.dim = _check.coordinates(_count(n, "n"), "n")
        self.terms: list[dict] = []
        self._descriptions: list[str] = []

    def add(self, v, variable="y", *, pairs=None, sites=None, matrix=None,
            params: Mapping | None = None) -> ChainPotential:
        """Adds Σ_b V((Lq)_b) for one function V of one variable.

        The rows of L, the linear forms, are given by exactly one of `pairs`, `sites` and
        `matrix`.

        Parameters
        ----------
        v : sympy.Expr or str
            V as an expression in `variable` (and the names in `params`).
        variable : sympy.Symbol or str
            The variable of V (default ``"y"``).
        pairs : sequence of (int, int), optional
            Index pairs (i, j), each the form q_j − q_i: a spring from particle i to particle j.
        sites : sequence of int, optional
            Indices i, each the form q_i: an on-site potential.
        matrix : array of shape (terms, n) or scipy.sparse matrix, optional
            L itself, one row per term.
        params : dict of str → float, optional
            Numeric values of the other symbols of `v`.

        Returns
        -------
        ChainPotential
            This chain, with the new terms.
        """
        (var,) = _tape.symbols([variable], "variable")
        params = _tape.parameters(params)
        expr = _tape.parse(v, [str(var), *params], "v")
        rows = _linear_rows(self.dim, pairs, sites, matrix)
        self.terms.append({"v": _tape.tape(expr, [var], params, "v", "variable"), "map": rows})
        self._descriptions.append(f"{len(rows['ptr']) - 1} x V({var}) = {expr}")
        _native.changed(self)
        _native.instructions(self, self.dim)  # compile now: errors here, not later
        return self

    def describe(self, n: int) -> dict:
        if not self.terms:
            raise ValueError("ChainPotential: no terms; add some with .add(v, variable, pairs=...)")
        if sum(len(t["map"]["ptr"]) - 1 for t in self.terms) <= ONE_PROGRAM_TERMS:
            return {"kind": "program", **_tape.chain_tape(self.dim, self.terms)}
        return {"kind": "chain", "n": self.dim, "terms": list(self.terms)}

    def __repr__(self) -> str:
        return f"ChainPotential(n={self.dim}: {'; '.join(self._descriptions) or 'no terms'})"


def _linear_rows(n: int, pairs, sites, matrix) -> dict:
    """A sparse matrix L (terms × n) in compressed rows from one of the three forms."""
    given = [x is not None for x in (pairs, sites, matrix)]
    if sum(given) != 1:
        raise ValueError("give exactly one of pairs=, sites= or matrix=")
    if pairs is not None:
        p = _check.indices(pairs, "pairs", n, width=2)
        if np.any(p[:, 0] == p[:, 1]):
            raise ValueError("pairs: a pair (i, i) is the zero form")
        idx = p[:, ::-1].reshape(-1)
        vals = np.tile([1.0, -1.0], p.shape[0])
        ptr = np.arange(0, 2 * p.shape[0] + 1, 2)
        rows = p.shape[0]
    elif sites is not None:
        s = _check.indices(sites, "sites", n)
        idx, vals, ptr, rows = s, np.ones(s.size), np.arange(s.size + 1), s.size
    else:
        try:
            import scipy.sparse as sparse

            m = sparse.csr_matrix(matrix, dtype=float)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"matrix: expected a 2-d array or scipy.sparse matrix: {exc}") from None
        if m.shape[1] != n or m.shape[0] == 0:
            raise ValueError(f"matrix: expected shape (terms, {n}), got {m.shape}")
        if not np.all(np.isfinite(m.data)):
            raise ValueError("matrix: entries must be finite")
        m.sort_indices()
        idx, vals, ptr, rows = m.indices, m.data, m.indptr, m.shape[0]
    return {"rows": int(rows), "cols": n, "ptr": [int(x) for x in ptr],
            "idx": [int(x) for x in idx], "vals": np.ascontiguousarray(vals, dtype=float)}


class PythonPotential(Potential):
    """U and ∇U as Python callables: for prototyping, and for what cannot be compiled.

    Per trajectory (default), ``value(q)`` and ``gradient(q)`` take a 1-d array q of shape (n,)
    and return a float and an array of shape (n,). With ``vectorized=True`` they take the
    states of a whole block of trajectories, an array of shape (lanes, n), and return shapes
    (lanes,) and (lanes, n): in ``ensemble()`` that is one call per bundle of 256 trajectories
    and step instead of one per trajectory. The block is column-major (each coordinate
    contiguous across the trajectories, as the kernel stores it), so operations on its columns
    ``q[:, i]`` run over all lanes at once; the functions must not modify it. The block always
    has the bundle's full 256 rows (padding rows included when an ensemble has fewer
    trajectories), so the results must have shapes (256,) and (256, n).

    Parameters
    ----------
    value : callable
        q ↦ U(q): an array of shape (n,) to a float, or with `vectorized` (lanes, n) to (lanes,).
    gradient : callable
        q ↦ ∇U(q): shape (n,) to (n,), or with `vectorized` (lanes, n) to (lanes, n).
    dim : int, optional
        The number of coordinates, if U is only defined for one (checked against the problem).
    vectorized : bool
        Whether the callables take a block of trajectories (``ensemble()`` only calls them
        that way; ``integrate()`` passes a block of one row).
    hessian_vector : callable, optional
        (q, v) ↦ ∇²U(q) v, both of shape (n,), for the tangent map (:func:`trigint.lyapunov`).
        Without it, the tangent map is refused unless central differences of the gradient are
        allowed there (``finite_differences=True``).

    Attributes
    ----------
    value_function, gradient_function, hessian_vector_function : callable
        The callables as given (the last None when not given).
    vectorized : bool
        Whether they take a block of trajectories.

    Examples
    --------
    >>> import numpy as np, trigint as ti
    >>> U = ti.PythonPotential(lambda q: float(np.sum(q**4)) / 4, lambda q: q**3)
    >>> U.gradient([2.0])
    array([8.])
    >>> V = ti.PythonPotential(lambda q: np.sum(q**4, axis=-1) / 4, lambda q: q**3, vectorized=True)
    >>> V.gradient([[1.0], [2.0]])
    array([[1.],
           [8.]])
    """

    def __init__(
        self,
        value: Callable[[np.ndarray], float],
        gradient: Callable[[np.ndarray], np.ndarray],
        dim: int | None = None,
        *,
        vectorized: bool = False,
        hessian_vector: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
    ):
        if not callable(value) or not callable(gradient):
            raise TypeError("value and gradient must be callables taking an array q")
        if hessian_vector is not None and not callable(hessian_vector):
            raise TypeError("hessian_vector must be a callable (q, v) -> Hess U(q) v, or None")
        self.hessian_vector_function = hessian_vector
        if not isinstance(vectorized, bool):
            raise TypeError(f"vectorized: expected True or False, got {vectorized!r}")
        self.value_function, self.gradient_function = value, gradient
        self.dim = None if dim is None else _check.coordinates(_count(dim, "dim"), "dim")
        self.vectorized = vectorized

    def describe(self, n: int) -> dict:
        return {"kind": "python", "n": n, "value": self.value_function, "gradient": self.gradient_function,
                "vectorized": self.vectorized, "hessian_vector": self.hessian_vector_function}

    def __repr__(self) -> str:
        kind = ", vectorized" if self.vectorized else ""
        return f"PythonPotential({getattr(self.value_function, '__name__', 'value')}{kind})"
