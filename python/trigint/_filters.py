"""Filter functions and their registry: the named methods A–E [GNI §XIII.2.2]."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


def sinc(x) -> np.ndarray:
    """sinc(ξ) = sin(ξ)/ξ with sinc(0) = 1 (unnormalized, unlike ``numpy.sinc``).

    Parameters
    ----------
    x : float or array
        ξ.

    Examples
    --------
    >>> import numpy as np
    >>> from trigint import sinc
    >>> round(float(sinc(np.pi / 2)), 12), float(sinc(0.0))
    (0.636619772368, 1.0)
    """
    try:
        x = np.asarray(x, dtype=float)
    except OverflowError:
        raise ValueError("x: a value is too large for a double (at most about 1.8e308 in magnitude)") from None
    out = np.ones_like(x)
    nz = x != 0
    out[nz] = np.sin(x[nz]) / x[nz]
    return out if out.ndim else float(out)


def one(x) -> np.ndarray:
    """The constant filter 1."""
    return np.ones_like(np.asarray(x, dtype=float))


def _half_tan_ratio(x) -> np.ndarray:
    """sinc²(ξ/2)/sinc(ξ) = 2 tan(ξ/2)/ξ, without the division by sinc: finite at the even
    multiples of π, undefined (NaN) at the odd ones, where sinc vanishes and sinc²(ξ/2) does not."""
    x = np.asarray(x, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(np.abs(np.cos(x / 2)) > 1e-6, 2 * np.tan(x / 2) / np.where(x == 0, 1.0, x), np.nan)
    return np.where(x == 0, 1.0, out)


def _nan(x) -> np.ndarray:
    return np.full_like(np.asarray(x, dtype=float), np.nan)


@dataclass(frozen=True)
class Filter:
    """A named filter pair (ψ, φ) with its source.

    ``psi_over_sinc`` and ``sigma`` are ψ/sinc and σ = sinc·φ/ψ in closed forms that do not divide
    by sinc: at hω = kπ, where sinc vanishes, they give the one-step form's numbers and the
    modified energy's weight (NaN where the quantity is undefined).
    """

    key: str
    psi: Callable
    phi: Callable
    reference: str
    formula: str
    psi_over_sinc: Callable = _nan
    sigma: Callable = _nan


FILTERS: dict[str, Filter] = {
    "A": Filter("A", lambda x: sinc(np.asarray(x) / 2) ** 2, one, "Gautschi 1961",
                "psi = sinc^2(xi/2), phi = 1", psi_over_sinc=_half_tan_ratio),
    "B": Filter("B", sinc, one, "Deuflhard 1979", "psi = sinc(xi), phi = 1",
                psi_over_sinc=one, sigma=one),
    "C": Filter("C", lambda x: sinc(x) ** 2, sinc, "Garcia-Archilla, Sanz-Serna, Skeel 1999",
                "psi = sinc^2(xi), phi = sinc(xi)", psi_over_sinc=sinc, sigma=one),
    "D": Filter("D", lambda x: sinc(np.asarray(x) / 2) ** 2,
                lambda x: sinc(x) * (1 + np.sin(np.asarray(x) / 2) ** 2 / 3),
                "Hochbruck-Lubich 1999", "psi = sinc^2(xi/2), phi = sinc(xi) (1 + sin^2(xi/2)/3)",
                psi_over_sinc=_half_tan_ratio,
                sigma=lambda x: np.cos(np.asarray(x) / 2) ** 2 * (1 + np.sin(np.asarray(x) / 2) ** 2 / 3)),
    "E": Filter("E", lambda x: sinc(x) ** 2, one, "Hairer-Lubich 2000", "psi = sinc^2(xi), phi = 1",
                psi_over_sinc=sinc),
}

ALIASES = {
    "gautschi": "A",
    "deuflhard": "B",
    "gss": "C",
    "garcia-archilla-sanz-serna-skeel": "C",
    "hochbruck-lubich": "D",
    "hairer-lubich": "E",
}


def lookup(name: str) -> Filter:
    """The filter pair registered under `name` (A–E or an alias, case-insensitive)."""
    if not isinstance(name, str):
        raise TypeError(f"filter: expected a name such as 'B' or 'deuflhard', got {type(name).__name__}")
    key = name.strip()
    key = key.upper() if key.upper() in FILTERS else ALIASES.get(key.lower(), key)
    if key not in FILTERS:
        valid = ", ".join([*FILTERS, *ALIASES])
        raise ValueError(f"filter: unknown name {name!r}; valid names are {valid}")
    return FILTERS[key]


def evaluate(f: Callable, x: np.ndarray, what: str, at: str = "xi") -> np.ndarray:
    """f at the points x (named `at` in errors), vectorized if f allows it, else point by point;
    must be real and finite."""
    try:
        y = _as_real(f(x), what)
        if y.shape != x.shape:
            y = np.broadcast_to(y, x.shape).astype(float) if y.ndim == 0 else None
    except TypeError:  # a scalar-only callable (math.sin, say): one point at a time
        y = None
    if y is None:
        values = [_as_real(f(float(v)), what) for v in x]
        if any(v.ndim != 0 for v in values):
            raise ValueError(f"{what}: must return one number per xi (or an array shaped like xi)")
        y = np.array(values, dtype=float).reshape(x.shape)
    if not np.all(np.isfinite(y)):
        i = int(np.flatnonzero(~np.isfinite(y))[0])
        raise ValueError(f"{what}: not finite at {at} = {float(x[i])!r} (value {float(y[i])!r})")
    return y


def _as_real(value, what: str) -> np.ndarray:
    if np.iscomplexobj(value):
        raise TypeError(f"{what}: returned complex values; filter functions must be real")
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{what}: returned {value!r}, not real numbers") from None
