"""integrate(): validate, build the coefficients, run the core, build the Solution."""

from __future__ import annotations

import os
import sys
import warnings
from collections.abc import Callable

import numpy as np
import xarray as xr

from . import _check, _native
from .energies import energy_names
from .methods import Method, _check_h, resolve_method
from .potentials import PythonPotential
from .problem import OscillatoryProblem
from .solution import Solution

FORMS = ("two-step", "one-step")
#: progress reports (and Ctrl-C checks) every this many steps; ~10 ms for native potentials
PROGRESS_EVERY_NATIVE = 1 << 20
PROGRESS_EVERY_PYTHON = 1 << 10
#: show a progress bar by default from this many steps on
PROGRESS_BAR_FROM = 10**7


def _sample_memory_limit() -> int:
    """Runs whose samples would need more than this are refused before they start: 8 GiB, or a
    quarter of the machine's memory if that is less (growing arrays and the copy into NumPy
    hold up to three times the samples at once)."""
    try:
        physical = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        physical = 32 << 30
    return int(min(8 << 30, physical // 4))


#: the longest run accepted: 2**53 steps (step numbers stay exact in a double; at 7 ns per
#: step it would take two years)
MAX_STEPS = 2**53

#: refuse runs whose samples would need more memory than this
MAX_SAMPLE_BYTES = _sample_memory_limit()


def sample_bytes(problem, samples: int) -> int:
    """Memory of `samples` kept states: q, p, the energies and the step number of each."""
    return samples * (2 * problem.dim + 4 + problem.n_blocks) * 8


def integrate(problem: OscillatoryProblem, method: Method | str, q0, p0, *, h: float,
              t_end: float | None = None, n_steps: int | None = None, save_every: int = 1,
              form: str = "two-step", track_energies: bool = True,
              progress: bool | Callable | None = None) -> Solution:
    """Integrates q'' + Ω²q = −∇U(q) from (q0, p0) with a trigonometric or modified method.

    Runs the recursion (2.2)/(2.5) started by (2.3), with p_n by the central
    difference (paper §2.2–2.3), or its one-step form (``form="one-step"``). The state at
    step n, and every energy, is known once step n + 1 is taken.

    Parameters
    ----------
    problem : OscillatoryProblem
    method : Method or str
        e.g. ``Trigonometric("B")``, ``IMEX()``, or a name such as ``"B"`` or ``"imex"``.
    q0, p0 : array of shape (n,)
    h : float
        Step size, > 0.
    t_end, n_steps : float or int
        Give exactly one; ``n_steps = round(t_end / h)``.
    save_every : int
        Keep the state every this many steps (always step 0 and the last step).
    form : {"two-step", "one-step"}
    track_energies : bool
        Stream max |E(t_n) − E(0)| over every step (default). Off, energies are computed only
        at the samples and `max_deviation` is NaN.
    progress : bool or callable, optional
        A tqdm bar over steps (default: for runs of 10⁷ steps or more), or a callable
        ``progress(steps_done)`` that may return False to stop.

    A problem with a large sparse stiffness matrix (``path="krylov"``) is stepped in the
    one-step form (the same method; the two-step form's momentum divides by χ(h√A)) with each
    matrix function applied by the Lanczos method; ``Solution.info`` reports the iterations.

    Returns
    -------
    Solution
        Memory is O(samples): 10⁹ steps with ``save_every=10**6`` keep 1001 states. A run whose
        state turns non-finite stops with status ``"blow-up"``; Ctrl-C stops it with
        ``"interrupted"``; both keep every sample taken.

    Examples
    --------
    >>> import numpy as np, trigint as ti
    >>> prob = ti.problems.fpu(m=3, omega=50.0)
    >>> q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
    >>> sol = ti.integrate(prob, ti.Trigonometric("B"), q0, p0, h=2*np.pi/3/50,
    ...                    t_end=30.0, save_every=10)
    >>> sol.status, sol.n_steps
    ('completed', 716)
    >>> bool(sol.max_deviation["oscillatory"] < 0.05)
    True
    """
    if not isinstance(problem, OscillatoryProblem):
        raise TypeError(f"problem: expected an OscillatoryProblem, got {type(problem).__name__}")
    method = resolve_method(method)
    h = _check_h(h)
    n_steps = _resolve_steps(h, t_end, n_steps)
    save_every = check_steps(_positive_int(save_every, "save_every"), "save_every")
    if not isinstance(form, str) or form not in FORMS:
        raise ValueError(f"form: must be one of {FORMS}, got {form!r}")
    track_energies = _flag(track_energies, "track_energies")
    q0 = _state(q0, "q0", problem.dim)
    p0 = _state(p0, "p0", problem.dim)
    n_samples = n_steps // save_every + 2
    if sample_bytes(problem, n_samples) > MAX_SAMPLE_BYTES:
        raise ValueError(
            f"save_every: {n_samples} samples of {problem.dim} coordinates would need more than "
            f"{MAX_SAMPLE_BYTES / 2**30:.3g} GiB (a quarter of this machine's memory, at most 8 GiB); "
            "increase save_every"
        )
    if problem.path == "krylov":
        return _krylov_solution(problem, method, h, n_steps, q0, p0, save_every, track_energies, progress)
    co = method.coefficients(h, problem.omega, form=form)
    python_potential = isinstance(problem.potential, PythonPotential)
    every = PROGRESS_EVERY_PYTHON if python_potential else PROGRESS_EVERY_NATIVE
    callback, close = _progress(progress, n_steps, python_potential)
    try:
        out = _native.integrate(problem, co, q0, p0, n_steps, save_every, form,
                                bool(track_energies), every, callback)
    finally:
        close()
    if out["interrupted_by"] is not None and "KeyboardInterrupt" not in out["interrupted_by"]:
        raise RuntimeError(f"progress callback failed: {out['interrupted_by']}")
    return _solution(problem, method, h, n_steps, out, co)


def _krylov_solution(problem, method, h, n_steps, q0, p0, save_every, track, progress) -> Solution:
    """A stiffness matrix on the Krylov path: the one-step form with matrix functions by Lanczos
    (see :mod:`trigint._krylov`), in Python; energies at the samples, and every step if tracked."""
    from . import _krylov

    callback, close = _progress(progress, n_steps, True)
    try:
        out = _krylov.integrate(problem, method, q0, p0, h, n_steps, save_every, track, callback,
                                problem.krylov_tolerance)
    finally:
        close()
    return _solution(problem, method, h, n_steps, out)


def _solution(problem, method, h, n_steps, out, co=None) -> Solution:
    names = energy_names(problem.n_blocks)
    samples = out["samples"]
    if co is not None and not np.all(np.isfinite(co.modified_p)):
        # one-step form at hω = kπ with a filter whose σ has no limit there (E, A)
        k = names.index("modified_oscillatory")
        samples["energies"][:, k] = np.nan
        out["max_deviation"][k] = out["initial_energies"][k] = np.nan
        j = int(np.flatnonzero(~np.isfinite(co.modified_p))[0])
        warnings.warn(f"the modified oscillatory energy is undefined at h*omega[{j}] = {co.xi[j]:.12g} for "
                      f"method {method.name!r} (sigma = sinc*phi/psi has no finite limit there); it is NaN",
                      RuntimeWarning, stacklevel=3)
    steps = samples["steps"].astype(np.int64)
    t = steps * h
    energies = xr.Dataset(
        {name: ("t", samples["energies"][:, k]) for k, name in enumerate(names)},
        coords={"t": t, "step": ("t", steps)},
        attrs={"method": repr(method), "h": h},
    )
    if out["status"] != "completed":
        warnings.warn(out["message"], RuntimeWarning, stacklevel=3)
    return Solution(
        t=t, q=samples["q"], p=samples["p"], steps=steps, energies=energies,
        max_deviation=dict(zip(names, out["max_deviation"].tolist(), strict=True)),
        initial_energies=dict(zip(names, out["initial_energies"].tolist(), strict=True)),
        h=h, n_steps=int(out["steps_done"]), n_steps_requested=n_steps,
        status=out["status"], message=out["message"], method=method, problem=problem,
        info=out.get("krylov") or {},
    )


def _resolve_steps(h: float, t_end, n_steps) -> int:
    if (t_end is None) == (n_steps is None):
        raise ValueError("t_end, n_steps: give exactly one of them")
    if n_steps is not None:
        return check_steps(_positive_int(n_steps, "n_steps"), "n_steps")
    t_end = _number(t_end, "t_end")
    if not np.isfinite(t_end) or t_end <= 0:
        raise ValueError(f"t_end: must be finite and > 0, got {t_end}")
    steps = t_end / h
    if steps > MAX_STEPS:
        raise ValueError(f"t_end: {t_end:g} is {steps:.3g} steps of h = {h:g}; at most 2**53 = {MAX_STEPS:.3g} "
                         "steps are allowed")
    steps = round(steps)
    if steps < 1:
        raise ValueError(f"t_end: {t_end} is shorter than half a step h = {h}")
    return int(steps)


def check_steps(n: int, name: str) -> int:
    """n, if it is a run length this library can count (at most 2**53 steps)."""
    if n > MAX_STEPS:
        count = f"{n:.3g} steps" if n < 10**300 else f"{_check.shown(n)} (steps)"
        raise ValueError(f"{name}: {count} is more than 2**53 = {MAX_STEPS:.3g}, the most allowed "
                         "(at 7 ns per step that would take two years)")
    return n


def _number(value, name: str) -> float:
    """A real number (not a string, a bool or a complex)."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"{name}: expected a number, got {_check.shown(value)} ({type(value).__name__})")
    try:
        return float(value)
    except OverflowError:
        raise _check.too_large(name, value) from None


def _flag(value, name: str) -> bool:
    if not isinstance(value, bool | np.bool_):
        raise TypeError(f"{name}: expected True or False, got {value!r}")
    return bool(value)


def _positive_int(value, name: str, allow_zero: bool = False) -> int:
    if not _check.is_integer(value):
        raise _check.IntegerTypeError(f"{name}: expected an integer, got {_check.shown(value)} "
                                      f"({type(value).__name__})")
    if value < (0 if allow_zero else 1):
        raise ValueError(f"{name}: must be {'>= 0' if allow_zero else '>= 1'}, got {value}")
    return int(value)


def _state(x, name: str, n: int) -> np.ndarray:
    if np.iscomplexobj(x):
        raise TypeError(f"{name}: complex values are not allowed; the state is real")
    try:
        a = np.ascontiguousarray(x, dtype=float)
    except OverflowError:
        raise ValueError(f"{name}: a value is too large for a double (at most about 1.8e308 in magnitude)") from None
    except (TypeError, ValueError):
        raise TypeError(f"{name}: expected an array of {n} floats") from None
    if a.shape != (n,):
        raise ValueError(f"{name}: expected shape ({n},) to match the problem, got {a.shape}")
    if not np.all(np.isfinite(a)):
        i = int(np.flatnonzero(~np.isfinite(a))[0])
        raise ValueError(f"{name}: entries must be finite; {name}[{i}] = {a[i]}")
    return a


def _progress(progress, n_steps: int, slow: bool):
    """A (callback, close) pair: a tqdm bar, the user's callable, or nothing."""
    if callable(progress) and not isinstance(progress, bool):
        return progress, lambda: None
    if progress is not None and not isinstance(progress, bool | np.bool_):
        raise TypeError(f"progress: expected True, False, None or a callable, got {type(progress).__name__}")
    show = progress if progress is not None else (n_steps >= PROGRESS_BAR_FROM or (slow and n_steps >= 10**5))
    if not show:
        return None, lambda: None
    from tqdm.auto import tqdm

    bar = tqdm(total=n_steps, unit="step", unit_scale=True, file=sys.stderr, desc="integrate")

    def update(done: int) -> None:
        bar.update(done - bar.n)

    return update, bar.close
