"""The one importer of the compiled core: packs problems, methods and potentials into the typed
dictionaries `trigint._core` takes, and unpacks its results.

The core runs in its own coordinates: slow coordinates first, then each oscillatory block
contiguous (stable within a block). For a diagonal Ω these are the user's coordinates permuted;
for a stiffness matrix A = QΛQᵀ they are the modal coordinates x = Qᵀq. Users never see them:
states are transformed on the way in and back on the way out, and potentials are given their
inputs in the user's coordinates (the permutation or Q composed into their input maps).
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
    """A problem's arrangement in the core's coordinates, with the map to and from them: a
    permutation (diagonal Ω) or the orthogonal modal basis Q (stiffness matrix)."""

    #: the arrangement as the core takes it, converted once (``_core.Layout``; ``.spec`` is its
    #: description)
    spec: object
    #: core coordinate k is user coordinate perm[k]
    perm: np.ndarray
    #: user coordinate i is core coordinate inverse[i]
    inverse: np.ndarray
    identity: bool
    #: Q, with q = Q x (None for a diagonal Ω)
    basis: np.ndarray | None = None
    #: a map of the problem's own (``to_core``/``to_user``), e.g. grid values ⇄ Fourier
    #: coordinates of a wave equation; the core's coordinates are then the map's, in order
    transform: object | None = None

    def to_core(self, x: np.ndarray) -> np.ndarray:
        """User coordinates → core coordinates along the last axis."""
        if self.transform is not None:
            return self.transform.to_core(x)
        if self.basis is not None:
            return change_basis(x, self.basis)
        return x if self.identity else np.ascontiguousarray(x[..., self.perm])

    def to_user(self, x: np.ndarray) -> np.ndarray:
        """Core coordinates → user coordinates along the last axis."""
        if self.transform is not None:
            return self.transform.to_user(x)
        if self.basis is not None:
            return change_basis(x, np.ascontiguousarray(self.basis.T))
        return x if self.identity else np.ascontiguousarray(x[..., self.inverse])

    def rows_to_core(self, x: np.ndarray) -> np.ndarray:
        """Per-coordinate numbers (a method's rows) in the core's order: the modal
        coordinates already are."""
        modal = self.basis is not None or self.transform is not None
        return np.ascontiguousarray(x) if modal else self.to_core(x)


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


def change_basis(x: np.ndarray, m: np.ndarray) -> np.ndarray:
    """x · m along the last axis, each row summed in a fixed order (the core's), so that a
    state has the same bits alone and in a batch of any size."""
    x = np.asarray(x, dtype=float)
    flat = np.ascontiguousarray(x.reshape(-1, x.shape[-1]))
    return _core.change_basis(flat, np.ascontiguousarray(m, dtype=float)).reshape(*x.shape[:-1], m.shape[1])


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
    # a stiffness matrix's modal coordinates come ordered (slow first, block by block): perm is
    # the identity and Q the whole map
    return CoreLayout(spec, perm, inverse, bool(np.all(perm == np.arange(perm.size))), problem.basis,
                      problem.coordinate_map)


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
    """The potential's description, with its inputs taken from the core's coordinates."""
    spec = potential.describe(lay.perm.size)
    if lay.basis is not None:
        return _modal_spec(spec, lay.basis, potential)
    return spec if lay.identity else _permute_spec(spec, lay, potential)


def _modal_spec(spec: dict, basis: np.ndarray, potential) -> dict:
    """U(Qx) for U(q): Q composed into the potential's input maps (a program's, each chain
    term's, the FPU's), or Python callables given q = Qx and returning Qᵀ∇U. A potential
    whose own coordinates are the modal ones (Q is the T of its `own_coordinates()`) runs
    with no map."""
    own = potential.own_coordinates()
    if own is not None and own[0].shape == basis.shape and np.array_equal(own[0], basis):
        return own[1]
    kind = spec["kind"]
    if kind in ("fpu", "program"):
        return {**spec, "map": _compose(spec.get("map"), spec["m"] * 2 if kind == "fpu" else spec["n"], basis)}
    if kind == "chain":
        return {**spec, "terms": [{**t, "map": _compose(t["map"], t["map"]["rows"], basis)} for t in spec["terms"]]}
    if kind == "python":
        value, gradient = spec["value"], spec["gradient"]

        back = np.ascontiguousarray(basis.T)

        # change_basis, not BLAS: a state gets the same q = Qx alone and in a block of lanes
        def value_modal(x):
            return value(change_basis(x, back))

        def gradient_modal(x):
            return change_basis(np.asarray(gradient(change_basis(x, back)), dtype=float), basis)

        hvp = spec.get("hessian_vector")

        def hessian_vector_modal(x, v):
            return change_basis(np.asarray(hvp(change_basis(x, back), change_basis(v, back)), dtype=float), basis)

        return {**spec, "value": value_modal, "gradient": gradient_modal,
                "hessian_vector": None if hvp is None else hessian_vector_modal}
    raise ValueError(_unmapped(kind, "in modal coordinates (a stiffness matrix)"))


def _compose(m: dict | None, rows: int, basis: np.ndarray) -> dict:
    """The sparse map M Q (M the identity when None) in the core's CSR form. Entries below
    1e-15 of their row's largest are the product's rounding noise (exact zeros of a sparse Q
    combined with ±1/√2 entries) and are dropped."""
    from scipy.sparse import csr_matrix

    n = basis.shape[0]
    left = (csr_matrix(np.eye(rows, n)) if m is None else
            csr_matrix((np.asarray(m["vals"], dtype=float), m["idx"], m["ptr"]), shape=(m["rows"], m["cols"])))
    dense = np.asarray(left @ basis)
    big = np.max(np.abs(dense), axis=1, keepdims=True)
    dense[np.abs(dense) <= 1e-15 * big] = 0.0
    out = csr_matrix(dense)
    out.sort_indices()
    return {"rows": int(out.shape[0]), "cols": n, "ptr": [int(x) for x in out.indptr],
            "idx": [int(x) for x in out.indices], "vals": np.asarray(out.data, dtype=float)}


def _permute_spec(spec: dict, lay: CoreLayout, potential) -> dict:
    kind = spec["kind"]
    inv = lay.inverse
    if kind == "fpu":
        if spec.get("map") is not None:
            return {**spec, "map": _permute_map(spec["map"], inv)}
        return _permute_spec(potential.program_description(), lay, potential)
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

        hvp = spec.get("hessian_vector")

        def hessian_vector_core(x, v):
            return np.asarray(hvp(x[..., inverse], v[..., inverse]), dtype=float)[..., perm]

        return {**spec, "value": value_core, "gradient": gradient_core,
                "hessian_vector": None if hvp is None else hessian_vector_core}
    raise ValueError(_unmapped(kind, "with its coordinates reordered (slow ones first, then block by block)"))


def _unmapped(kind: str, where: str) -> str:
    """Why a native kind without a coordinate map cannot run in the core's coordinates."""
    return (f"a potential of kind {kind!r} reads no coordinate map, so it runs only on a problem whose core "
            f"coordinates are the user's; this problem runs {where}. Kinds that take a map: fpu, program, "
            "chain, python")


def _permute_map(m: dict, inv: np.ndarray) -> dict:
    """A linear map of user coordinates as one of core coordinates: columns renamed."""
    return {**m, "idx": [int(inv[j]) for j in m["idx"]]}


def integrate(problem, co, q0, p0, n_steps, save_every, form, track, every, callback):
    """Runs one trajectory; returns the core's RunResult with states in the user's order."""
    lay = core_layout(problem)
    out = _core.integrate(
        problem_potential(problem, lay), lay.spec, core_method(problem, co, lay),
        lay.to_core(q0), lay.to_core(p0), int(n_steps), int(save_every), form, bool(track),
        int(every), callback,
    )
    s = out.samples[0]
    s["q"], s["p"] = lay.to_user(s["q"]), lay.to_user(s["p"])
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
