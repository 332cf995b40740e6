"""The energies of paper §2.1 and §3 as quadratic forms on arrays (NumPy).

Shared by :func:`trigint.energies` and the tests; the core streams the same forms.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from . import _native
from .coefficients import Coefficients
from .methods import Method
from .problem import OscillatoryProblem


def energy_names(n_blocks: int, n_axes: int = 0) -> list[str]:
    """Channel names in output order, from the core's channel table (``_core.CHANNELS``): total,
    oscillatory, slow, modified_oscillatory, then oscillatory_1 … oscillatory_ℓ, then (a wave
    equation's momentum, `n_axes` components) momentum_1 … momentum_d.

    Parameters
    ----------
    n_blocks : int
        ℓ, the problem's number of oscillatory blocks.
    n_axes : int
        The number of per-axis channels (0 unless the problem has a momentum).

    Examples
    --------
    >>> energy_names(2)
    ['total', 'oscillatory', 'slow', 'modified_oscillatory', 'oscillatory_1', 'oscillatory_2']
    """
    return _native.channel_names(n_blocks, n_axes)


def layout(problem: OscillatoryProblem, coefficients: Coefficients | None) -> dict:
    """Per-coordinate weights of the quadratic forms, as the core consumes them.

    I_j = Σ_{i in block j} ½(p_i² + ω_i² q_i²); the modified oscillatory energy is
    Σ_i ½(a_i p_i² + b_i q_i²) with a = σ (χ/sinc(hω̃))², b = σ ω̃² (paper (3.4) and
    §3.2); for trigonometric methods a = σ, b = σ ω².
    """
    omega = problem.omega
    fast = omega > 0
    if coefficients is None:
        modified_p = np.full(omega.size, np.nan)
        modified_q = np.full(omega.size, np.nan)
    else:
        modified_p = np.where(fast, coefficients.modified_p, 0.0)
        modified_q = np.where(fast, coefficients.modified_q, 0.0)
    return dict(omega2=omega**2, modified_p=modified_p, modified_q=modified_q,
                block=problem.blocks, n_blocks=problem.n_blocks)


def energies(problem: OscillatoryProblem, q, p, method: Method | str | None = None,
             h: float | None = None) -> xr.Dataset:
    """All energies at states (q, p) of shape (n,) or (m, n).

    For a stiffness matrix A the block energies are ½(|P_j p|² + ω_j²|P_j q|²) with the
    spectral projectors P_j of A, and H_slow = ½|P₀p|² + U(q).

    Parameters
    ----------
    problem : OscillatoryProblem
    q, p : array of float, shape (n,) or (m, n)
        One state, or m states as rows.
    method : Method or str, optional
        With `h`: the method whose modified oscillatory energy (3.4) is added.
    h : float, optional
        The step size of `method`.

    Returns
    -------
    xarray.Dataset
        ``total``, ``oscillatory`` (H_ω), ``slow`` (½|p₀|² + U), ``oscillatory_1`` … (the I_j)
        and, when `method` and `h` are given, ``modified_oscillatory`` (H*_ω or H*_ω̃); over a
        ``sample`` dimension for 2-d input.

    Examples
    --------
    >>> import trigint as ti
    >>> prob = ti.problems.fpu(m=3, omega=50.0)
    >>> q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
    >>> round(float(ti.energies(prob, q0, p0)["total"]), 8)
    2.00120008
    """
    if not isinstance(problem, OscillatoryProblem):
        raise TypeError(f"problem: expected an OscillatoryProblem, got {type(problem).__name__}")
    from . import _check

    q = _check.real_array(q, "q", ndim=None, finite=False)
    p = _check.real_array(p, "p", ndim=None, finite=False)
    if q.shape != p.shape or q.ndim not in (1, 2) or q.shape[-1] != problem.dim:
        raise ValueError(
            f"q, p: expected equal shapes (n,) or (m, n) with n = {problem.dim}, got {q.shape} and {p.shape}"
        )
    if (method is None) != (h is None):
        raise ValueError("method, h: give both (for the modified oscillatory energy) or neither")
    data = problem.stepper.whole_state_energies(problem, q, p, method, h)
    if data is not None:  # computed by the stepper (no frequencies on the Krylov path)
        if q.ndim == 1:
            return xr.Dataset({k: ((), v[0]) for k, v in data.items()})
        return xr.Dataset({k: ("sample", v) for k, v in data.items()})
    if method is not None:
        from ._method_names import resolve_method

        method = resolve_method(method)
    coefficients = method.coefficients(h, problem.omega) if method is not None else None
    w = layout(problem, coefficients)
    q_user = np.atleast_2d(q)
    q2, p2 = np.atleast_2d(q), np.atleast_2d(p)
    if problem.coordinate_map is not None:
        q2, p2 = problem.coordinate_map.to_core(q2), problem.coordinate_map.to_core(p2)
        q_user = q2
    if problem.basis is not None:
        # the quadratic forms in the modal coordinates x = Qᵀq: |P_j q|² = |x_j|²
        q2, p2 = q2 @ problem.basis, p2 @ problem.basis
    per_coordinate = 0.5 * (p2**2 + w["omega2"] * q2**2)
    order = np.argsort(w["block"], kind="stable")
    starts = np.searchsorted(w["block"][order], np.arange(w["n_blocks"] + 1))
    sums = np.add.reduceat(per_coordinate[:, order], starts, axis=1) if per_coordinate.shape[1] else per_coordinate
    present = np.bincount(w["block"], minlength=w["n_blocks"] + 1) > 0
    blocks = [sums[:, j] if present[j] else np.zeros(q2.shape[0]) for j in range(w["n_blocks"] + 1)]
    oscillatory = np.sum(blocks[1:], axis=0) if w["n_blocks"] else np.zeros(q2.shape[0])
    slow = blocks[0] + problem.potential.value(q_user)
    data = dict(total=oscillatory + slow, oscillatory=oscillatory, slow=slow)
    if coefficients is not None:
        data["modified_oscillatory"] = (0.5 * (w["modified_p"] * p2**2 + w["modified_q"] * q2**2)).sum(axis=1)
    for j in range(1, w["n_blocks"] + 1):
        data[f"oscillatory_{j}"] = blocks[j]
    if q.ndim == 1:
        return xr.Dataset({k: ((), v[0]) for k, v in data.items()})
    return xr.Dataset({k: ("sample", v) for k, v in data.items()})
