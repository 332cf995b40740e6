"""Methods by name: "A"–"E", the filter aliases, "imex" and "stormer-verlet", one object per
name, and the closest valid name for a misspelt one."""

from __future__ import annotations

import functools
from collections.abc import Callable

from ._filters import FILTERS
from .methods import IMEX, Method, StormerVerlet, Trigonometric

#: the methods that are not a filter pair of the trigonometric family, by name
MODIFIED_METHODS: dict[str, Callable[[], Method]] = {
    "imex": IMEX,
    "stormer-verlet": StormerVerlet,
    "verlet": StormerVerlet,
}


def _closest(name: str, names) -> str:
    """", did you mean 'x'?" for the valid name nearest to a misspelt one, if one is near.

    >>> _closest("stormer_verlett", ["imex", "stormer-verlet"])
    ", did you mean 'stormer-verlet'?"
    """
    import difflib

    key = name.strip().lower().replace("_", "-")
    lowered = {n.lower(): n for n in names}
    near = difflib.get_close_matches(key, list(lowered), n=1, cutoff=0.6)
    return f", did you mean {lowered[near[0]]!r}?" if near else ""


def resolve_method(method: Method | str) -> Method:
    """A method object from itself or a name ("A"–"E", filter aliases, "imex", "stormer-verlet");
    the same object for the same name (so that what is computed for it can be kept)."""
    if isinstance(method, Method):
        return method
    if isinstance(method, str):
        return _method_named(method)
    raise TypeError(
        "method: expected a trigint method (Trigonometric('B'), IMEX(), AlphaMethod(alpha), ...) "
        f"or its name, got {type(method).__name__}"
    )


@functools.lru_cache(maxsize=64)
def _method_named(method: str) -> Method:
    key = method.strip().lower().replace("_", "-")
    if key in MODIFIED_METHODS:
        return MODIFIED_METHODS[key]()
    try:
        return Trigonometric(method)
    except ValueError:
        from ._filters import ALIASES

        names = [*FILTERS, *ALIASES, *MODIFIED_METHODS]
        raise ValueError(f"method: unknown name {method!r}{_closest(method, names)}; "
                         f"valid names are {', '.join(names)}") from None
