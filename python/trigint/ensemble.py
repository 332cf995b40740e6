"""Ensembles and sweeps: many trajectories of one problem, on every core and through Dask.

:func:`ensemble` runs a batch (each trajectory with its own q0, p0 and step size) in the
core's batched kernel; :func:`scan` is the resonance scan of the paper's Figure 3;
:func:`perturb` builds the perturbed initial values of Figure 2's grey curves. Work is split
into chunks of trajectories; chunks run locally one after the other (each on all cores), or on
a ``concurrent.futures`` executor or a ``dask.distributed.Client``; with ``store=`` each
finished chunk is written to disk at once and a rerun skips it. Every trajectory's numbers are
those of :func:`trigint.integrate` on it alone, bit for bit, whatever the chunks, threads or
workers.
"""

from __future__ import annotations

import os
import warnings
from typing import TYPE_CHECKING

import numpy as np

from . import _check, _outputs, _progress, _stacklevel
from ._batch import core_arguments, prepare
from ._method_names import resolve_method
from ._native import METHOD_ROWS
from ._outputs import STATUS_NAMES
from ._steppers import run_chunk
from ._store import SweepStore, fingerprint, stored_chunk_size
from .energies import energy_names
from .integrate import MAX_SAMPLE_BYTES, check_form, method_coefficients, sample_bytes, warn_near_resonance
from .methods import Method
from .potentials import PythonPotential
from .problem import OscillatoryProblem
from .saveat import SaveAt

if TYPE_CHECKING:  # imported where a Dataset is made, so that `import trigint` loads no xarray (nor pandas)
    import xarray as xr

#: show a progress bar by default from this many trajectory-steps on
PROGRESS_FROM = 10**8


def ensemble(problem: OscillatoryProblem, method: Method | str, q0, p0, *, h, t_end: float | None = None,
             n_steps: int | None = None, save_every: int | None = None, form: str = "two-step",
             track_energies: bool = True, threads: int | None = None, client=None, chunk_size: int | None = None,
             store=None, progress: bool | None = None, saveat: SaveAt | None = None,
             lyapunov: int | None = None) -> xr.Dataset:
    """Integrates many trajectories of one problem; returns an ``xarray.Dataset``.

    Parameters
    ----------
    problem, method
        As for :func:`trigint.integrate`: each trajectory with the bits of ``integrate()`` in
        the same `form` (on the Krylov path of a large sparse stiffness matrix, the one-step form).
    q0, p0 : array of shape (B, n) or (n,)
        Initial values; (n,) is broadcast to every trajectory.
    h : float or array of shape (B,)
        Step sizes; each trajectory has its own coefficients and step count.
    t_end, n_steps
        Give one: ``n_steps = round(t_end / h)`` per trajectory, or the same count for all.
    save_every : int, optional
        Keep samples every this many steps (and each trajectory's last step); default none.
    form : {"two-step", "one-step"}
        As for :func:`trigint.integrate`, each trajectory with its bits: the two-step recursion
        with p_n by the central difference, or the one-step form, which needs no division by
        χ(hω̃) and so is defined at hω = kπ too (methods B, C, E), where a scan may step.
        With `lyapunov`, the two-step form only (the Krylov path runs the one-step form
        whatever this says).
    track_energies : bool
        Stream max |E(t_n) − E(0)| over every step (default); off, the energies are taken at
        the samples only and ``max_deviation`` is NaN.
    threads : int, optional
        Threads per chunk (default: all cores). Results do not depend on it.
    client : dask.distributed.Client or concurrent.futures.Executor, optional
        Runs the chunks there and gathers them; without one, chunks run here. For a scheduler's
        address, pass ``dask.distributed.Client(address)``. A process pool receives the
        potential by pickle: a :class:`PythonPotential` must then be made of functions defined
        with ``def`` at module level (checked before anything runs).
    chunk_size : int, optional
        Trajectories per chunk (the unit of progress, of distribution and of ``store``).
    store : str or path, optional
        A zarr directory: each finished chunk is written as it completes; the same call with the
        same store skips the finished chunks and returns the identical result, whatever its thread
        count, chunk size or client (the store keeps the chunking it was made with). A process
        killed at any moment, even while creating the store, loses at most the unfinished chunks.
        A store written by a different call is refused. A finished chunk that no longer reads back
        (each carries a checksum) is recomputed with a warning; a store that cannot be used
        (damaged metadata, a missing array, a folder that cannot be written, a file or dangling
        link in the way) raises :class:`trigint.StoreError` before anything is computed.
    progress : bool, optional
        A tqdm bar over chunks (default: for sweeps of 10⁸ trajectory-steps or more, when
        stderr is a terminal or in a notebook; ``True`` where no bar can be drawn prints a line
        every 10 % instead).
    saveat : SaveAt, optional
        What to keep, as one value (replaces `save_every` and `track_energies`), the same value
        :func:`integrate` takes.
    lyapunov : int, optional
        Also the leading `lyapunov` finite-time Lyapunov exponents of each trajectory's numerical
        map and its MEGNO (:func:`trigint.lyapunov` on each trajectory alone, the same numbers),
        as ``lyapunov`` (trajectory, exponent) and ``megno`` (trajectory): computed in each chunk
        beside its run, so on a client and into a store as the rest.

    Returns
    -------
    xarray.Dataset
        ``max_deviation`` (trajectory, energy): max |E(t_n) − E(0)| over every step;
        ``initial_energies`` (trajectory, energy); ``status`` and ``steps_done`` (trajectory);
        coordinates ``h``, ``n_steps``; with ``save_every`` also ``q``, ``p`` (trajectory,
        sample, coordinate), ``energies`` (trajectory, sample, energy) and ``t`` (trajectory,
        sample). Trajectories that share ``n_steps`` have no padding: ``ds.q[:, -1]`` is each one's
        final state. Where ``n_steps`` differs (a ``scan`` over step sizes at one ``t_end``), the
        shorter ones are padded with NaN (``step`` −1) after their last sample; the coordinate
        ``last_sample`` (trajectory) selects each one's final state:
        ``ds.q.isel(sample=ds.last_sample)``.

    Examples
    --------
    >>> import numpy as np, trigint as ti
    >>> prob = ti.problems.fpu(); q0, p0 = ti.problems.fpu_initial()
    >>> Q0, P0 = ti.perturb(q0, p0, [0.0, 7e-16, -7e-16])
    >>> ds = ti.ensemble(prob, "B", Q0, P0, h=2*np.pi/3/50, t_end=30.0)
    >>> ds.max_deviation.sel(energy="oscillatory").shape
    (3,)
    """
    if not isinstance(problem, OscillatoryProblem):
        raise TypeError(f"problem: expected an OscillatoryProblem, got {type(problem).__name__}")
    # The result is a Dataset: xarray (with pandas, about 0.3 s the first time in a process) is
    # loaded before the run, so that a Ctrl-C's return does not wait for it.
    import xarray  # noqa: F401

    method = resolve_method(method)
    form = check_form(form)
    _check_lyapunov(lyapunov, problem, form)
    batch = prepare(problem, method, q0, p0, h, t_end, n_steps, form)
    _warn_at_one_step_size(problem, method, batch.h, form)
    saveat = SaveAt.resolve(saveat, save_every, track_energies)
    save_every, track_energies = saveat.every, saveat.track_energies
    if threads is not None:
        _at_least_one(threads, "threads", " or None")
    if threads is not None and threads > MAX_THREADS:
        raise ValueError(f"threads: at most {MAX_THREADS}, got {threads}")
    count = len(batch)
    _check_memory(problem, batch, save_every)
    _check_client(client)
    chunk = _chunk_size(chunk_size, count, client, threads)
    if store is not None:  # a store keeps the chunking it was made with (results do not depend on it)
        if not isinstance(store, str | os.PathLike):
            raise TypeError(f"store: expected a folder path (a str or pathlib.Path), got {type(store).__name__}")
        chunk = stored_chunk_size(store) or chunk
    spans = [slice(a, min(a + chunk, count)) for a in range(0, count, chunk)]
    names = energy_names(problem.n_blocks, problem.n_axes)
    args = core_arguments(problem, method)
    _check_sendable(client, problem.potential, args[1].spec)  # args: stepper, potential, layout, map
    # more threads than trajectories would only idle (the bits do not depend on the count)
    kwargs = dict(save_every=None if save_every is None else int(save_every), track=bool(track_energies),
                  form=form, lyapunov=None if lyapunov is None else int(lyapunov),
                  threads=None if threads is None else int(min(threads, count)))
    sink = _open_store(store, problem, method, batch, names, save_every, track_energies, chunk, spans, lyapunov,
                       form)
    results: dict[int, dict] = {}
    todo = list(range(len(spans)))
    stored: dict[int, dict] = {}
    if sink is not None:
        stored = sink.finished(spans)  # damaged finished chunks are left out: recomputed
        todo = [i for i in todo if i not in stored]
        if todo:
            sink.prepare(len(todo))  # writable, before anything is computed
    if progress is not None and not isinstance(progress, bool | np.bool_):
        raise TypeError(f"progress: expected True, False or None, got {type(progress).__name__}")
    show = progress if progress is not None else (int(batch.n_steps.sum()) >= PROGRESS_FROM
                                                  and _progress.interactive())
    bar = _bar(show, len(spans), len(spans) - len(todo))
    interrupted = False
    try:
        for i, out in _execute(client, todo, spans, batch, args, kwargs):
            results[i] = out
            if sink is not None and not out.interrupted:
                sink.write(i, spans[i], _outputs.chunk_rows(out, _sizes(problem, batch, names, save_every, lyapunov),
                                                            save_every is not None))
            bar.update(1)
            if out.interrupted:
                interrupted = True
                break
    except KeyboardInterrupt:
        interrupted = True
    finally:
        bar.close()
    ds = problem.ensemble_dataset(_assemble(problem, method, batch, names, spans, results, stored, save_every,
                                                  lyapunov))
    if interrupted:
        finished = int((ds.status == "completed").sum())
        warnings.warn(f"interrupted: kept {finished} of {count} finished trajectories"
                      + (f" (in {store})" if store else "") + "; the others have status 'interrupted'",
                      RuntimeWarning, stacklevel=_stacklevel.outside())
    blown = int((ds.status == "blow-up").sum())
    if blown:
        warnings.warn(f"{blown} of {count} trajectories blew up (status 'blow-up'); their numbers stop at "
                      "the last finite step", RuntimeWarning, stacklevel=_stacklevel.outside())
    return ds


def scan(problem: OscillatoryProblem, method: Method | str, q0, p0, *, h_omega, omega_ref: float | None = None,
         t_end: float, energy: str = "oscillatory", **kwargs) -> xr.DataArray:
    """The resonance scan of the paper's Figure 3: max |E(t) − E(0)| over 0 ≤ t ≤ t_end as a
    function of hω_ref, each step size h = hω_ref/ω_ref with its own n_steps = round(t_end/h).

    Parameters
    ----------
    problem, method, q0, p0
        As for :func:`ensemble`; q0 and p0 of shape (n,) (one initial value for every step size).
    h_omega : array of float
        The values hω_ref to scan, > 0.
    omega_ref : float, optional
        The frequency that measures h (default: the largest frequency of the problem; required on the
        Krylov path, whose frequencies are never computed).
    t_end : float
        End time of every run.
    energy : str
        The energy whose deviation is returned (``"oscillatory"``, ``"total"``, ``"slow"``,
        ``"modified_oscillatory"`` or ``"oscillatory_j"``).
    **kwargs
        Passed to :func:`ensemble`: ``form`` (``"one-step"`` steps through hω = kπ too),
        ``threads``, ``client``, ``chunk_size``, ``store``, ``progress``, ...

    Returns
    -------
    xarray.DataArray
        Over ``h_omega``, with coordinates ``h``, ``n_steps`` and ``status``.

    Examples
    --------
    >>> import numpy as np, trigint as ti
    >>> prob = ti.problems.fpu(); q0, p0 = ti.problems.fpu_initial()
    >>> s = ti.scan(prob, "B", q0, p0, h_omega=np.linspace(2.05, 2.15, 5), t_end=100.0)
    >>> s.dims
    ('h_omega',)
    """
    if not isinstance(problem, OscillatoryProblem):
        raise TypeError(f"problem: expected an OscillatoryProblem, got {type(problem).__name__}")
    if omega_ref is None:
        problem.require_spectrum("scan without omega_ref")
    h_omega = _check.real_array(h_omega, "h_omega", positive=True).reshape(-1)
    ref = float(np.max(problem.omega)) if omega_ref is None else _check.real(omega_ref, "omega_ref", positive=True)
    if not ref > 0:
        raise ValueError("omega_ref: the problem has no oscillatory frequency; give omega_ref")
    _check.choice(energy, "energy", energy_names(problem.n_blocks, problem.n_axes))
    ds = ensemble(problem, method, q0, p0, h=h_omega / ref, t_end=t_end, **kwargs)
    da = ds.max_deviation.sel(energy=energy).drop_vars("energy")
    da = da.rename(trajectory="h_omega").assign_coords(h_omega=h_omega, h=("h_omega", ds.h.values),
                                                       n_steps=("h_omega", ds.n_steps.values),
                                                       status=("h_omega", ds.status.values))
    if "lyapunov" in ds:
        da = da.assign_coords(lyapunov=("h_omega", ds.lyapunov.values[:, 0]), megno=("h_omega", ds.megno.values))
    da.name = f"max_deviation_{energy}"
    da.attrs.update(ds.attrs, energy=energy, t_end=float(t_end), omega_ref=ref)
    return da


def perturb(q0, p0, deltas, *, index: int = 0, component: str = "q") -> tuple[np.ndarray, np.ndarray]:
    """Initial values (B, n) with entry `index` of q0 (or p0) moved by each δ in `deltas`
    (Figure 2's grey curves: x₀,₁(0) = 1 ± δ, |δ| ≤ 7·10⁻¹⁶).

    Parameters
    ----------
    q0, p0 : array of float, shape (n,) or a wave problem's grid shape
        The initial values to perturb (grid values of shape (64, 64) give (B, 64, 64)).
    deltas : array of float, shape (B,)
        One perturbation per trajectory (0 keeps the unperturbed values).
    index : int or tuple of int
        The entry that is moved: a flat index, or a grid point (i, j, …) of grid-shaped values.
    component : {"q", "p"}
        Whether q0 or p0 is moved.

    Returns
    -------
    Q, P : arrays of shape (B, n), or (B,) + the grid shape

    >>> import trigint as ti
    >>> Q, P = ti.perturb([1.0, 0.0], [0.0, 1.0], [0.0, 1e-3])
    >>> Q.tolist()
    [[1.0, 0.0], [1.001, 0.0]]
    """
    q0 = np.atleast_1d(_check.real_array(q0, "q0", ndim=None))
    p0 = np.atleast_1d(_check.real_array(p0, "p0", ndim=None))
    if p0.shape != q0.shape:
        raise ValueError(f"p0: has shape {p0.shape}, q0 has {q0.shape}; give two arrays of one shape, "
                         "(n,) or a wave problem's grid shape")
    deltas = _check.real_array(deltas, "deltas").reshape(-1)
    _check.choice(component, "component", ("q", "p"))
    if isinstance(index, tuple):  # a grid point (i, j, …) of grid-shaped values
        if len(index) != q0.ndim:
            raise ValueError(f"index: {index} has {len(index)} entries for values of shape {q0.shape}")
        index = int(np.ravel_multi_index(tuple(_check.integer(i, "index", low=0, high=n - 1)
                                                for i, n in zip(index, q0.shape, strict=True)), q0.shape))
    index = _check.integer(index, "index", low=0, high=q0.size - 1)
    Q = np.repeat(q0.reshape(1, -1), deltas.size, axis=0)
    P = np.repeat(p0.reshape(1, -1), deltas.size, axis=0)
    target = Q if component == "q" else P
    target[:, index] += deltas
    Q, P = Q.reshape(deltas.size, *q0.shape), P.reshape(deltas.size, *q0.shape)
    return Q, P


#: the most threads one call may ask for
MAX_THREADS = 1024


def _check_lyapunov(count, problem, form: str = "two-step") -> None:
    """``lyapunov=``: a number of exponents, 1 … 2n, of the two-step form's tangent map (the
    Krylov path's is the one-step form's, whatever `form` says)."""
    if count is None:
        return
    if form == "one-step" and problem.stepper.has_spectrum:
        raise ValueError("form: lyapunov=… takes the tangent map of the two-step form; run it with "
                         "form='two-step' (the same trajectory: the forms differ only in how p_n is computed)")
    if not _check.is_integer(count) or not 1 <= count <= 2 * problem.dim:
        raise ValueError(f"lyapunov: the number of exponents per trajectory, an integer from 1 to 2n = "
                         f"{2 * problem.dim}, got {count!r}")
    pot = problem.potential
    if isinstance(pot, PythonPotential) and pot.hessian_vector_function is None:
        # (before the run: the core would suggest lyapunov()'s finite_differences, which is not here)
        give = ("a wave's (V, V', V'') gives it" if getattr(pot, "no_second_derivative", None)
                else "give one, PythonPotential(..., hessian_vector=f)")
        raise ValueError("lyapunov: this Python potential has no second derivative (x, v) -> Hess U(x) v, which "
                         f"the tangent map needs; {give}, or run ti.lyapunov(..., finite_differences=True) on each "
                         "trajectory (central differences of the gradient)")


def _check_memory(problem, batch, save_every) -> None:
    """Refuses, before anything is allocated, an ensemble whose samples would not fit: the
    result holds every trajectory's samples (q, p, energies, step) in memory."""
    if save_every is None:
        return
    width = _max_samples(batch, int(save_every))
    need = sample_bytes(problem, len(batch) * width)
    if need > MAX_SAMPLE_BYTES:
        raise ValueError(
            f"save_every: {len(batch)} trajectories of up to {width} samples of {problem.dim} coordinates "
            f"would need {need / 2**30:.3g} GiB, more than the {MAX_SAMPLE_BYTES / 2**30:.3g} GiB allowed "
            "(a quarter of this machine's memory, at most 8 GiB); "
            "increase save_every, or leave it None to keep only the energy statistics"
        )


def _at_least_one(value, name: str, alternative: str = "") -> None:
    """An integer >= 1: a float, string or bool is an IntegerTypeError (a TypeError, and a
    ValueError as before), an integer below 1 a ValueError."""
    if not _check.is_integer(value):
        raise _check.IntegerTypeError(f"{name}: must be an integer >= 1{alternative}, got {value!r}")
    if value < 1:
        raise ValueError(f"{name}: must be an integer >= 1{alternative}, got {value!r}")


def _chunk_size(chunk_size, count: int, client, threads) -> int:
    if chunk_size is not None:
        _at_least_one(chunk_size, "chunk_size")
        return int(chunk_size)
    if client is not None:
        return max(1, -(-count // 16))
    # A full block of 256 trajectories per thread: smaller blocks pay the per-step overhead of
    # the kernel on fewer trajectories (measured: 74-lane blocks run 1.7 times slower).
    cores = threads or os.cpu_count() or 1
    return max(256 * cores, -(-count // 20))


def _is_dask(client) -> bool:
    return hasattr(client, "gather") and hasattr(client, "scatter")


def _check_client(client) -> None:
    """A client that can take work: an executor that is not shut down, a connected Dask client."""
    if client is None:
        return
    if not callable(getattr(client, "submit", None)):
        hint = (f"; for a scheduler at {client!r} pass client=dask.distributed.Client({client!r})"
                if isinstance(client, str) else "")
        raise TypeError(f"client: expected a dask.distributed.Client or a concurrent.futures.Executor, got "
                        f"{type(client).__name__}{hint}")
    if _is_dask(client) and getattr(client, "status", "running") in ("closing", "closed"):
        raise ValueError("client: this dask.distributed.Client is closed; pass a connected one")


def _check_sendable(client, potential, spec: dict) -> None:
    """A process pool or Dask pickles what each chunk needs; Python callables that cannot be
    pickled (a lambda, a local function: pickle finds functions by module and name) fail
    here, with what to do, instead of deep inside the executor."""
    from concurrent.futures import ProcessPoolExecutor

    if client is None or spec.get("kind") != "python":
        return
    if _is_dask(client):
        try:
            import cloudpickle as pickler  # what Dask uses: lambdas and closures are fine
        except ImportError:
            return
        where = "Dask sends it to its workers with cloudpickle"
    elif isinstance(client, ProcessPoolExecutor):
        import pickle as pickler

        where = "a ProcessPoolExecutor sends it to its worker processes with pickle"
    else:
        return  # a thread pool shares the objects; other executors' ways of sending are unknown
    try:
        pickler.dumps(spec)
        return
    except Exception as exc:  # pickle raises PicklingError, AttributeError, TypeError, ...
        error = exc
    try:
        pickler.dumps((potential.value_function, potential.gradient_function))
    except Exception as exc:
        functions = (potential.value_function, potential.gradient_function)
        names = ", ".join(getattr(f, "__qualname__", repr(f)) for f in functions)
        raise TypeError(
            f"potential: the PythonPotential's functions ({names}) cannot be pickled ({exc}), and {where}. "
            "Define value and gradient with def at module level in a module the workers can import, run "
            "the chunks in a ThreadPoolExecutor or a dask.distributed.Client, or compile the potential "
            "(ExpressionPotential, ChainPotential)"
        ) from None
    raise TypeError(
        f"potential: on a stiffness matrix a PythonPotential's functions are wrapped in the change of basis, "
        f"which cannot be pickled ({error}), and {where}; run the chunks in a ThreadPoolExecutor or a "
        "dask.distributed.Client, or compile the potential (ExpressionPotential, ChainPotential)"
    ) from None


def _execute(client, todo, spans, batch, args, kwargs):
    """Yields (chunk index, result) as chunks finish: here, on an executor, or on Dask."""
    if client is None:
        for i in todo:
            yield i, run_chunk(*args, batch.rows(spans[i]), **kwargs)
        return
    if _is_dask(client):  # dask.distributed.Client
        from distributed import as_completed
    else:
        from concurrent.futures import as_completed
    futures = {}
    try:
        for i in todo:
            futures[client.submit(run_chunk, *args, batch.rows(spans[i]), **kwargs)] = i
    except RuntimeError as exc:  # concurrent.futures after shutdown()
        for future in futures:
            future.cancel()
        raise ValueError(f"client: cannot take work ({exc}); pass an executor that is not shut down") from None
    try:
        for future in as_completed(list(futures)):
            yield futures[future], future.result()
    finally:  # an interrupted or failed run: drop the work still queued
        for future in futures:
            if not future.done():
                future.cancel()


def _sizes(problem, batch, names, save_every, lyapunov=None) -> dict:
    """The dimension sizes of a sweep's output table (``_outputs.OUTPUTS``)."""
    sizes = {"trajectory": len(batch), "energy": len(names), "coordinate": problem.dim}
    if lyapunov is not None:
        sizes["exponent"] = int(lyapunov)
    if save_every is not None:
        sizes["sample"] = _max_samples(batch, save_every)
    return sizes


def _max_samples(batch, save_every) -> int:
    """Samples of the longest trajectory: steps 0, s, 2s, … and its last step when that is not a
    multiple of s (a blow-up or an interruption keeps no more than that)."""
    n = np.asarray(batch.n_steps, dtype=np.int64)
    return int(np.max(n // save_every + 1 + (n % save_every != 0)))


def _open_store(store, problem, method, batch, names, save_every, track, chunk, spans, lyapunov=None,
                form: str = "two-step"):
    if store is None:
        return None
    shapes = _outputs.shapes(_sizes(problem, batch, names, save_every, lyapunov), save_every is not None)
    matrix = problem.stepper.store_matrix(problem)
    coefficients = np.stack([batch.methods[k] for k in METHOD_ROWS]) if batch.methods else None
    prints = fingerprint({
        "omega": problem.omega, "blocks": problem.blocks, "potential": _potential_key(problem.potential),
        **matrix, "method": repr(method), "coefficients": coefficients,
        "h": batch.h, "n_steps": batch.n_steps, "q0": batch.q0, "p0": batch.p0, "save_every": save_every,
        "track_energies": bool(track), "lyapunov": lyapunov,
        # (only where not the default: stores made before ensemble() had a form stay valid; the
        # Krylov path runs the one-step form whatever it says)
        **({"form": form} if form != "two-step" and problem.stepper.has_spectrum else {}),
    })
    return SweepStore(store, prints, shapes, chunk, len(spans))


def _potential_key(potential) -> str:
    spec = potential.describe(potential.dim or 0)
    if spec["kind"] == "python":  # callables: by name, the best a fingerprint can do
        names = (getattr(f, "__qualname__", "?") for f in (potential.value_function, potential.gradient_function))
        return "python:" + ":".join(names)
    return repr(spec)


def _warn_at_one_step_size(problem, method: Method, h: np.ndarray, form: str = "two-step") -> None:
    """Where every trajectory has the same step size (Figure 2's perturbed runs), the warning
    :func:`trigint.integrate` gives at it: hω near a non-zero multiple of π. A scan over step
    sizes crosses resonances on purpose, so it is not warned (its blow-ups are reported after
    the run); nor is a problem with its own check after the run (a wave) or without computed
    frequencies (the Krylov path)."""
    if h.size == 0 or not problem.stepper.has_spectrum or getattr(problem, "warn_resonances", None) is not None:
        return
    if np.all(h == h[0]):
        warn_near_resonance(method_coefficients(problem, method, float(h[0]), form), method, stacklevel=4)


def _assemble(problem, method, batch, names, spans, results, stored, save_every, lyapunov=None) -> xr.Dataset:
    count = len(batch)
    sizes, with_samples = _sizes(problem, batch, names, save_every, lyapunov), save_every is not None
    arrays = _outputs.empty(sizes, with_samples)
    for i, rows in stored.items():  # finished chunks read back from the store
        for name in arrays:
            arrays[name][spans[i]] = rows[name]
    for i, out in results.items():
        for name, value in _outputs.chunk_rows(out, sizes, with_samples).items():
            arrays[name][spans[i]] = value
    arrays["status"] = np.array([STATUS_NAMES[int(s)] for s in arrays["status"]], dtype=object)
    data = {o.name: (o.dims, arrays[o.name]) for o in _outputs.outputs(with_samples, lyapunov is not None)}
    coords = {"trajectory": np.arange(count), "energy": names, "h": ("trajectory", batch.h),
              "n_steps": ("trajectory", batch.n_steps)}
    if lyapunov is not None:
        coords["exponent"] = [f"λ{j + 1}" for j in range(int(lyapunov))]
    if with_samples:
        step = arrays["step"]
        data["t"] = (("trajectory", "sample"), np.where(step >= 0, step * batch.h[:, None], np.nan))
        # Each trajectory's last kept sample (its final state): ds.q.isel(sample=ds.last_sample).
        coords["last_sample"] = ("trajectory", np.maximum((step >= 0).sum(axis=1) - 1, 0))
    import xarray as xr

    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update(method=repr(method), problem=repr(problem))
    if lyapunov is not None:
        ds["lyapunov"].attrs["description"] = "finite-time Lyapunov exponents at the last step (Benettin's order)"
        ds["megno"].attrs["description"] = "time-averaged MEGNO <Y> of the leading deviation vector"
    return ds


def _bar(show: bool, total: int, initial: int):
    if not show:
        class _Silent:
            def update(self, k):
                pass

            def close(self):
                pass

        return _Silent()
    return _progress.bar(total, "chunk", "ensemble", initial)
