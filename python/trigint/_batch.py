"""Preparing a batch: broadcasting inputs, per-trajectory coefficients (from the problem's
stepper), and the arguments every chunk takes (the chunk runner is ``_steppers.run_chunk``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _check
from .methods import Method
from .problem import OscillatoryProblem
from .saveat import MAX_STEPS, check_steps


@dataclass
class Batch:
    """Every trajectory's inputs as arrays with a leading trajectory axis."""

    q0: np.ndarray  # (B, n)
    p0: np.ndarray  # (B, n)
    h: np.ndarray  # (B,)
    n_steps: np.ndarray  # (B,) int64
    #: the method's numbers per trajectory, (B, n) each, keyed by the core's row names
    #: (``_native.METHOD_ROWS``), in the user's coordinate order
    methods: dict[str, np.ndarray]

    def __len__(self) -> int:
        return self.h.size

    def __getattr__(self, name: str) -> np.ndarray:
        """A method row by its name, e.g. ``batch.chi``."""
        methods = self.__dict__.get("methods", {})
        if name in methods:
            return methods[name]
        raise AttributeError(f"Batch has no attribute {name!r}")

    def rows(self, sel: slice) -> dict:
        """The inputs of trajectories `sel`, as the chunk runner takes them."""
        arrays = {"q0": self.q0, "p0": self.p0, "h": self.h, "n_steps": self.n_steps, **self.methods}
        return {k: np.ascontiguousarray(v[sel]) for k, v in arrays.items()}


def _batched(x, name: str, n: int) -> np.ndarray:
    if np.iscomplexobj(x):
        raise TypeError(f"{name}: complex values are not allowed; the state is real")
    try:
        a = np.asarray(x, dtype=float)
    except OverflowError:
        raise ValueError(f"{name}: a value is too large for a double (at most about 1.8e308 in magnitude)") from None
    except (TypeError, ValueError):
        raise TypeError(f"{name}: expected an array of shape (n,) or (B, n) with n = {n}") from None
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != n:
        raise ValueError(f"{name}: expected shape ({n},) or (B, {n}), got {np.shape(x)}")
    if a.shape[0] == 0:
        raise ValueError(f"{name}: the batch is empty")
    bad = ~np.isfinite(a)
    if bad.any():
        t, i = np.argwhere(bad)[0]
        raise ValueError(f"{name}: trajectory {t}, entry {i} is not finite ({a[t, i]})")
    return a


def prepare(problem: OscillatoryProblem, method: Method, q0, p0, h, t_end, n_steps, form: str = "two-step") -> Batch:
    """Validates and broadcasts the inputs and evaluates every trajectory's coefficients (for
    the two-step or the one-step form: they differ only where χ(hω̃) = 0)."""
    n = problem.dim
    q0 = _batched(problem.as_state(q0, "q0"), "q0", n)
    p0 = _batched(problem.as_state(p0, "p0"), "p0", n)
    if np.iscomplexobj(h) or isinstance(h, bool | str):
        raise TypeError(f"h: expected a positive number or an array of them, got {h!r}")
    try:
        h_arr = np.asarray(h, dtype=float).reshape(-1) if np.ndim(h) else np.asarray([h], dtype=float)
    except OverflowError:
        raise ValueError("h: a step size is too large for a double (at most about 1.8e308 in magnitude)") from None
    except (TypeError, ValueError):
        raise TypeError(f"h: expected a positive number or an array of them, got {h!r}") from None
    if np.ndim(h) > 1:
        raise ValueError(f"h: expected a scalar or shape (B,), got shape {np.shape(h)}")
    if h_arr.size == 0:
        raise ValueError("h: the batch is empty")
    sizes = {name: a.shape[0] for name, a in (("q0", q0), ("p0", p0), ("h", h_arr)) if a.shape[0] != 1}
    if len(set(sizes.values())) > 1:
        raise ValueError(f"q0, p0, h: batch sizes differ: {sizes}; give (B, n), (B, n) and (B,) or broadcast")
    count = max([1, *sizes.values()])
    q0 = np.broadcast_to(q0, (count, n)).copy()
    p0 = np.broadcast_to(p0, (count, n)).copy()
    h_arr = np.broadcast_to(h_arr, (count,)).copy()
    bad = np.flatnonzero(~np.isfinite(h_arr) | (h_arr <= 0))
    if bad.size:
        raise ValueError(f"h: trajectory {bad[0]} has step size {h_arr[bad[0]]}; step sizes must be finite and > 0")
    if (t_end is None) == (n_steps is None):
        raise ValueError("t_end, n_steps: give exactly one of them")
    if n_steps is not None:
        if not _check.is_integer(n_steps):
            raise _check.IntegerTypeError(f"n_steps: must be an integer >= 1, got {n_steps!r}")
        if n_steps < 1:
            raise ValueError(f"n_steps: must be an integer >= 1, got {n_steps!r}")
        steps = np.full(count, check_steps(int(n_steps), "n_steps"), dtype=np.int64)
    else:
        t_end = _check.number(t_end, "t_end")
        if not np.isfinite(t_end) or t_end <= 0:
            raise ValueError(f"t_end: must be finite and > 0, got {t_end}")
        ratio = t_end / h_arr
        if np.any(ratio > MAX_STEPS):
            t = int(np.argmax(ratio))
            raise ValueError(f"t_end: {t_end:g} is {ratio[t]:.3g} steps for trajectory {t} (h = {h_arr[t]:g}); "
                             f"at most 2**53 = {MAX_STEPS:.3g} steps are allowed")
        steps = np.rint(ratio).astype(np.int64)
        short = np.flatnonzero(steps < 1)
        if short.size:
            raise ValueError(f"t_end: shorter than half a step for trajectory {short[0]} (h = {h_arr[short[0]]})")
    methods = problem.stepper.coefficient_rows(problem, method, h_arr, form)
    return Batch(q0=q0, p0=p0, h=h_arr, n_steps=steps, methods=methods)


def core_arguments(problem: OscillatoryProblem, method: Method) -> tuple:
    """What every chunk of a problem's batch needs, first of all its stepper
    (``trigint._steppers``): then the potential built in the core's coordinates (once per problem;
    it pickles as its description), the layout's description, and the layout that maps states to
    and from them (None if the core's coordinates are the user's)."""
    return (problem.stepper, *problem.stepper.core_arguments(problem, method))
