"""What users would otherwise write: the same recursion in NumPy and in Numba, and SciPy's
DOP853 on the first-order system. FPU in the variables of GNI §I.5, method B (ψ = sinc, φ = 1)."""

from __future__ import annotations

import time

import numpy as np


def fpu_force(x: np.ndarray) -> np.ndarray:
    """g = −∇U for FPU, vectorized NumPy on one state: the m + 1 spring elongations d, then
    g₀ = −d³[:m] + s·d³[1:], g₁ = d³[:m] + s·d³[1:] with s = (1, …, 1, −1)."""
    m = x.size // 2
    x0, x1 = x[:m], x[m:]
    d = np.empty(m + 1)
    d[0] = x0[0] - x1[0]
    d[1:m] = x0[1:] - x1[1:] - x0[:-1] - x1[:-1]
    d[m] = x0[-1] + x1[-1]
    d3 = d**3
    sign = np.ones(m)
    sign[-1] = -1.0
    return np.r_[-d3[:m] + sign * d3[1:], d3[:m] + sign * d3[1:]]


def coefficients(h: float, omega: np.ndarray):
    xi = h * omega
    sinc = np.where(xi == 0, 1.0, np.sin(xi) / np.where(xi == 0, 1.0, xi))
    return 2 * np.cos(xi), h * h * sinc, np.cos(xi), h * sinc


def numpy_run(h: float, omega: np.ndarray, q0: np.ndarray, p0: np.ndarray, n_steps: int) -> np.ndarray:
    """The two-step recursion (trigo) with NumPy arrays, one step per Python iteration."""
    two_c, h2psi, c, hs = coefficients(h, omega)
    q_prev = q0.copy()
    q = c * q0 + hs * p0 + 0.5 * h2psi * fpu_force(q0)
    for _ in range(n_steps - 1):
        q_prev, q = q, two_c * q - q_prev + h2psi * fpu_force(q)
    return q


def numba_kernel():
    """The recursion compiled by Numba (scalar loops, as one would write it)."""
    import numba

    @numba.njit(cache=False, fastmath=False)
    def run(two_c, h2psi, c, hs, q0, p0, n_steps):
        n = q0.size
        m = n // 2
        q_prev = q0.copy()
        f = np.zeros(n)
        q = np.empty(n)

        def force(x, f):
            for i in range(n):
                f[i] = 0.0
            d = x[0] - x[m]
            d3 = d * d * d
            f[0] -= d3
            f[m] += d3
            for i in range(1, m):
                d = x[i] - x[m + i] - x[i - 1] - x[m + i - 1]
                d3 = d * d * d
                f[i] -= d3
                f[m + i] += d3
                f[i - 1] += d3
                f[m + i - 1] += d3
            d = x[m - 1] + x[n - 1]
            d3 = d * d * d
            f[m - 1] -= d3
            f[n - 1] -= d3

        force(q0, f)
        for i in range(n):
            q[i] = c[i] * q0[i] + hs[i] * p0[i] + 0.5 * h2psi[i] * f[i]
        for _ in range(n_steps - 1):
            force(q, f)
            for i in range(n):
                nxt = two_c[i] * q[i] - q_prev[i] + h2psi[i] * f[i]
                q_prev[i] = q[i]
                q[i] = nxt
        return q

    return run


def numba_run(h, omega, q0, p0, n_steps, kernel=None):
    kernel = kernel or numba_kernel()
    return kernel(*coefficients(h, omega), q0, p0, n_steps)


def scipy_run(omega: np.ndarray, q0: np.ndarray, p0: np.ndarray, t_end: float, rtol: float) -> dict:
    """DOP853 on q' = p, p' = −Ω²q + g(q); returns the time and the energy deviations."""
    from scipy.integrate import solve_ivp

    n = q0.size
    w2 = omega**2
    m = n // 2

    def rhs(_, y):
        q = y[:n]
        return np.r_[y[n:], -w2 * q + fpu_force(q)]

    t = time.perf_counter()
    sol = solve_ivp(rhs, (0.0, t_end), np.r_[q0, p0], method="DOP853", rtol=rtol, atol=rtol * 1e-2,
                    dense_output=False)
    seconds = time.perf_counter() - t
    q, p = sol.y[:n], sol.y[n:]
    osc = 0.5 * np.sum(p[m:] ** 2 + w2[m:, None] * q[m:] ** 2, axis=0)
    return dict(seconds=seconds, steps=int(sol.t.size - 1), rhs_evaluations=int(sol.nfev),
                oscillatory_deviation=float(np.max(np.abs(osc - osc[0]))))
