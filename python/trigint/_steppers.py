"""How a problem's steps are taken, as an object the problem carries (``problem.stepper``): the
two-step recursion on the problem's frequencies (every instruction-set copy and lane loop of
the core), or the Krylov step of a large sparse stiffness matrix, whose frequencies are never
computed. ``integrate``, ``ensemble``, ``energies`` and the stores ask the stepper; none of them
branches on the kind of problem.

A new kind of step is a class with these methods and a problem that carries it.
"""

from __future__ import annotations

import numpy as np

from . import _core, _krylov, _native
from ._deviation import RENORMALIZE_EVERY, default_deviation


class Recursion:
    """The two-step recursion (2.5) with the method's coefficients at the problem's frequencies."""

    #: the frequencies and eigenvectors exist (modified energies, resonance checks, per-block energies)
    has_spectrum = True

    def coefficient_rows(self, problem, method, h: np.ndarray, form: str = "two-step") -> dict:
        """The core's coefficient rows for trajectories with step sizes `h` (shape (B,)) in
        `form`: each distinct step size evaluated once, elementwise over (step size, coordinate)."""
        distinct, which = np.unique(h, return_inverse=True)
        try:
            d, n = distinct.size, problem.omega.size
            co = method.pointwise(np.repeat(distinct, n), np.tile(problem.omega, d), form=form)
            rows = _native.method_rows(co, np.tile(problem.omega > 0, d))
            table = {k: v.reshape(d, n) for k, v in rows.items()}
        except ValueError:
            # Say which trajectory's step size fails, with the method's own message.
            for t, ht in enumerate(h):
                try:
                    method.coefficients(float(ht), problem.omega, form)
                except ValueError as exc:
                    raise ValueError(f"trajectory {t} (h = {float(ht)!r}): {exc}") from None
            raise
        return {k: table[k][which] for k in _native.METHOD_ROWS}

    def core_arguments(self, problem, method) -> tuple:
        """What every chunk of an ensemble needs: the potential built in the core's coordinates,
        the layout's description, and the map back to the user's coordinates (None if the
        core's coordinates are the user's)."""
        lay = _native.core_layout(problem)
        order = None if lay.identity else lay
        return _native.problem_potential(problem, lay), lay.spec, order

    def run_chunk(self, potential_spec, layout_spec: dict, order, rows: dict, save_every, track: bool,
                  threads, form: str):
        """Runs one chunk of trajectories in the core; states back in the user's coordinates."""

        def state_to_core(x):
            return np.ascontiguousarray(x if order is None else order.to_core(x))

        def rows_to_core(x):
            return np.ascontiguousarray(x if order is None else order.rows_to_core(x))

        methods = {k: rows_to_core(np.asarray(rows[k], dtype=float)) for k in _native.METHOD_ROWS}
        methods["h"] = np.ascontiguousarray(rows["h"], dtype=float)
        out = _native.integrate_batch(
            potential_spec, layout_spec, methods, state_to_core(rows["q0"]), state_to_core(rows["p0"]),
            rows["n_steps"], save_every, form, track, threads,
        )
        if order is not None and out.samples is not None:
            for s, q0, p0 in zip(out.samples, np.atleast_2d(rows["q0"]), np.atleast_2d(rows["p0"]), strict=True):
                s["q"] = order.samples_to_user(s["steps"], s["q"], q0)
                s["p"] = order.samples_to_user(s["steps"], s["p"], p0)
        return out

    def run_one(self, problem, method, co, h: float, q0, p0, n_steps: int, save_every: int, form: str,
                track: bool, every: int, callback):
        """One trajectory in the core, with the coefficients `co` evaluated by ``integrate``."""
        return _native.integrate(problem, co, q0, p0, n_steps, save_every, form, track, every, callback)

    def store_matrix(self, problem) -> dict:
        """What identifies the stiffness in a store's fingerprint."""
        return {} if problem.stiffness is None else {"stiffness": problem.stiffness}

    def state_energies(self, problem, q, p, method, h) -> dict:
        """The energy channels of each row of q, p (m × n, user coordinates), by name, as a run
        observes its initial state (``_core.state_energies``); the modified energy of `method`
        at step size `h` only when they are given (NaN where its σ is undefined)."""
        lay = _native.core_layout(problem)
        potential = _native.problem_potential(problem, lay)
        modified = None
        if method is not None:
            co = method.coefficients(h, problem.omega)
            fast = problem.omega > 0
            modified = tuple(lay.rows_to_core(np.where(fast, getattr(co, k), 0.0).astype(float))
                             for k in ("modified_p", "modified_q"))
        rows = _core.state_energies(potential, lay.spec, np.ascontiguousarray(lay.to_core(q), dtype=float),
                                    np.ascontiguousarray(lay.to_core(p), dtype=float), modified)
        names = _native.channel_names(problem.n_blocks, problem.n_axes)
        return {name: rows[:, k] for k, name in enumerate(names)
                if method is not None or name != "modified_oscillatory"}

    def tangent(self, problem, method, co, h: float, potential, q0, p0, dq0, dp0, n_steps: int,
                renormalize_every: int, sample_every: int, every: int, callback) -> dict:
        """One trajectory with deviation vectors (rows of dq0, dp0) carried by the tangent step
        of the two-step recursion (``_core.tangent``), with the coefficients `co` (two-step form);
        `potential` the built potential in the core's coordinates, or None for the problem's.
        Everything in and out in the user's coordinates."""
        lay = _native.core_layout(problem)
        if potential is None:
            potential = _native.problem_potential(problem, lay)
        order = None if lay.identity else lay
        return _recursion_tangent(potential, lay.spec, order, _native.core_method(problem, co, lay),
                                  q0, p0, dq0, dp0, n_steps, renormalize_every, sample_every, every, callback)

    def tangent_chunk(self, potential_spec, layout_spec: dict, order, rows: dict, count: int, threads) -> tuple:
        """The leading `count` exponents and the MEGNO of each trajectory of a chunk, each as
        ``trigint.lyapunov`` computes it alone (default deviation, renormalized every 16 steps):
        one call of the core, which runs the FPU chain's trajectories in bundles of lanes and
        the others one by one, the same numbers either way."""
        methods = {k: _rows_to_core(order, np.asarray(rows[k], dtype=float)) for k in _native.METHOD_ROWS}
        methods["h"] = np.ascontiguousarray(rows["h"], dtype=float)
        n = rows["q0"].shape[1]
        dq0, dp0 = default_deviation(n, count)
        core = _to_core(order)
        out = _core.tangent_batch(potential_spec, layout_spec, methods, core(rows["q0"]), core(rows["p0"]),
                                  [int(s) for s in rows["n_steps"]], core(dq0), core(dp0), _metric(order, n),
                                  RENORMALIZE_EVERY, threads)
        if out["interrupted"]:
            raise KeyboardInterrupt
        return _exponents_at_end(out["steps"], out["log_growth"], out["megno"], rows["h"])

    def tangent_potential(self, problem, finite_differences: bool):
        """A Python potential built to difference its gradient (the other kinds: None, the usual).
        A potential that knows it has no second derivative says so in its own terms (a wave's
        (V, V') pair: what the wave's user can give), before the run."""
        missing = getattr(problem.potential, "no_second_derivative", None)
        if missing is not None and not finite_differences:
            raise ValueError(missing)
        spec = _native.potential_spec(problem.potential, _native.core_layout(problem))
        return _core.Potential({**spec, "finite_differences": True}) if finite_differences else None


class Krylov:
    """The one-step form with the matrix functions of h√A applied by the Lanczos method in the
    core (:mod:`trigint._krylov`): no frequencies, no eigenvectors."""

    has_spectrum = False

    def coefficient_rows(self, problem, method, h: np.ndarray, form: str = "two-step") -> dict:
        """None needed: the core evaluates the method at the Ritz values (one-step form)."""
        return {}

    def core_arguments(self, problem, method) -> tuple:
        """The potential built once, the sparse matrix by its arrays with the method, no map."""
        spec = {**_krylov.stiffness_spec(problem), "method": method}
        return _native.built_potential(problem.potential, problem.dim), spec, None

    def run_chunk(self, potential_spec, layout_spec: dict, order, rows: dict, save_every, track: bool,
                  threads, form: str):
        """Runs one chunk of trajectories on the Krylov path in the core."""
        return _krylov.run(potential_spec, layout_spec, layout_spec["method"], rows["h"], rows["q0"], rows["p0"],
                           rows["n_steps"], save_every, track, threads)

    def run_one(self, problem, method, co, h: float, q0, p0, n_steps: int, save_every: int, form: str,
                track: bool, every: int, callback):
        """One trajectory on the Krylov path (the one-step form whatever `form` says)."""
        return _krylov.integrate(problem, method, q0, p0, h, n_steps, save_every, track, callback)

    def store_matrix(self, problem) -> dict:
        """The sparse matrix by its arrays, and the stopping rule."""
        a = problem.stiffness
        return {"stiffness_indptr": a.indptr, "stiffness_indices": a.indices, "stiffness_data": a.data,
                "krylov_tolerance": problem.krylov_tolerance}

    def tangent(self, problem, method, co, h: float, potential, q0, p0, dq0, dp0, n_steps: int,
                renormalize_every: int, sample_every: int, every: int, callback) -> dict:
        """The tangent step of the one-step form with the Lanczos products (``_core.tangent_krylov``),
        in the user's coordinates (the only ones here)."""
        spec = _krylov.stiffness_spec(problem)
        if potential is None:
            potential = _native.built_potential(problem.potential, problem.dim)
        return _core.tangent_krylov(
            potential, spec["n"], spec["indptr"], spec["indices"], spec["data"], _krylov.method_spec(method, h),
            spec["tol"], _krylov.MAX_ITERATIONS, np.ascontiguousarray(q0), np.ascontiguousarray(p0),
            np.ascontiguousarray(dq0), np.ascontiguousarray(dp0), np.ones(problem.dim), int(n_steps),
            int(renormalize_every), int(sample_every), int(every), callback,
        )

    def tangent_chunk(self, potential_spec, layout_spec: dict, order, rows: dict, count: int, threads) -> tuple:
        """The leading exponents and the MEGNO of each trajectory of a chunk (see Recursion)."""
        def one(b):
            dq0, dp0 = default_deviation(rows["q0"].shape[1], count)
            h = float(rows["h"][b])
            return _core.tangent_krylov(
                potential_spec, layout_spec["n"], layout_spec["indptr"], layout_spec["indices"], layout_spec["data"],
                _krylov.method_spec(layout_spec["method"], h), layout_spec["tol"], _krylov.MAX_ITERATIONS,
                np.ascontiguousarray(rows["q0"][b]), np.ascontiguousarray(rows["p0"][b]), dq0, dp0,
                np.ones(rows["q0"].shape[1]), int(rows["n_steps"][b]), RENORMALIZE_EVERY, int(rows["n_steps"][b]),
                64, None,
            )

        return _exponents(one, rows, threads)

    def tangent_potential(self, problem, finite_differences: bool):
        """A Python potential built to difference its gradient (the other kinds: None, the usual)."""
        spec = problem.potential.describe(problem.dim)
        return _core.Potential({**spec, "finite_differences": True}) if finite_differences else None

    def state_energies(self, problem, q, p, method, h) -> dict:
        """The channels of each row of q, p as the Krylov path's runs stream them (no modified
        energy: it needs the frequencies)."""
        if method is not None:
            raise ValueError("method, h: the modified oscillatory energy needs the frequencies, which the Krylov "
                             "path does not compute; leave them out")
        rows = _krylov.energies(problem, q, p)
        return {name: rows[:, k] for k, name in enumerate(_native.channel_names(1))
                if name != "modified_oscillatory"}


RECURSION = Recursion()
KRYLOV = Krylov()



def _rows_to_core(order, x):
    return np.ascontiguousarray(x if order is None else order.rows_to_core(x))


def _to_core(order):
    """States (or rows of states) from the user's coordinates to the core's."""
    def core(x):
        return np.ascontiguousarray(x if order is None else order.to_core(np.asarray(x, dtype=float)))

    return core


def _metric(order, n: int) -> np.ndarray:
    """The core's metric that reproduces the user's Euclidean norm: the maps are orthogonal (a
    permutation, a modal basis) or the Fourier map, SᵀS = N·I."""
    scale = 1.0
    if order is not None and order.map.kind == "fourier":
        unit = np.zeros((1, n))
        unit[0, 0] = 1.0
        scale = float(np.sum(order.to_user(unit) ** 2))
    return np.full(n, scale)


def _recursion_tangent(potential, layout_spec: dict, order, method: dict, q0, p0, dq0, dp0, n_steps: int,
                       renormalize_every: int, sample_every: int, every: int, callback) -> dict:
    """``_core.tangent`` with states and deviations in the user's coordinates (`order` the map to
    the core's, None when they are the same), whose Euclidean norm the core's metric reproduces:
    the maps are orthogonal (a permutation, a modal basis) or the Fourier map, SᵀS = N·I."""
    core, n = _to_core(order), np.asarray(q0).shape[-1]
    out = _core.tangent(potential, layout_spec, method, core(q0), core(p0), core(dq0), core(dp0), _metric(order, n),
                        int(n_steps), int(renormalize_every), int(sample_every), int(every), callback)
    if order is not None:
        for key in ("q", "p", "dq", "dp"):
            out[key] = order.to_user(np.asarray(out[key]))
    return out


def _exponents(one, rows: dict, threads) -> tuple:
    """(exponents (B, K), MEGNO (B,)) of a chunk's trajectories, `one(b)` the core's tangent run
    of trajectory b, on `threads` threads (the core leaves the interpreter while it steps): the
    exponents at the last step, as ``lyapunov()`` gives them."""
    import os
    from concurrent.futures import ThreadPoolExecutor

    count = len(rows["h"])
    workers = max(1, min(count, (os.cpu_count() or 1) if threads is None else int(threads)))
    with ThreadPoolExecutor(max_workers=workers) as pool:
        outs = list(pool.map(one, range(count)))
    k = np.asarray(outs[0]["log_growth"]).shape[1] if outs else 0
    last = [(int(o["steps"][-1]), np.asarray(o["log_growth"])[-1], float(o["megno"][-1])) if len(o["steps"])
            else (0, np.full(k, np.nan), np.nan) for o in outs]
    return _exponents_at_end(np.array([s for s, _, _ in last], dtype=np.int64),
                             np.array([g for _, g, _ in last]).reshape(len(outs), k),
                             np.array([y for _, _, y in last]), rows["h"])


def _exponents_at_end(steps, log_growth, megno, h) -> tuple:
    """(exponents (B, K), MEGNO (B,)) from each trajectory's last sample: its step (0: none, then
    NaN), Σ ln R_jj there and ⟨Y⟩ there, with step sizes `h`."""
    steps = np.asarray(steps, dtype=np.int64)
    t = steps * np.asarray(h, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        exponents = np.asarray(log_growth, dtype=float) / t[:, None]
    exponents[steps == 0] = np.nan
    megno = np.where(steps == 0, np.nan, np.asarray(megno, dtype=float))
    return exponents, megno


def run_chunk(stepper, potential_spec, layout_spec: dict, order, rows: dict, save_every: int | None, track: bool,
              threads: int | None = None, form: str = "two-step", lyapunov: int | None = None):
    """Runs one chunk of an ensemble with `stepper`. Module-level and free of local state, so that
    it can be sent to executors and Dask workers. States come back in the user's coordinates.
    With `lyapunov`, ``out.info`` also holds each trajectory's leading exponents ("lyapunov") and
    MEGNO ("megno"), unless the chunk was interrupted."""
    out = stepper.run_chunk(potential_spec, layout_spec, order, rows, save_every, track, threads, form)
    if lyapunov is not None and not out.interrupted:
        out.info["lyapunov"], out.info["megno"] = stepper.tangent_chunk(potential_spec, layout_spec, order, rows,
                                                                        int(lyapunov), threads)
    return out
