"""The energies of paper §2.1 and §3 at given states, computed by the core as its runs observe
them (the channel table, the observing sweep's sums): :func:`trigint.energies`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from . import _native
from .methods import Method
from .problem import OscillatoryProblem

if TYPE_CHECKING:  # imported where a Dataset is made, so that `import trigint` loads no xarray (nor pandas)
    import xarray as xr


def energy_names(n_blocks: int, n_axes: int = 0) -> list[str]:
    """Channel names in output order, from the core's channel table (``_core.CHANNELS``): the
    whole-state channels (total, oscillatory, slow, modified_oscillatory, …), then
    oscillatory_1 … oscillatory_ℓ, then (a wave equation's momentum, `n_axes` components)
    momentum_1 … momentum_d.

    Parameters
    ----------
    n_blocks : int
        ℓ, the problem's number of oscillatory blocks.
    n_axes : int
        The number of per-axis channels (0 unless the problem has a momentum).

    Examples
    --------
    >>> energy_names(2)[:3], energy_names(2)[-2:]
    (['total', 'oscillatory', 'slow'], ['oscillatory_1', 'oscillatory_2'])
    """
    return _native.channel_names(n_blocks, n_axes)


def energies(problem: OscillatoryProblem, q, p, method: Method | str | None = None,
             h: float | None = None) -> xr.Dataset:
    """All energies at states (q, p) of shape (n,) or (m, n).

    For a stiffness matrix A the block energies are ½(|P_j p|² + ω_j²|P_j q|²) with the
    spectral projectors P_j of A, and H_slow = ½|P₀p|² + U(q).

    Parameters
    ----------
    problem : OscillatoryProblem
    q, p : array of float, shape (n,) or (m, n)
        One state, or m states as rows; for a wave problem also grid values, of the grid's
        shape or ``(m, *grid)``.
    method : Method or str, optional
        With `h`: the method whose modified oscillatory energy (3.4) is added.
    h : float, optional
        The step size of `method`.

    Returns
    -------
    xarray.Dataset
        Every channel a run streams, in the core's order (:func:`energy_names`): ``total``,
        ``oscillatory`` (H_ω), ``slow`` (½|p₀|² + U), ``kinetic`` (½|p₀|²), ``oscillatory_1`` …
        (the I_j), a wave equation's ``momentum_1`` …, and, when `method` and `h` are given,
        ``modified_oscillatory`` (H*_ω or H*_ω̃); over a ``sample`` dimension for 2-d input.
        Computed by the core as a run observes its initial state: at a run's samples these
        are the streamed values (bit for bit where no modal basis or grid map rounds the
        samples on their way back).

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

    # a wave problem's grid values, (*grid) or (m, *grid), as flat states
    q = _check.real_array(problem.as_state(q, "q"), "q", ndim=None, finite=False)
    p = _check.real_array(problem.as_state(p, "p"), "p", ndim=None, finite=False)
    if q.shape != p.shape or q.ndim not in (1, 2) or q.shape[-1] != problem.dim:
        raise ValueError(
            f"q, p: expected equal shapes (n,) or (m, n) with n = {problem.dim}, got {q.shape} and {p.shape}"
        )
    if (method is None) != (h is None):
        raise ValueError("method, h: give both (for the modified oscillatory energy) or neither")
    if method is not None:
        from ._method_names import resolve_method

        method = resolve_method(method)
    import xarray as xr

    data = problem.stepper.state_energies(problem, np.atleast_2d(q), np.atleast_2d(p), method, h)
    if q.ndim == 1:
        return xr.Dataset({k: ((), v[0]) for k, v in data.items()})
    return xr.Dataset({k: ("sample", v) for k, v in data.items()})
