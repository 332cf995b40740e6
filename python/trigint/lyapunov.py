"""Tangent maps and Lyapunov spectra of the integrator's own step.

The two-step recursion (2.5) that :func:`~trigint.integrate` steps is a map of the state; its
exact linearization along the trajectory is the same recursion on a deviation (δq, δp) with the
force replaced by its derivative G(x)δ = −∇²U(x)δ,

    δq_{n+1} − 2cos(hΩ̃)δq_n + δq_{n−1} = h²Ψ G(Φq_n) Φδq_n,    2hχ δp_n = δq_{n+1} − δq_{n−1},

started like (2.3). The core carries it beside the trajectory (the trajectory's bits are those of
``integrate``), with the second derivatives exact for every native potential kind (FPU,
compiled expressions, chains and wave equations, from the tape), a user Hessian–vector product
for a :class:`~trigint.PythonPotential`, or, when asked for, central differences of its gradient.

:func:`lyapunov` turns this into finite-time Lyapunov exponents: one vector by renormalized
growth, several by Benettin's method with QR re-orthonormalization (Benettin, Galgani,
Giorgilli, Strelcyn, Meccanica 15 (1980); the tangent map method of Skokos, Lect. Notes Phys.
790 (2010)), with the MEGNO chaos indicator ⟨Y⟩ of the leading vector (Cincotta, Simó, Astron.
Astrophys. Suppl. 147 (2000)): ⟨Y⟩ → 2 on a regular (quasi-periodic) orbit, ⟨Y⟩ ≈ λt/2 on a
chaotic one. :func:`tangent_map` applies the linearized map itself.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import _check
from ._deviation import RENORMALIZE_EVERY, default_deviation
from ._method_names import resolve_method
from .integrate import (
    MAX_SAMPLE_BYTES,
    checked_state,
    method_coefficients,
    positive_int,
    progress_callback,
    resolve_steps,
)
from .potentials import PythonPotential
from .problem import OscillatoryProblem
from .saveat import check_steps


def history_bytes(samples: int, k: int) -> int:
    """Memory of a history of `samples` samples: each its step, Σ ln R_jj of k vectors (a vector
    of its own in the core) and the MEGNO, in the core and again in the result."""
    return samples * 2 * (8 * (k + 2) + 48)

#: renormalize every this many steps unless told (see :mod:`trigint._deviation`)
DEFAULT_RENORMALIZE_EVERY = RENORMALIZE_EVERY

#: history samples kept by default: about this many over the run
DEFAULT_SAMPLES = 1000


@dataclass(frozen=True)
class LyapunovResult:
    """Finite-time Lyapunov exponents of a trajectory of the numerical map.

    Attributes
    ----------
    exponents : ndarray of shape (K,)
        The finite-time spectrum at the last step, λ_j = (1/t) Σ ln R_jj of the j-th vector
        (Benettin's order, which is largest first in the limit; at finite t neighbours may
        still be out of order). After a blow-up, those at the last re-orthonormalization
        before it (NaN if there was none), whatever `sample_every`.
    history : xarray.DataArray
        The spectrum over time, dims ``(t, exponent)``, sampled at re-orthonormalizations
        (every `sample_every` steps, and after a blow-up at the last one before it).
    megno : xarray.DataArray
        The time-averaged MEGNO ⟨Y⟩ of the leading vector over ``t``.
    t_end : float
        The time reached, `steps_done` · h (after a blow-up, the exponents are those of the
        last re-orthonormalization before it: the last ``t`` of `history`).
    status : str
        ``"completed"``, ``"blow-up"`` or ``"interrupted"``.
    message : str
        What happened, in words (empty when completed).
    q, p : ndarray
        The trajectory's state at step `steps_done` (the state ``integrate`` reaches, bit for
        bit); after a blow-up, the last state whose q and p are finite. ``integrate`` asks its
        energies to be finite too, so where H overflows first (|p| beyond about 1e154) it stops
        one step earlier.
    dq, dp : ndarray of shape (K, n)
        The orthonormal deviation vectors at the last step (after a blow-up, as they were
        when it was found: not finite where a deviation blew up).
    second_derivatives : str
        ``"exact"``, ``"user hessian_vector"`` or ``"central differences"``.
    steps_done : int
        Steps taken.
    h : float
        The step size.
    method : Method
        The method.
    renormalize_every : int
        Steps between re-orthonormalizations.
    leading : float
        ``exponents[0]``.
    info : dict
        Anything else a run reports.
    """

    exponents: np.ndarray
    history: object
    megno: object
    t_end: float
    steps_done: int
    status: str
    message: str
    q: np.ndarray
    p: np.ndarray
    dq: np.ndarray
    dp: np.ndarray
    h: float
    method: object
    second_derivatives: str
    renormalize_every: int
    info: dict = field(default_factory=dict)

    @property
    def leading(self) -> float:
        """The largest finite-time exponent."""
        return float(self.exponents[0])

    def __repr__(self) -> str:
        shown = ", ".join(f"{x:.4g}" for x in self.exponents[:6])
        more = ", …" if self.exponents.size > 6 else ""
        megno = float(self.megno.values[-1]) if self.megno.size else float("nan")
        return (f"LyapunovResult({self.method.name}, h={self.h:g}, t={self.t_end:g}, {self.status}: "
                f"exponents [{shown}{more}], MEGNO {megno:.3g}, {self.second_derivatives} second derivatives)")

    def plot(self, ax=None):
        """The finite-time exponents against t (log-scaled time).

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Where to draw (default: a new figure).

        Returns
        -------
        matplotlib Axes
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 4))
        t = self.history["t"].values
        for j in range(self.history.shape[1]):
            ax.plot(t, self.history.values[:, j], lw=1, label=f"λ{j + 1}")
        ax.set_xscale("log")
        ax.set_xlabel("t")
        ax.set_ylabel("finite-time exponent")
        ax.axhline(0, color="0.6", lw=0.5)
        if self.history.shape[1] <= 8:
            ax.legend(loc="upper right", fontsize="small")
        ax.set_title(f"{self.method.name}, h = {self.h:g}")
        return ax


def lyapunov(problem: OscillatoryProblem, method, q0, p0, *, h: float, t_end: float | None = None,
             n_steps: int | None = None, n_exponents: int = 1, deviation=None,
             renormalize_every: int = DEFAULT_RENORMALIZE_EVERY, sample_every: int | None = None,
             finite_differences: bool = False, progress=None) -> LyapunovResult:
    """The finite-time Lyapunov spectrum of the numerical map along the trajectory from (q0, p0).

    The deviation vectors follow the exact tangent map of the step ``integrate`` takes (the
    two-step form; on the Krylov path the one-step form, as ``integrate`` steps it there); every
    `renormalize_every` steps they are re-orthonormalized (Gram–Schmidt, the QR of Benettin's
    method) and λ_j(t) = (1/t) Σ ln R_jj accumulates. Norms and inner products are the
    Euclidean ones of (δq, δp) in the coordinates q0, p0 are given in (grid values for a wave
    problem, the original coordinates for a stiffness matrix).

    Parameters
    ----------
    problem, method, q0, p0, h, t_end, n_steps
        As for :func:`~trigint.integrate`.
    n_exponents : int
        How many exponents, 1 … 2n (2n: the full spectrum, which sums to zero: the map preserves
        volume).
    deviation : (dq0, dp0), optional
        Initial deviation vectors, arrays of shape (n,) or (n_exponents, n); orthonormalized
        before the first step. Default: deterministic, the Q factor of a standard normal
        (2n × n_exponents) matrix drawn with ``numpy.random.default_rng(20150)``
        (``from trigint.lyapunov import default_deviation``), in general position.
    renormalize_every : int
        Steps between re-orthonormalizations (default 16).
    sample_every : int, optional
        Steps between samples of the history, a multiple of `renormalize_every` (default: about
        1000 samples).
    finite_differences : bool
        For a :class:`~trigint.PythonPotential` without ``hessian_vector``, or a wave's
        potential given as Python functions (V, V') without V'': allow central differences of
        its gradient (labelled in the result). Every other kind is exact.
    progress : bool or callable, optional
        As for :func:`~trigint.integrate`.

    Returns
    -------
    LyapunovResult

    Examples
    --------
    A linear problem (U = 0) has exponents → 0 like 1/t:

    >>> import numpy as np, trigint as ti
    >>> prob = ti.OscillatoryProblem(omega=[0.0, 5.0], potential=ti.ExpressionPotential("0*a*b", ["a", "b"]))
    >>> res = ti.lyapunov(prob, "B", [1.0, 0.1], [0.0, 0.0], h=0.1, t_end=1000, n_exponents=4)
    >>> bool(np.all(np.abs(res.exponents) < 0.02)), abs(float(res.exponents.sum())) < 1e-10
    (True, True)
    """
    import xarray as xr

    if not isinstance(problem, OscillatoryProblem):
        raise TypeError(f"problem: expected an OscillatoryProblem, got {type(problem).__name__}")
    method = resolve_method(method)
    h = _check.step_size(h)
    n_steps = resolve_steps(h, t_end, n_steps)
    n = problem.dim
    if not _check.is_integer(n_exponents) or not 1 <= n_exponents <= 2 * n:
        raise ValueError(f"n_exponents: must be an integer from 1 to 2n = {2 * n} (the state has 2n numbers), "
                         f"got {n_exponents!r}")
    k = int(n_exponents)
    renormalize_every = check_steps(positive_int(renormalize_every, "renormalize_every"), "renormalize_every")
    if sample_every is None:
        sample_every = renormalize_every * max(1, n_steps // (renormalize_every * DEFAULT_SAMPLES))
    sample_every = check_steps(positive_int(sample_every, "sample_every"), "sample_every")
    if sample_every % renormalize_every:
        raise ValueError(f"sample_every: must be a multiple of renormalize_every = {renormalize_every}, "
                         f"got {sample_every}")
    samples = n_steps // sample_every + 2  # and the last step, and a blow-up's last re-orthonormalization
    if history_bytes(samples, k) > MAX_SAMPLE_BYTES:
        raise ValueError(
            f"sample_every: {samples} samples of {k} exponents would need more than "
            f"{MAX_SAMPLE_BYTES / 2**30:.3g} GiB (a quarter of this machine's memory, at most 8 GiB); "
            "increase sample_every")
    q0 = checked_state(problem.as_state(q0, "q0"), "q0", n)
    p0 = checked_state(problem.as_state(p0, "p0"), "p0", n)
    dq0, dp0 = _deviations(problem, deviation, k)
    run = _TangentRun(problem, method, h, finite_differences)
    callback, close = progress_callback(progress, n_steps, run.slow)
    out = None
    try:
        out = run.call(q0, p0, dq0, dp0, n_steps, renormalize_every, sample_every, callback)
    finally:
        close(None if out is None else int(out["steps_done"]))
    steps = np.asarray(out["steps"], dtype=np.int64)
    t = steps * h
    growth = np.asarray(out["log_growth"])
    with np.errstate(invalid="ignore", divide="ignore"):
        spectrum = growth / t[:, None] if t.size else growth
    names = [f"λ{j + 1}" for j in range(k)]
    history = xr.DataArray(spectrum, dims=("t", "exponent"), coords={"t": t, "step": ("t", steps),
                                                                      "exponent": names},
                           name="lyapunov", attrs={"method": repr(method), "h": h})
    megno = xr.DataArray(np.asarray(out["megno"]), dims=("t",), coords={"t": t}, name="megno")
    exponents = spectrum[-1].copy() if t.size else np.full(k, np.nan)
    if out["status"] != "completed":
        import warnings

        warnings.warn(out["message"], RuntimeWarning, stacklevel=2)
    return LyapunovResult(
        exponents=exponents, history=history, megno=megno, t_end=float(int(out["steps_done"]) * h),
        steps_done=int(out["steps_done"]), status=out["status"], message=out["message"],
        q=np.asarray(out["q"]), p=np.asarray(out["p"]), dq=np.asarray(out["dq"]), dp=np.asarray(out["dp"]),
        h=h, method=method, second_derivatives=run.second_derivatives, renormalize_every=renormalize_every,
    )


def tangent_map(problem: OscillatoryProblem, method, q0, p0, dq, dp, *, h: float, n_steps: int = 1,
                finite_differences: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The linearized numerical map applied to deviations: (δq_N, δp_N) = DΦ_h^N(q0, p0)·(δq, δp),
    Φ_h the step of :func:`~trigint.integrate` (two-step form, p_n by the central difference).

    Parameters
    ----------
    problem, method, q0, p0, h
        As for :func:`~trigint.integrate`.
    dq, dp : array of shape (n,) or (K, n)
        The deviations (K of them as rows), in the user's coordinates; for a wave problem
        also grid values, of the grid's shape or ``(K, *grid)``.
    n_steps : int
        How many steps N the map spans (default 1).
    finite_differences : bool
        As for :func:`lyapunov`.

    Returns
    -------
    dq_N, dp_N : arrays of the shape of `dq`
        The image of the deviations, exact to rounding.

    Examples
    --------
    >>> import numpy as np, trigint as ti
    >>> prob = ti.problems.fpu(m=1, omega=10)
    >>> dq, dp = ti.tangent_map(prob, "B", [1.0, 0.1], [0.0, 0.0], [1e-8, 0.0], [0.0, 0.0], h=0.05)
    >>> a = ti.integrate(prob, "B", [1.0 + 1e-8, 0.1], [0.0, 0.0], h=0.05, n_steps=1)
    >>> b = ti.integrate(prob, "B", [1.0, 0.1], [0.0, 0.0], h=0.05, n_steps=1)
    >>> bool(np.allclose(dq, a.q[-1] - b.q[-1], rtol=1e-6, atol=1e-15))
    True
    """
    if not isinstance(problem, OscillatoryProblem):
        raise TypeError(f"problem: expected an OscillatoryProblem, got {type(problem).__name__}")
    method = resolve_method(method)
    h = _check.step_size(h)
    n_steps = check_steps(positive_int(n_steps, "n_steps"), "n_steps")
    n = problem.dim
    q0 = checked_state(problem.as_state(q0, "q0"), "q0", n)
    p0 = checked_state(problem.as_state(p0, "p0"), "p0", n)
    dq_in, dp_in = (np.asarray(x, dtype=float) for x in (dq, dp))
    # a wave problem's grid-shaped deviations, (*grid) or (K, *grid), as flat rows
    dq_flat, dp_flat = problem.as_state(dq_in, "dq"), problem.as_state(dp_in, "dp")
    dq2, dp2 = np.atleast_2d(dq_flat), np.atleast_2d(dp_flat)
    if dq_in.shape != dp_in.shape or dq2.ndim != 2 or dq2.shape[1] != n:
        raise ValueError(f"dq, dp: expected arrays of shape ({n},) or (K, {n}), got {dq_in.shape} and {dp_in.shape}")
    _finite(dq2, "dq")
    _finite(dp2, "dp")
    run = _TangentRun(problem, method, h, finite_differences)
    out = run.call(q0, p0, dq2, dp2, n_steps, 0, n_steps, None)
    dq_out, dp_out = np.asarray(out["dq"]), np.asarray(out["dp"])
    return dq_out.reshape(dq_in.shape), dp_out.reshape(dp_in.shape)


def _finite(a: np.ndarray, name: str) -> None:
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: entries must be finite")


def _deviations(problem, deviation, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The initial deviations as K orthonormal rows (δq, δp) in the user's coordinates."""
    n = problem.dim
    if deviation is None:
        return default_deviation(n, k)
    try:
        dq, dp = deviation
    except (TypeError, ValueError):
        raise TypeError("deviation: expected a pair (dq0, dp0) of arrays of shape (n,) or (n_exponents, n)") from None
    dq, dp = np.asarray(dq, dtype=float), np.asarray(dp, dtype=float)
    # grid-shaped deviations of a wave problem, (k, *grid) or (*grid,) for k = 1, as rows
    dq, dp = (x.reshape(k, n) if x.size == k * n else np.atleast_2d(x) for x in (dq, dp))
    if dq.shape != (k, n) or dp.shape != (k, n):
        raise ValueError(f"deviation: expected dq0 and dp0 of shape ({k}, {n}) for n_exponents = {k}, "
                         f"got {dq.shape} and {dp.shape}")
    _finite(dq, "deviation")
    _finite(dp, "deviation")
    rows = np.hstack([dq, dp])
    norms = np.linalg.norm(rows, axis=1)
    if np.any(norms == 0):
        raise ValueError(f"deviation: vector {int(np.flatnonzero(norms == 0)[0])} is zero; a deviation needs a "
                         "direction")
    q, r = np.linalg.qr(rows.T)
    diag = np.abs(np.diag(r))
    if np.any(diag <= 1e-12 * norms.max()):
        raise ValueError("deviation: the vectors are linearly dependent; give independent ones")
    q = q * np.sign(np.diag(r))  # each vector keeps its direction
    rows = q.T
    return np.ascontiguousarray(rows[:, :n]), np.ascontiguousarray(rows[:, n:])


class _TangentRun:
    """A tangent run of one problem with one method and step size, by the problem's stepper."""

    def __init__(self, problem, method, h: float, finite_differences: bool):
        self.problem, self.method, self.h = problem, method, h
        pot = problem.potential
        self.slow = isinstance(pot, PythonPotential) or not problem.stepper.has_spectrum
        self.second_derivatives = "exact"
        differenced = False
        if isinstance(pot, PythonPotential):
            if pot.hessian_vector_function is not None:
                self.second_derivatives = "user hessian_vector"
            elif finite_differences:
                self.second_derivatives = "central differences"
                differenced = True
        self.potential = problem.stepper.tangent_potential(problem, differenced)
        # the recursion's coefficients (two-step form), kept per problem as integrate() keeps them
        self.co = method_coefficients(problem, method, h, "two-step") if problem.stepper.has_spectrum else None

    def call(self, q0, p0, dq0, dp0, n_steps, renormalize_every, sample_every, callback):
        every = 1 << 10 if self.slow else 1 << 16
        out = self.problem.stepper.tangent(self.problem, self.method, self.co, self.h, self.potential, q0, p0, dq0,
                                           dp0, n_steps, renormalize_every, sample_every, every, callback)
        if out["interrupted_by"] is not None and "KeyboardInterrupt" not in out["interrupted_by"]:
            raise RuntimeError(f"progress callback failed: {out['interrupted_by']}")
        return out

