"""The one importer of the compiled core: packs problems, methods and potentials into the typed
dictionaries `trigint._core` takes, and unpacks its results.

The core runs in its own coordinates: slow coordinates first, then each oscillatory block
contiguous (stable within a block). For a diagonal Ω these are the user's coordinates permuted;
for a stiffness matrix A = QΛQᵀ they are the modal coordinates x = Qᵀq; for a wave equation the
real Fourier coordinates of the grid values. Users never see them: the core's coordinate map
(``_core.CoordinateMap``) transforms states on the way in and back on the way out, and
potentials are given their inputs in the user's coordinates (the map composed into their input
maps).
"""

from __future__ import annotations

import functools
import weakref
from dataclasses import dataclass

import numpy as np

from . import _core

#: the rows of a method's numbers, in the order of the core's table (``_core.METHOD_ROWS``)
METHOD_ROWS: tuple[str, ...] = tuple(_core.METHOD_ROWS)


#: the Krylov path's matrix functions, in the order of the core's table (``_core.KRYLOV_FUNCTIONS``)
KRYLOV_FUNCTIONS: tuple[str, ...] = tuple(_core.KRYLOV_FUNCTIONS)

#: the named filters the Krylov path has in closed form in the core (``_core.KRYLOV_FILTERS``); any
#: other method, a named filter added in Python included, gives the core its functions to evaluate
KRYLOV_FILTERS: tuple[str, ...] = tuple(_core.KRYLOV_FILTERS)


def channel_names(n_blocks: int, n_axes: int = 0) -> list[str]:
    """The energy channels' names in output order for ℓ = n_blocks oscillatory blocks and
    `n_axes` per-axis channels."""
    return list(_channel_names(int(n_blocks), int(n_axes)))


@functools.lru_cache(maxsize=32)
def _channel_names(n_blocks: int, n_axes: int) -> tuple[str, ...]:
    # A wave problem has a channel per mode: tens of thousands of names, made once.
    return tuple(_core.channels(n_blocks, n_axes))


def channel_index(n_blocks: int, n_axes: int = 0) -> tuple[tuple[str, ...], dict[str, int]]:
    """The channels' names in output order and each name's position (made once per count)."""
    return _channel_index(int(n_blocks), int(n_axes))


@functools.lru_cache(maxsize=32)
def _channel_index(n_blocks: int, n_axes: int) -> tuple[tuple[str, ...], dict[str, int]]:
    names = _channel_names(n_blocks, n_axes)
    return names, {name: k for k, name in enumerate(names)}


@dataclass(frozen=True)
class CoreLayout:
    """A problem's arrangement in the core's coordinates and the one map to and from them
    (``_core.CoordinateMap``: the identity, a permutation for a diagonal Ω, the modal basis Q of
    a stiffness matrix, or a wave equation's Fourier coordinates), applied by the core."""

    #: the arrangement as the core takes it, converted once (``_core.Layout``; ``.spec`` is its
    #: description)
    spec: object
    #: ``_core.CoordinateMap``: user coordinates → the core's and back
    map: object
    #: core coordinate k is user coordinate perm[k] (the identity unless the map permutes)
    perm: np.ndarray
    #: user coordinate i is core coordinate inverse[i]
    inverse: np.ndarray

    @property
    def identity(self) -> bool:
        return self.map.is_identity

    # (the identity hands the array back, as it comes, rather than copying it through the core)

    def to_core(self, x: np.ndarray) -> np.ndarray:
        """User coordinates → core coordinates along the last axis."""
        x = np.asarray(x, dtype=float)
        return x if self.map.is_identity else self.map.to_core(x)

    def state_to_core(self, x: np.ndarray) -> np.ndarray:
        """A run's initial state (one row) in the core's coordinates, as :meth:`to_core`. On a
        wave grid a state at rest (every entry +0.0: u_t = 0, as waves often start) is the kept
        image of zero, the same bits without a transform (0.1 ms on 2¹⁶ points)."""
        x = np.asarray(x, dtype=float)
        # (the bits, not the values: a −0.0 entry may give other signs of zero through the FFT)
        if self.map.kind == "fourier" and x.ndim == 1 and not x.view(np.int64).any():
            return self._zero_image
        return self.to_core(x)

    @functools.cached_property
    def _zero_image(self) -> np.ndarray:
        """to_core of the zero state, made once (read-only)."""
        z = self.map.to_core(np.zeros(self.map.dim))
        z.flags.writeable = False
        return z

    def to_user(self, x: np.ndarray) -> np.ndarray:
        """Core coordinates → user coordinates along the last axis."""
        x = np.asarray(x, dtype=float)
        return x if self.map.is_identity else self.map.to_user(x)

    def samples_to_user(self, steps: np.ndarray, x: np.ndarray, x0: np.ndarray,
                        done: np.ndarray | None = None) -> np.ndarray:
        """A trajectory's samples (rows, core coordinates) in the user's coordinates. The sample
        of step 0 is the state the run started from, so it is `x0` as the user gave it (user
        coordinates): no transform back, whose result would differ from it by rounding and, on
        a large wave grid, cost as much as a step. Rows r with ``done[r]`` are in the user's
        coordinates already (a wave's q taken from the force evaluation's grid values)."""
        x = np.asarray(x, dtype=float)
        if self.map.is_identity:
            return x
        # (into x itself, the core's fresh array, row by row: a new array of the samples' size
        # would be mapped page by page, and double the memory they take)
        given = len(steps) > 0 and int(steps[0]) == 0
        done = None if done is None or not np.any(done) else np.asarray(done, dtype=bool)
        if not (x.flags.c_contiguous and x.flags.writeable):
            x = np.array(x, order="C")
        if len(x) > int(given):
            self.map.to_user_in_place(x, int(given), done)
        if given:
            x[0] = x0
        return x

    def rows_to_core(self, x: np.ndarray) -> np.ndarray:
        """Per-coordinate numbers (a method's rows, listed like the problem's frequencies) in
        the core's order: only a permutation moves them."""
        x = np.asarray(x, dtype=float)
        return x if self.map.is_identity else self.map.numbers_to_core(x)


def evaluator(spec: dict):
    """A potential compiled once for many evaluations: ``.evaluate(x)`` of x of shape (m, n)
    returns (U at each row, −∇U at each row)."""
    return _core.Potential(spec)


#: built potentials (``_core.Potential``: tape compiled, FFTs planned), one per owner (a
#: potential, or a problem whose layout maps the potential's inputs), with the key they were
#: built for
_BUILT: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
#: how often each potential has changed (ChainPotential.add): a built one of an older version
#: is rebuilt
_VERSIONS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _built(owner, key, spec):
    entry = _BUILT.get(owner)
    if entry is not None and entry[0] == key:
        return entry[1]
    handle = _core.Potential(spec())
    _BUILT[owner] = (key, handle)
    return handle


def changed(potential) -> None:
    """Says that `potential` has changed: what was built from it is built again when next used."""
    _VERSIONS[potential] = _VERSIONS.get(potential, 0) + 1
    _BUILT.pop(potential, None)


def built_potential(potential, n: int):
    """The potential on n coordinates (its own order), built once and kept while it lives."""
    return _built(potential, (n, _VERSIONS.get(potential, 0)), lambda: potential.describe(n))


def problem_potential(problem, lay: CoreLayout):
    """A problem's potential in the core's coordinates (maps composed), built once per problem."""
    key = (_VERSIONS.get(problem.potential, 0), id(problem.potential))
    return _built(problem, key, lambda: potential_spec(problem.potential, lay))


def core_layout(problem) -> CoreLayout:
    """The problem's arrangement in the core's coordinates, made once and kept on the problem
    (a problem's frequencies and blocks never change; building it for a 2¹⁶-point wave took
    1.4 ms a call)."""
    kept = problem.__dict__.get("_core_layout")
    if kept is None:
        kept = problem.__dict__["_core_layout"] = _core_layout(problem)
    return kept


def _core_layout(problem) -> CoreLayout:
    blocks = np.asarray(problem.blocks)
    perm = np.argsort(blocks, kind="stable")
    inverse = np.empty_like(perm)
    inverse[perm] = np.arange(perm.size)
    sorted_blocks = blocks[perm]
    n_slow = int(np.count_nonzero(sorted_blocks == 0))
    # block j ends after its last coordinate (the labels are sorted): O(n log n), not O(ℓ n)
    ends = np.searchsorted(sorted_blocks, np.arange(1, problem.n_blocks + 1), side="right").tolist()
    spec = _core.Layout({
        "omega2": np.ascontiguousarray(problem.omega[perm] ** 2),
        "n_slow": n_slow,
        "block_ends": ends,
        # a bilinear invariant in the core's coordinates (a wave equation's momentum), or None
        "pair_forms": problem.pair_forms,
    })
    # a stiffness matrix's modal coordinates and a wave equation's Fourier coordinates come
    # ordered (slow first, block by block): the map is the basis or the problem's own
    if problem.coordinate_map is not None:
        cmap = problem.coordinate_map
    elif problem.basis is not None:
        cmap = _core.CoordinateMap.modal(np.ascontiguousarray(problem.basis, dtype=float))
    else:
        cmap = _core.CoordinateMap.permuted(perm.astype(np.int64))
    return CoreLayout(spec, cmap, perm, inverse)


def method_rows(co, fast: np.ndarray) -> dict:
    """The per-coordinate numbers of one method (user order) as the core takes them.

    ψ/χ and sin²(hω̃)/(hχ) are the one-step form's numbers (with their limits where χ = 0)."""
    rows = {k: np.asarray(getattr(co, k), dtype=float) for k in METHOD_ROWS}
    # NaN where σ is undefined: the core sums 0 there and the caller reports NaN
    for k in ("modified_p", "modified_q"):
        rows[k] = np.where(fast & np.isfinite(rows[k]), rows[k], 0.0)
    return rows


def method_spec(co, lay: CoreLayout, fast: np.ndarray) -> dict:
    rows = method_rows(co, fast)
    spec = {k: lay.rows_to_core(v) for k, v in rows.items()}
    spec["h"] = float(co.h)
    return spec


#: objects kept per problem and kind (method coefficients, converted methods), for repeated calls
KEPT_PER_PROBLEM = 4


def kept_on(problem, kind: str, key, owner, make):
    """``make()``, kept on `problem` under `kind` for the next call with the same `key`, as long
    as `owner` (an object the key names by ``id``) is the same object; `owner` is kept alive with
    it, so that its id is not reused. At most :data:`KEPT_PER_PROBLEM` per kind, the oldest
    dropped first. (A problem's frequencies never change, so what is made from them stays valid.)"""
    kept = problem.__dict__.setdefault(kind, {})
    hit = kept.get(key)
    if hit is not None and hit[0] is owner:
        return hit[1]
    made = make()
    if len(kept) >= KEPT_PER_PROBLEM:
        kept.pop(next(iter(kept)))
    kept[key] = (owner, made)
    return made


def core_method(problem, co, lay: CoreLayout):
    """The core's form of the coefficients `co` (``_core.Method``: the rows in the core's order,
    converted once), kept on the problem for the next call with the same coefficient object."""
    return kept_on(problem, "_core_methods", id(co), co,
                   lambda: _core.Method(method_spec(co, lay, problem.omega > 0)))


def potential_spec(potential, lay: CoreLayout) -> dict:
    """The potential's description, with its inputs taken from the core's coordinates: each
    input map M of the user's coordinates composed by the core into M∘(to_user), a Python
    callable given the user's coordinates. A wave equation's potentials are written in its
    Fourier coordinates (the core's), and a potential whose own coordinates are the modal ones
    (Q is the T of its `own_coordinates()`) runs with no map."""
    cmap = lay.map
    spec = potential.describe(cmap.dim)
    if cmap.kind in ("identity", "fourier"):
        return spec
    if cmap.kind == "modal":
        own = potential.own_coordinates()
        basis = cmap.basis
        if own is not None and own[0].shape == basis.shape and np.array_equal(own[0], basis):
            return own[1]
    return _mapped_spec(spec, lay, potential)


def _mapped_spec(spec: dict, lay: CoreLayout, potential) -> dict:
    cmap, kind = lay.map, spec["kind"]
    if kind in ("fpu", "program") and spec.get("map") is None and cmap.kind == "permuted":
        # no map to rename: an FPU chain runs as its program, a program reads its inputs renamed
        if kind == "fpu":
            return _mapped_spec(potential.program_description(), lay, potential)
        return {**spec, "ops": [("input", int(lay.inverse[op[1]])) if op[0] == "input" else op for op in spec["ops"]]}
    if kind in ("fpu", "program"):
        return {**spec, "map": cmap.compose(spec.get("map"), spec["m"] * 2 if kind == "fpu" else spec["n"])}
    if kind == "chain":
        return {**spec, "terms": [{**t, "map": cmap.compose(t["map"], t["map"]["rows"])} for t in spec["terms"]]}
    if kind == "python":
        # the maps are orthogonal: a force goes back as a state does
        value, gradient, hvp = spec["value"], spec["gradient"], spec.get("hessian_vector")

        def value_core(x):
            return value(lay.to_user(x))

        def gradient_core(x):
            return lay.to_core(gradient(lay.to_user(x)))

        def hessian_vector_core(x, v):
            return lay.to_core(hvp(lay.to_user(x), lay.to_user(v)))

        return {**spec, "value": value_core, "gradient": gradient_core,
                "hessian_vector": None if hvp is None else hessian_vector_core}
    where = ("in modal coordinates (a stiffness matrix)" if cmap.kind == "modal" else
             "with its coordinates reordered (slow ones first, then block by block)")
    raise ValueError(_unmapped(kind, where))


def _unmapped(kind: str, where: str) -> str:
    """Why a native kind without a coordinate map cannot run in the core's coordinates."""
    return (f"a potential of kind {kind!r} reads no coordinate map, so it runs only on a problem whose core "
            f"coordinates are the user's; this problem runs {where}. Kinds that take a map: fpu, program, "
            "chain, python")


def integrate(problem, co, q0, p0, n_steps, save_every, form, track, every, callback):
    """Runs one trajectory; returns the core's RunResult with states in the user's order."""
    lay = core_layout(problem)
    out = _core.integrate(
        problem_potential(problem, lay), lay.spec, core_method(problem, co, lay),
        lay.state_to_core(q0), lay.state_to_core(p0), int(n_steps), int(save_every), form, bool(track),
        int(every), callback, q_from_grid=lay.map.kind == "fourier",
    )
    s = out.samples[0]
    # (a wave's q samples come as the force evaluation's grid values where it had them: the
    # same bits as the transform back, which on 2¹⁶ points costs a third of a step per sample)
    s["q"] = lay.samples_to_user(s["steps"], s["q"], q0, s.pop("q_in_user"))
    s["p"] = lay.samples_to_user(s["steps"], s["p"], p0)
    return out


def integrate_batch(potential_core, layout_spec: dict, methods: dict, q0, p0, n_steps,
                    save_every, form, track, threads):
    """Runs a batch whose inputs are already in the core's order (see :func:`core_layout`);
    `potential_core` is a built potential (:func:`problem_potential`) or its description.
    Returns the core's RunResult."""
    return _core.integrate_batch(
        potential_core, layout_spec, methods, np.ascontiguousarray(q0, dtype=float),
        np.ascontiguousarray(p0, dtype=float), [int(s) for s in n_steps], save_every, form,
        bool(track), threads,
    )


def integrate_krylov(potential_core, spec: dict, methods: list[dict], max_iterations: int, q0, p0, n_steps,
                     save_every, track, threads=None, callback=None):
    """Runs the rows of q0, p0 on the Krylov path in the core: `spec` the CSR arrays and the
    tolerance (:func:`trigint._krylov.stiffness_spec`), `methods` one dict per trajectory
    (:func:`trigint._krylov.method_spec`). Returns the core's RunResult."""
    return _core.integrate_krylov(
        potential_core, spec["n"], spec["indptr"], spec["indices"], spec["data"], methods, spec["tol"],
        int(max_iterations), np.ascontiguousarray(q0, dtype=float), np.ascontiguousarray(p0, dtype=float),
        [int(s) for s in n_steps], None if save_every is None else int(save_every), bool(track), threads,
        64, callback,
    )


def evaluate(potential, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(U, −∇U) at the rows of x (the potential's own order), the potential built once."""
    x = np.ascontiguousarray(x, dtype=float)
    return built_potential(potential, x.shape[1]).evaluate(x)


def instructions(potential, n: int) -> int | None:
    """Builds the potential now (so that a bad one fails here) and returns the instruction count
    of a compiled program's force code."""
    return built_potential(potential, n).instructions()
