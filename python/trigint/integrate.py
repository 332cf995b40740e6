"""integrate(): validate, build the coefficients, run the core, build the Solution."""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable

import numpy as np

from . import _check, _native
from . import _progress as progress_report
from ._method_names import resolve_method
from .methods import Method
from .potentials import PythonPotential
from .problem import OscillatoryProblem
from .saveat import MAX_STEPS, SaveAt, check_steps
from .solution import Channels, Deferred, Solution

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


#: refuse runs whose samples would need more memory than this
MAX_SAMPLE_BYTES = _sample_memory_limit()

#: integrate() warns when |sin(hω̃_j)| < min(√h, this) for some hω̃_j > π/2 (see its docstring)
NEAR_RESONANCE_SIN = 0.1


def check_form(form) -> str:
    """``form=``: one of :data:`FORMS`.

    >>> check_form("one-step")
    'one-step'
    """
    if not isinstance(form, str) or form not in FORMS:
        raise ValueError(f"form: must be one of {FORMS}, got {form!r}")
    return form


def sample_bytes(problem, samples: int) -> int:
    """Memory of `samples` kept states: q, p, the energies and the step number of each."""
    return samples * (2 * problem.dim + len(_native.channel_index(problem.n_blocks, problem.n_axes)[0])) * 8


def integrate(problem: OscillatoryProblem, method: Method | str, q0, p0, *, h: float,
              t_end: float | None = None, n_steps: int | None = None, save_every: int = 1,
              form: str = "two-step", track_energies: bool = True,
              progress: bool | Callable | None = None, saveat: SaveAt | None = None) -> Solution:
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
        A tqdm bar over steps (default: for runs of 10⁷ steps or more, when stderr is a
        terminal or in a notebook; ``True`` where no bar can be drawn, as in a log file, prints
        a line every 10 % instead), or a callable ``progress(steps_done)`` that may return
        False to stop. The core reports every 2²⁰ steps (2¹⁰ with a `PythonPotential` or on
        the Krylov path), so a shorter run calls it not at all and a bar shows its end only.
    saveat : SaveAt, optional
        What to keep, as one value (replaces `save_every` and `track_energies`);
        ``SaveAt(every=None)`` keeps step 0 and the last step only.

    Returns
    -------
    Solution
        Memory is O(samples): 10⁹ steps with ``save_every=10**6`` keep 1001 states. A run whose
        state turns non-finite stops with status ``"blow-up"``; Ctrl-C stops it with
        ``"interrupted"``; both keep every sample taken.

    Warns
    -----
    RuntimeWarning
        When some hω̃_j (hω_j for trigonometric methods, the modified frequency for modified
        methods) lies near a non-zero multiple of π: |sin(hω̃_j)| < min(√h, 0.1) with
        hω̃_j > π/2. Below √h the paper's non-resonance condition (3.2), κ = min_j |sin(hω̃_j)|
        ≥ √h, fails, and the error bounds of its Theorems 3.1 and 3.2 grow like 1/κ: the
        energies may drift far or blow up (FPU at hω = 3.14159265: a deviation of 10⁴). The cap
        0.1 keeps step sizes outside the theory's regime of small h (h > 0.01, where √h > 0.1)
        from being warned far from the resonance. Exactly at a multiple of π the two-step form
        is undefined and raises ValueError. Also warns when a run stops early (blow-up, Ctrl-C).

    Notes
    -----
    A problem with a large sparse stiffness matrix (``path="krylov"``) is stepped in the
    one-step form (the same method; the two-step form's momentum divides by χ(h√A)) with each
    matrix function applied by the Lanczos method; ``Solution.info`` reports the iterations.
    Its frequencies are never computed, so no resonance warning is given there.

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
    h = _check.step_size(h)
    n_steps = resolve_steps(h, t_end, n_steps)
    if saveat is None:
        save_every = check_steps(positive_int(save_every, "save_every"), "save_every")
    saveat = SaveAt.resolve(saveat, save_every, track_energies)
    save_every = saveat.every if saveat.every is not None else max(n_steps, 1)
    track_energies = saveat.track_energies
    form = check_form(form)
    q0 = checked_state(problem.as_state(q0, "q0"), "q0", problem.dim)
    p0 = checked_state(problem.as_state(p0, "p0"), "p0", problem.dim)
    n_samples = n_steps // save_every + 2
    if sample_bytes(problem, n_samples) > MAX_SAMPLE_BYTES:
        raise ValueError(
            f"save_every: {n_samples} samples of {problem.dim} coordinates would need more than "
            f"{MAX_SAMPLE_BYTES / 2**30:.3g} GiB (a quarter of this machine's memory, at most 8 GiB); "
            "increase save_every"
        )
    stepper = problem.stepper  # the recursion, or the Krylov step (trigint._steppers)
    co = method_coefficients(problem, method, h, form) if stepper.has_spectrum else None
    # A problem with its own resonance theory (a wave equation) warns after the run, knowing which
    # modes carry energy; the others by the ODE condition (3.2), before it.
    own_warning = getattr(problem, "warn_resonances", None)
    if co is not None and own_warning is None:
        warn_near_resonance(co, method)
    # a step that calls Python or runs Lanczos iterations is slow: the progress bar shows sooner
    slow = isinstance(problem.potential, PythonPotential) or not stepper.has_spectrum
    every = PROGRESS_EVERY_PYTHON if slow else PROGRESS_EVERY_NATIVE
    callback, close = progress_callback(progress, n_steps, slow)
    out = None
    try:
        out = stepper.run_one(problem, method, co, h, q0, p0, n_steps, save_every, form, bool(track_energies),
                              every, callback)
    finally:
        close(None if out is None else int(out.steps_done[0]))
    if out.interrupted_by is not None and "KeyboardInterrupt" not in out.interrupted_by:
        raise RuntimeError(f"progress callback failed: {out.interrupted_by}")
    sol = _solution(problem, method, h, n_steps, out, co)
    if own_warning is not None:
        own_warning(sol, method, stacklevel=3)
    return sol


def method_coefficients(problem, method: Method, h: float, form: str):
    """``method.coefficients(h, problem.omega, form)``, kept on the problem for the next call
    with the same method object, h and form (a wave problem's 2¹⁶ frequencies take 17 ms to
    evaluate)."""
    return _native.kept_on(problem, "_coefficients_kept", (id(method), h, form), method,
                           lambda: method.coefficients(h, problem.omega, form=form))


def warn_near_resonance(co, method: Method, stacklevel: int = 3) -> None:
    """The warning of integrate()'s docstring: hω̃_j near a non-zero multiple of π (`stacklevel`
    points at the user's call)."""
    xt = np.where(co.omega > 0, co.xi_tilde, 0.0)
    kappa = np.abs(np.sin(xt))
    bound = min(float(np.sqrt(co.h)), NEAR_RESONANCE_SIN)
    near = np.flatnonzero((xt > np.pi / 2) & (kappa < bound))
    if near.size == 0:
        return
    j = int(near[np.argmin(kappa[near])])
    k = int(np.rint(xt[j] / np.pi))
    name = "h*omega" if co.xi_tilde[j] == co.xi[j] else "h*omega_tilde"
    warnings.warn(
        f"numerical resonance: {name}[{j}] = {xt[j]:.10g} is {abs(xt[j] - k * np.pi):.3g} from {k}*pi; "
        f"|sin({name}[{j}])| = {kappa[j]:.3g} < {bound:.3g} = min(sqrt(h), {NEAR_RESONANCE_SIN:g}), so the "
        f"non-resonance condition (3.2) of Cohen, Gauckler, Hairer, Lubich (2015) fails and the energies may "
        f"drift or blow up (method {method.name!r}, h = {co.h:.6g}). Choose h with {name}[{j}] away from "
        "multiples of pi; trigint.resonance.analyze(h, omega) checks a step size",
        RuntimeWarning, stacklevel=stacklevel)


def _solution(problem, method, h, n_steps, out, co=None) -> Solution:
    names, index = _native.channel_index(problem.n_blocks, problem.n_axes)
    samples = out.samples[0]
    max_deviation, initial_energies = out.max_deviation[0], out.initial_energies[0]
    if co is not None and not _modified_is_finite(problem, co):
        # one-step form at hω = kπ with a filter whose σ has no limit there (E, A)
        k = index["modified_oscillatory"]
        samples["energies"][:, k] = np.nan
        max_deviation[k] = initial_energies[k] = np.nan
        j = int(np.flatnonzero(~np.isfinite(co.modified_p))[0])
        warnings.warn(f"the modified oscillatory energy is undefined at h*omega[{j}] = {co.xi[j]:.12g} for "
                      f"method {method.name!r} (sigma = sinc*phi/psi has no finite limit there); it is NaN",
                      RuntimeWarning, stacklevel=3)
    steps = samples["steps"].astype(np.int64)
    t = steps * h
    energies = Deferred(problem.energy_dataset, names, samples["energies"], {"t": t, "step": ("t", steps)},
                        {"method": repr(method), "h": h})
    status, message = out.status[0], out.messages[0]
    if status != "completed":
        warnings.warn(message, RuntimeWarning, stacklevel=3)
    return Solution(
        t=t, q=samples["q"], p=samples["p"], steps=steps, _energies=energies,
        max_deviation=Channels.of(names, index, max_deviation),
        initial_energies=Channels.of(names, index, initial_energies),
        h=h, n_steps=int(out.steps_done[0]), n_steps_requested=n_steps,
        status=status, message=message, method=method, problem=problem,
        info=dict(out.info),
    )


def _modified_is_finite(problem, co) -> bool:
    """Whether the modified energy's weights of `co` are finite, kept on the problem with the
    coefficients (a scan of 2¹⁶ weights at every call otherwise)."""
    return _native.kept_on(problem, "_modified_finite", id(co), co,
                           lambda: bool(np.all(np.isfinite(co.modified_p))))


def resolve_steps(h: float, t_end, n_steps) -> int:
    if (t_end is None) == (n_steps is None):
        raise ValueError("t_end, n_steps: give exactly one of them")
    if n_steps is not None:
        return check_steps(positive_int(n_steps, "n_steps"), "n_steps")
    t_end = _check.number(t_end, "t_end")
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


def positive_int(value, name: str, allow_zero: bool = False) -> int:
    if not _check.is_integer(value):
        raise _check.IntegerTypeError(f"{name}: expected an integer, got {_check.shown(value)} "
                                      f"({type(value).__name__})")
    if value < (0 if allow_zero else 1):
        raise ValueError(f"{name}: must be {'>= 0' if allow_zero else '>= 1'}, got {value}")
    return int(value)


def checked_state(x, name: str, n: int) -> np.ndarray:
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


def progress_callback(progress, n_steps: int, slow: bool):
    """A (callback, close) pair: a tqdm bar, the user's callable, or nothing."""
    if callable(progress) and not isinstance(progress, bool):
        return progress, lambda done=None: None
    if progress is not None and not isinstance(progress, bool | np.bool_):
        raise TypeError(f"progress: expected True, False, None or a callable, got {type(progress).__name__}")
    long_run = n_steps >= PROGRESS_BAR_FROM or (slow and n_steps >= 10**5)
    show = progress if progress is not None else (long_run and progress_report.interactive())
    if not show:
        return None, lambda done=None: None
    bar = progress_report.bar(n_steps, "step", "integrate", unit_scale=True)

    def update(done: int) -> None:
        bar.update(done - bar.n)

    def close(done: int | None = None) -> None:
        """The bar at the last step taken (the core reports every 2¹⁰ or 2²⁰ steps), closed."""
        if done is not None:
            update(int(done))
        bar.close()

    return update, close
