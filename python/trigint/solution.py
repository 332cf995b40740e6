"""The result of a run: samples, energies and the streamed diagnostics."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import xarray as xr


@dataclass(frozen=True)
class Solution:
    """A numerical solution, sampled at steps 0, s, 2s, … and the last step.

    Attributes
    ----------
    t, q, p : arrays
        Sample times (shape (m,)) and states (shape (m, n)).
    steps : array of int
        The step index of each sample.
    energies : xarray.Dataset
        Every energy over ``t`` at the samples: ``total``, ``oscillatory``, ``slow``,
        ``modified_oscillatory`` and ``oscillatory_1`` … ``oscillatory_ℓ``.
    max_deviation : dict
        max |E(t_n) − E(0)| per energy over every step n (streamed, not from the samples).
    initial_energies : dict
        E(0) per energy.
    h : float
        The step size.
    n_steps : int
        The last step reached (the requested number unless the run stopped early).
    n_steps_requested : int
        The number of steps asked for.
    status : str
        ``"completed"``, ``"blow-up"`` or ``"interrupted"``; `message` says more.
    message : str
        How the run ended, in words.
    success : bool
        True when every requested step was taken (``status == "completed"``).
    method : Method
        The method that ran.
    problem : OscillatoryProblem
        The problem it ran on.
    info : dict
        How the run went beyond the energies: on the Krylov path, the Lanczos ``iterations``
        (total), ``products`` (matrix functions applied), ``iterations_per_product`` and
        ``tolerance``; empty otherwise.

    Examples
    --------
    >>> import trigint as ti
    >>> prob = ti.problems.fpu(); q0, p0 = ti.problems.fpu_initial()
    >>> sol = ti.integrate(prob, "B", q0, p0, h=0.04, n_steps=100, save_every=50)
    >>> sol.steps.tolist(), sol.status, sol.q.shape
    ([0, 50, 100], 'completed', (3, 6))
    """

    t: np.ndarray
    q: np.ndarray
    p: np.ndarray
    steps: np.ndarray
    energies: xr.Dataset
    max_deviation: dict
    initial_energies: dict
    h: float
    n_steps: int
    n_steps_requested: int
    status: str
    message: str
    method: object = field(repr=False)
    problem: object = field(repr=False)
    info: dict = field(default_factory=dict, repr=False)

    @property
    def success(self) -> bool:
        """True when every requested step was taken."""
        return self.status == "completed"

    def deviation(self, energy: str = "oscillatory") -> xr.DataArray:
        """E(t) − E(0) at the samples for one energy.

        Parameters
        ----------
        energy : str
            A name of `energies`: ``"oscillatory"``, ``"total"``, ``"slow"``,
            ``"modified_oscillatory"`` or ``"oscillatory_j"``.
        """
        if energy not in self.energies:
            raise KeyError(f"energy: unknown name {energy!r}; valid: {list(self.energies.data_vars)}")
        return self.energies[energy] - self.initial_energies[energy]

    def __repr__(self) -> str:
        devs = ", ".join(f"{k}={v:.3e}" for k, v in self.max_deviation.items())
        return (
            f"Solution(status={self.status!r}, method={self.method!r}, h={self.h:g}, "
            f"n_steps={self.n_steps}, samples={self.t.size}, max_deviation: {devs})"
        )
