"""The one importer of the compiled core: packs problems, methods and potentials into the typed
dictionaries `trigint._core` takes, and unpacks its results.

The core runs in its own coordinate order: slow coordinates first, then each oscillatory block
contiguous (stable within a block). Users never see that order: states are permuted on the way
in and back on the way out, and potentials are given their inputs in the user's order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _core

#: the rows of a method's numbers, in the order the core names them
METHOD_ROWS = ("one_minus_cos", "chi", "psi", "phi", "psi_over_chi", "sin2_over_h_chi",
               "modified_p", "modified_q")


@dataclass(frozen=True)
class CoreLayout:
    """A problem's arrangement in the core's order, with the permutation to and from it."""

    spec: dict
    #: core coordinate k is user coordinate perm[k]
    perm: np.ndarray
    #: user coordinate i is core coordinate inverse[i]
    inverse: np.ndarray
    identity: bool

    def to_core(self, x: np.ndarray) -> np.ndarray:
        """User order → core order along the last axis."""
        return x if self.identity else np.ascontiguousarray(x[..., self.perm])

    def to_user(self, x: np.ndarray) -> np.ndarray:
        """Core order → user order along the last axis."""
        return x if self.identity else np.ascontiguousarray(x[..., self.inverse])


def core_layout(problem) -> CoreLayout:
    blocks = np.asarray(problem.blocks)
    perm = np.argsort(blocks, kind="stable")
    inverse = np.empty_like(perm)
    inverse[perm] = np.arange(perm.size)
    sorted_blocks = blocks[perm]
    n_slow = int(np.count_nonzero(sorted_blocks == 0))
    ends = [int(np.flatnonzero(sorted_blocks == j)[-1]) + 1 for j in range(1, problem.n_blocks + 1)]
    spec = {
        "omega2": np.ascontiguousarray(problem.omega[perm] ** 2),
        "n_slow": n_slow,
        "block_ends": ends,
    }
    return CoreLayout(spec, perm, inverse, bool(np.all(perm == np.arange(perm.size))))


def method_rows(co, fast: np.ndarray) -> dict:
    """The per-coordinate numbers of one method (user order) as the core takes them.

    ψ/χ and sin²(hω̃)/(hχ) are the one-step form's numbers (with their limits where χ = 0)."""
    psi_over_chi, sin2 = co.psi_over_chi, co.sin2_over_h_chi
    rows = {
        "one_minus_cos": co.one_minus_cos, "chi": co.chi, "psi": co.psi, "phi": co.phi,
        "psi_over_chi": psi_over_chi, "sin2_over_h_chi": sin2,
        # NaN where σ is undefined: the core sums 0 there and the caller reports NaN
        "modified_p": np.where(fast & np.isfinite(co.modified_p), co.modified_p, 0.0),
        "modified_q": np.where(fast & np.isfinite(co.modified_q), co.modified_q, 0.0),
    }
    return {k: np.asarray(v, dtype=float) for k, v in rows.items()}


def method_spec(co, lay: CoreLayout, fast: np.ndarray) -> dict:
    rows = method_rows(co, fast)
    spec = {k: np.ascontiguousarray(lay.to_core(v)) for k, v in rows.items()}
    spec["h"] = float(co.h)
    return spec


def potential_spec(potential, lay: CoreLayout) -> dict:
    """The potential's description, with its inputs taken from the core's coordinate order."""
    spec = potential._spec(lay.perm.size)
    return spec if lay.identity else _permute_spec(spec, lay, potential)


def _permute_spec(spec: dict, lay: CoreLayout, potential) -> dict:
    kind = spec["kind"]
    inv = lay.inverse
    if kind == "fpu":
        return _permute_spec(potential._program_spec(), lay, potential)
    if kind == "program":
        out = dict(spec)
        if spec.get("map") is not None:
            out["map"] = _permute_map(spec["map"], inv)
        else:
            out["ops"] = [("input", int(inv[op[1]])) if op[0] == "input" else op for op in spec["ops"]]
        return out
    if kind == "chain":
        return {**spec, "terms": [{**t, "map": _permute_map(t["map"], inv)} for t in spec["terms"]]}
    if kind == "python":
        perm, inverse = lay.perm, lay.inverse
        value, gradient = spec["value"], spec["gradient"]

        def value_core(x):
            return value(x[..., inverse])

        def gradient_core(x):
            return np.asarray(gradient(x[..., inverse]), dtype=float)[..., perm]

        return {**spec, "value": value_core, "gradient": gradient_core}
    raise ValueError(f"unknown potential kind {kind!r}")


def _permute_map(m: dict, inv: np.ndarray) -> dict:
    """A linear map of user coordinates as one of core coordinates: columns renamed."""
    return {**m, "idx": [int(inv[j]) for j in m["idx"]]}


def integrate(problem, co, q0, p0, n_steps, save_every, form, track, every, callback) -> dict:
    """Runs one trajectory; returns the core's dictionary with states in the user's order."""
    lay = core_layout(problem)
    fast = problem.omega > 0
    out = _core.integrate(
        potential_spec(problem.potential, lay), lay.spec, method_spec(co, lay, fast),
        lay.to_core(q0), lay.to_core(p0), int(n_steps), int(save_every), form, bool(track),
        int(every), callback,
    )
    s = out["samples"]
    s["q"], s["p"] = lay.to_user(s["q"]), lay.to_user(s["p"])
    return out


def integrate_batch(potential_spec_core: dict, layout_spec: dict, methods: dict, q0, p0, n_steps,
                    save_every, form, track, threads) -> dict:
    """Runs a batch whose inputs are already in the core's order (see :func:`core_layout`)."""
    return _core.integrate_batch(
        potential_spec_core, layout_spec, methods, np.ascontiguousarray(q0, dtype=float),
        np.ascontiguousarray(p0, dtype=float), [int(s) for s in n_steps], save_every, form,
        bool(track), threads,
    )


def evaluate(spec: dict, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(U, −∇U) at the rows of x (user order: the spec is not permuted)."""
    return _core.evaluate(spec, np.ascontiguousarray(x, dtype=float))


def instructions(spec: dict) -> int | None:
    return _core.instructions(spec)
