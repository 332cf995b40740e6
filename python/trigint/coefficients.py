"""A method's numbers at one step size: the record every method returns and the core runs on."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: relative tolerance of the symplecticity test ψ = χφ
SYMPLECTIC_RTOL = 1e-12


@dataclass(frozen=True)
class Coefficients:
    """Per-coordinate numbers of a method at step size h (all arrays of shape (n,)).

    For slow coordinates (ω = 0) everything is that of Störmer–Verlet: c = χ = ψ = φ = 1.
    Returned by :meth:`Method.coefficients`; the kernels run on these numbers alone.

    Attributes
    ----------
    h : float
        The step size.
    omega : array
        The frequencies ω_i.
    xi : array
        hω_i.
    xi_tilde : array
        hω̃_i, the modified frequencies times h (equal to `xi` for trigonometric methods).
    cos, sin : array
        cos(hω̃_i) and sin(hω̃_i).
    one_minus_cos : array
        1 − cos(hω̃_i) = 2 sin²(½hω̃_i), to full relative precision (the kernels use it).
    chi, psi, phi : array
        χ(hω̃_i), ψ(hω̃_i), φ(hω̃_i): the momentum factor and the two filters of (2.5).
    sigma : array
        σ(hω̃_i) = sinc(hω̃_i) φ/ψ (paper (3.3)); 0 on slow coordinates.
    modified_p, modified_q : array
        Weights of ½p_i² and ½q_i² in the modified oscillatory energy (3.4); NaN where σ is
        undefined (the one-step form at hω = kπ for some filters).
    psi_over_chi, sin2_over_h_chi : array
        The one-step form's numbers ψ/χ and sin²(hω̃)/(hχ), with their limits where χ = 0.
    symplectic : bool
        Whether ψ = χφ at every oscillatory coordinate (paper (2.4)).

    Examples
    --------
    >>> import trigint as ti
    >>> co = ti.Trigonometric("B").coefficients(0.1, [0.0, 10.0])
    >>> co.sigma.tolist(), round(float(co.chi[1]), 8)
    ([0.0, 1.0], 0.84147098)
    """

    h: float
    omega: np.ndarray
    xi: np.ndarray
    xi_tilde: np.ndarray
    cos: np.ndarray
    one_minus_cos: np.ndarray
    sin: np.ndarray
    chi: np.ndarray
    psi: np.ndarray
    phi: np.ndarray
    sigma: np.ndarray
    modified_p: np.ndarray
    modified_q: np.ndarray
    psi_over_chi: np.ndarray
    sin2_over_h_chi: np.ndarray

    @property
    def symplectic(self) -> bool:
        """ψ = χ φ at every oscillatory coordinate (paper (2.4))."""
        fast = self.omega > 0
        return bool(np.allclose(self.psi[fast], (self.chi * self.phi)[fast], rtol=SYMPLECTIC_RTOL, atol=0))
