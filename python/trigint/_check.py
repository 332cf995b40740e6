"""Argument checks shared by the public entry points: each error names the argument and says
what is allowed (a TypeError for the wrong kind of value, a ValueError for a wrong value)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


class IntegerTypeError(TypeError, ValueError):
    """A float, string, boolean or other non-integer given where an integer is expected.

    A TypeError; also a ValueError, which some of these arguments raised before.

    >>> issubclass(IntegerTypeError, TypeError) and issubclass(IntegerTypeError, ValueError)
    True
    """


def shown(value) -> str:
    """`value` for an error message: its repr, shortened; an integer too long to print by its length.

    >>> shown(10**400)
    'an integer of 401 digits'
    >>> shown(2.5)
    '2.5'
    """
    if isinstance(value, int | np.integer) and not isinstance(value, bool) and abs(int(value)) >= 10**30:
        return f"an integer of {_digits(int(value))} digits"
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _digits(n: int) -> int:
    n = abs(n)
    bits = n.bit_length()
    if bits < 10000:
        return len(str(n))
    return int(bits * 0.30102999566398120)  # too long to convert to text; close enough for a message


def too_large(name: str, value) -> ValueError:
    """The error for a number that does not fit a double."""
    return ValueError(f"{name}: {shown(value)} is too large for a double (at most about 1.8e308 in magnitude)")


def _unwrapped(value):
    """A 0-d NumPy array of integers or floats (``np.array(0.03)``) as its scalar; anything
    else unchanged."""
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        return value[()]
    return value


def _kind(value) -> str:
    """The type of `value` as an error message names it (an array with its shape)."""
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape}"
    return type(value).__name__


def real(value, name: str, *, positive: bool = False, nonneg: bool = False, finite: bool = True) -> float:
    """A real number: int or float (NumPy scalars included), not bool, str or complex.

    >>> real(3, "h")
    3.0
    >>> real(10**400, "h")
    Traceback (most recent call last):
    ValueError: h: an integer of 401 digits is too large for a double (at most about 1.8e308 in magnitude)
    """
    value = _unwrapped(value)
    if isinstance(value, bool | np.bool_) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"{name}: expected a real number, got {shown(value)} ({type(value).__name__})")
    try:
        x = float(value)
    except OverflowError:
        raise too_large(name, value) from None
    if finite and not np.isfinite(x):
        raise ValueError(f"{name}: must be finite, got {x}")
    if positive and not x > 0:
        raise ValueError(f"{name}: must be > 0, got {x}")
    if nonneg and not x >= 0:
        raise ValueError(f"{name}: must be >= 0, got {x}")
    return x


def is_integer(value) -> bool:
    """An integer (Python or NumPy), not a bool, float or string."""
    return isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)


def number(value, name: str) -> float:
    """A real number, finite or not (not a string, a bool or a complex)."""
    value = _unwrapped(value)
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"{name}: expected a number, got {shown(value)} ({type(value).__name__})")
    try:
        return float(value)
    except OverflowError:
        raise too_large(name, value) from None


def step_size(h) -> float:
    """The step size h: a finite float > 0 (a 0-d array of one is taken as its number)."""
    h = _unwrapped(h)
    if isinstance(h, bool) or not isinstance(h, int | float | np.integer | np.floating):
        raise TypeError(f"h: expected a positive float, got {_kind(h)}")
    try:
        h = float(h)
    except OverflowError:
        raise too_large("h", h) from None
    if not np.isfinite(h) or h <= 0:
        raise ValueError(f"h: the step size must be finite and > 0, got {h}")
    return h


def integer(value, name: str, *, low: int | None = None, high: int | None = None) -> int:
    """An integer (Python or NumPy, not bool) within [low, high].

    >>> integer(np.int32(4), "m", low=1)
    4
    >>> integer(4.0, "m")
    Traceback (most recent call last):
    trigint._check.IntegerTypeError: m: expected an integer, got 4.0 (float)
    """
    if not is_integer(value):
        raise IntegerTypeError(f"{name}: expected an integer, got {shown(value)} ({type(value).__name__})")
    n = int(value)
    if (low is not None and n < low) or (high is not None and n > high):
        bounds = (f"from {low} to {high}" if low is not None and high is not None
                  else f">= {low}" if low is not None else f"<= {high}")
        raise ValueError(f"{name}: must be an integer {bounds}, got {shown(n)}")
    return n


def indices(value, name: str, n: int, *, width: int | None = None) -> np.ndarray:
    """Coordinate indices in 0 … n−1 as an int64 array: a sequence (or integer array) of
    integers, or with `width` a sequence of tuples of that many. Floats, strings and booleans
    are refused, never truncated or split into characters.

    >>> indices(range(3), "sites", 4).tolist()
    [0, 1, 2]
    >>> indices([(0, 1), (1, 2)], "pairs", 3, width=2).tolist()
    [[0, 1], [1, 2]]
    >>> try:
    ...     indices([(0.7, 1.2)], "pairs", 3, width=2)
    ... except TypeError as exc:
    ...     print(exc)
    pairs: 0.7 (float) is not an integer; indices must be integers (not floats, strings or booleans)
    """
    what = "a sequence of integer index pairs (i, j)" if width == 2 else "a sequence of integer coordinate indices"
    if isinstance(value, str | bytes) or not _iterable(value):
        raise IntegerTypeError(f"{name}: expected {what}, got {shown(value)} ({type(value).__name__})")
    if isinstance(value, np.ndarray):
        if value.dtype.kind not in "iu":
            raise IntegerTypeError(f"{name}: expected {what}, got an array of {value.dtype}")
        a = value.astype(np.int64)
    elif isinstance(value, range):
        a = np.asarray(value, dtype=np.int64)
    else:
        rows = list(value)
        flat = rows
        if width is not None:
            for row in rows:
                if isinstance(row, str | bytes) or not _iterable(row):
                    raise IntegerTypeError(f"{name}: expected {what}, got the entry {shown(row)}")
            rows = [list(row) for row in rows]
            flat = [x for row in rows for x in row]
        for x in flat:
            if not is_integer(x):
                raise IntegerTypeError(f"{name}: {shown(x)} ({type(x).__name__}) is not an integer; indices must "
                                       "be integers (not floats, strings or booleans)")
        try:
            a = np.asarray(rows, dtype=np.int64)
        except OverflowError:
            raise ValueError(f"{name}: an index is outside 0 … {n - 1}") from None
        except ValueError:
            raise ValueError(f"{name}: expected {what}; the entries have different lengths") from None
    if width is not None and (a.ndim != 2 or a.shape[1] != width):
        raise ValueError(f"{name}: expected shape (terms, {width}), got {a.shape}")
    if width is None:
        a = a.reshape(-1)
    if a.size == 0:
        raise ValueError(f"{name}: empty")
    bad = (a < 0) | (a >= n)
    if bad.any():
        raise ValueError(f"{name}: index {a[bad][0]} is outside 0 … {n - 1}")
    return a


def _iterable(value) -> bool:
    try:
        iter(value)
    except TypeError:
        return False
    return True


def real_array(value, name: str, *, ndim: int | None = 1, finite: bool = True, positive: bool = False,
               nonneg: bool = False, nonempty: bool = True) -> np.ndarray:
    """A float array from a sequence or array of real numbers (complex and strings refused)."""
    if isinstance(value, str | bytes | dict) or value is None or callable(value):
        raise TypeError(f"{name}: expected an array of real numbers, got {type(value).__name__}")
    if np.iscomplexobj(value):
        raise TypeError(f"{name}: complex values are not allowed")
    try:
        a = np.asarray(value, dtype=float)
    except OverflowError:
        raise ValueError(f"{name}: a value is too large for a double (at most about 1.8e308 in magnitude), got "
                         f"{_short(value)}") from None
    except (TypeError, ValueError):
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
    try:
        text = repr(value)
    except ValueError:  # an integer with more digits than Python prints
        return f"a {type(value).__name__} holding a huge integer"
    return text if len(text) <= 80 else text[:77] + "..."


def physical_memory() -> int:
    """This machine's memory in bytes (32 GiB where the system does not say)."""
    import os

    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 32 << 30


#: the arrays of n numbers that one trajectory's run holds at least (state, checkpoint, last good
#: state, method coefficients and energy weights)
ARRAYS_PER_COORDINATE = 24


def coordinates(n: int, name: str, what: str = "coordinates") -> int:
    """A count of coordinates that a run could hold in memory, refused before anything is
    allocated otherwise (a size the core cannot allocate would end the interpreter).

    >>> coordinates(10**12, "n")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ValueError: n: 1000000000000 coordinates would need at least 175 TiB (...), more than this machine's ...
    """
    need = int(n) * 8 * ARRAYS_PER_COORDINATE
    have = physical_memory()
    if need > have:
        raise ValueError(
            f"{name}: {int(n)} {what} would need at least {_bytes(need)} ({ARRAYS_PER_COORDINATE} arrays of "
            f"8-byte numbers), more than this machine's {_bytes(have)} memory"
        )
    return int(n)


def dense_matrix(n: int, name: str) -> int:
    """The side n of a dense n × n matrix that fits in memory, refused before it is allocated.

    >>> dense_matrix(2 * 10**6, "m")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ValueError: m: a dense 2000000 x 2000000 matrix would need 29.1 TiB, more than this machine's ...
    """
    need, have = int(n) ** 2 * 8, physical_memory()
    if need > have:
        raise ValueError(f"{name}: a dense {int(n)} x {int(n)} matrix would need {_bytes(need)}, more than this "
                         f"machine's {_bytes(have)} memory")
    return int(n)


def _bytes(n: int) -> str:
    """A byte count in the largest binary unit that leaves a number >= 1.

    >>> _bytes(3 << 30)
    '3 GiB'
    """
    value, unit = float(n), "bytes"
    for u in ("KiB", "MiB", "GiB", "TiB", "PiB", "EiB"):
        if value < 1024:
            break
        value, unit = value / 1024, u
    return f"{value:.3g} {unit}"
