"""The ensemble's output table, written once: every array a sweep returns, its dimensions, its
type and the value of a trajectory that has not run. The store (its arrays), the assembly (the
Dataset) and the chunks (a RunResult as rows of the table) all read it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: status names and their codes in the arrays
STATUS_CODES = {"completed": 0, "blow-up": 1, "interrupted": 2}
STATUS_NAMES = {v: k for k, v in STATUS_CODES.items()}


@dataclass(frozen=True)
class Output:
    """One array of a sweep's results, over the trajectories first."""

    name: str
    dims: tuple[str, ...]
    dtype: str
    #: the value of a trajectory not (yet) run
    fill: float | int
    #: kept only when the sweep keeps states (``save_every``)
    per_sample: bool = False
    #: kept only when the sweep computes Lyapunov exponents (``lyapunov=``)
    per_exponent: bool = False


OUTPUTS = (
    Output("max_deviation", ("trajectory", "energy"), "float64", np.nan),
    Output("initial_energies", ("trajectory", "energy"), "float64", np.nan),
    Output("steps_done", ("trajectory",), "int64", 0),
    Output("status", ("trajectory",), "int8", STATUS_CODES["interrupted"]),
    Output("step", ("trajectory", "sample"), "int64", -1, per_sample=True),
    Output("q", ("trajectory", "sample", "coordinate"), "float64", np.nan, per_sample=True),
    Output("p", ("trajectory", "sample", "coordinate"), "float64", np.nan, per_sample=True),
    Output("energies", ("trajectory", "sample", "energy"), "float64", np.nan, per_sample=True),
    Output("lyapunov", ("trajectory", "exponent"), "float64", np.nan, per_exponent=True),
    Output("megno", ("trajectory",), "float64", np.nan, per_exponent=True),
)


def outputs(with_samples: bool, with_exponents: bool = False) -> tuple[Output, ...]:
    """The arrays of a sweep that keeps states (`with_samples`) or only their statistics, and
    with Lyapunov exponents or not."""
    return tuple(o for o in OUTPUTS
                 if (with_samples or not o.per_sample) and (with_exponents or not o.per_exponent))


def shapes(sizes: dict, with_samples: bool) -> dict[str, tuple[tuple[int, ...], str, float | int]]:
    """name → (shape, dtype, fill) for dimension sizes such as ``{"trajectory": 10, ...}`` (with
    an ``"exponent"`` size, the Lyapunov arrays too)."""
    return {o.name: (tuple(sizes[d] for d in o.dims), o.dtype, o.fill)
            for o in outputs(with_samples, "exponent" in sizes)}


def empty(sizes: dict, with_samples: bool) -> dict[str, np.ndarray]:
    """Every array filled with its not-run value."""
    table = shapes(sizes, with_samples)
    return {name: np.full(shape, fill, dtype=dtype) for name, (shape, dtype, fill) in table.items()}


def chunk_rows(out, sizes: dict, with_samples: bool) -> dict[str, np.ndarray]:
    """A chunk's RunResult as rows of the table (samples padded to ``sizes["sample"]``; the
    exponents from its ``info`` when ``sizes`` has an ``"exponent"``)."""
    rows = {
        "max_deviation": np.asarray(out.max_deviation, dtype=float),
        "initial_energies": np.asarray(out.initial_energies, dtype=float),
        "steps_done": np.asarray(out.steps_done, dtype=np.int64),
        "status": np.array([STATUS_CODES[s] for s in out.status], dtype=np.int8),
    }
    if with_samples:
        padded = empty({**sizes, "trajectory": len(out.status)}, True)
        for t, s in enumerate(out.samples):
            k = s["steps"].size
            padded["step"][t, :k] = s["steps"]
            for name in ("q", "p", "energies"):
                padded[name][t, :k] = s[name]
        rows.update({o.name: padded[o.name] for o in OUTPUTS if o.per_sample})
    if "exponent" in sizes:
        rows["lyapunov"] = np.asarray(out.info["lyapunov"], dtype=float).reshape(len(out.status), sizes["exponent"])
        rows["megno"] = np.asarray(out.info["megno"], dtype=float)
    return rows
