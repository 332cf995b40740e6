"""Argument checks shared by the public entry points: each error names the argument and says
what is allowed (a TypeError for the wrong kind of value, a ValueError for a wrong value)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def real(value, name: str, *, positive: bool = False, nonneg: bool = False, finite: bool = True) -> float:
    """A real number: int or float (NumPy scalars included), not bool, str or complex."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"{name}: expected a real number, got {value!r} ({type(value).__name__})")
    try:
        x = float(value)
    except OverflowError:
        raise ValueError(f"{name}: {value} is too large for a double") from None
    if finite and not np.isfinite(x):
        raise ValueError(f"{name}: must be finite, got {x}")
    if positive and not x > 0:
        raise ValueError(f"{name}: must be > 0, got {x}")
    if nonneg and not x >= 0:
        raise ValueError(f"{name}: must be >= 0, got {x}")
    return x


def number(value, name: str) -> float:
    """A real number, finite or not (not a string, a bool or a complex)."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"{name}: expected a number, got {value!r} ({type(value).__name__})")
    return float(value)


def step_size(h) -> float:
    """The step size h: a finite float > 0."""
    if isinstance(h, bool) or not isinstance(h, int | float | np.integer | np.floating):
        raise TypeError(f"h: expected a positive float, got {type(h).__name__}")
    h = float(h)
    if not np.isfinite(h) or h <= 0:
        raise ValueError(f"h: the step size must be finite and > 0, got {h}")
    return h


def integer(value, name: str, *, low: int | None = None, high: int | None = None) -> int:
    """An integer (Python or NumPy, not bool) within [low, high]."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, int | np.integer):
        raise TypeError(f"{name}: expected an integer, got {value!r} ({type(value).__name__})")
    n = int(value)
    if (low is not None and n < low) or (high is not None and n > high):
        bounds = (f"from {low} to {high}" if low is not None and high is not None
                  else f">= {low}" if low is not None else f"<= {high}")
        raise ValueError(f"{name}: must be an integer {bounds}, got {n}")
    return n


def real_array(value, name: str, *, ndim: int | None = 1, finite: bool = True, positive: bool = False,
               nonneg: bool = False, nonempty: bool = True) -> np.ndarray:
    """A float array from a sequence or array of real numbers (complex and strings refused)."""
    if isinstance(value, str | bytes | dict) or value is None or callable(value):
        raise TypeError(f"{name}: expected an array of real numbers, got {type(value).__name__}")
    if np.iscomplexobj(value):
        raise TypeError(f"{name}: complex values are not allowed")
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise TypeError(f"{name}: expected an array of real numbers, got {_short(value)}") from None
    if ndim is not None and a.ndim > ndim:
        raise ValueError(f"{name}: expected at most {ndim} dimension(s), got shape {a.shape}")
    if ndim is not None and a.ndim < ndim:
        a = a.reshape((1,) * (ndim - a.ndim) + a.shape)
    if nonempty and a.size == 0:
        raise ValueError(f"{name}: give at least one value")
    if finite and not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: values must be finite, got {_short(value)}")
    if positive and not np.all(a > 0):
        raise ValueError(f"{name}: values must be > 0, got {_short(value)}")
    if nonneg and not np.all(a >= 0):
        raise ValueError(f"{name}: values must be >= 0, got {_short(value)}")
    return a


def choice(value, name: str, choices: Sequence[str]) -> str:
    """One of the strings `choices`."""
    if not isinstance(value, str):
        raise TypeError(f"{name}: expected one of {', '.join(map(repr, choices))}, got {value!r}")
    if value not in choices:
        raise ValueError(f"{name}: unknown {value!r}; valid: {', '.join(map(repr, choices))}")
    return value


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."
