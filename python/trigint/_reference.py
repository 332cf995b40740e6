"""Slow pure-NumPy versions of the recursions, written from the formulas of the paper (Cohen,
Gauckler, Hairer, Lubich, BIT 2015: the two-step form (2.5) started by (2.3), the one-step form
of Hairer, Lubich, Wanner, Geometric Numerical Integration XIII (2.7)–(2.9)) independently of
the core: the test oracle for the Rust kernels.

Not part of the public API.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def fpu_gradient(x: np.ndarray) -> np.ndarray:
    """∇U for the FPU potential in the variables (x₀,₁…x₀,ₘ, x₁,₁…x₁,ₘ), written out by hand."""
    m = x.size // 2
    x0, x1 = x[:m], x[m:]
    grad = np.zeros_like(x)
    d = x0[0] - x1[0]
    grad[0] += d**3
    grad[m] -= d**3
    for i in range(1, m):
        d = x0[i] - x1[i] - x0[i - 1] - x1[i - 1]
        grad[i] += d**3
        grad[m + i] -= d**3
        grad[i - 1] -= d**3
        grad[m + i - 1] -= d**3
    d = x0[m - 1] + x1[m - 1]
    grad[m - 1] += d**3
    grad[2 * m - 1] += d**3
    return grad


def fpu_value(x: np.ndarray) -> float:
    m = x.size // 2
    x0, x1 = x[:m], x[m:]
    d = [x0[0] - x1[0], *(x0[1:] - x1[1:] - x0[:-1] - x1[:-1]), x0[-1] + x1[-1]]
    return 0.25 * float(np.sum(np.asarray(d) ** 4))


def two_step(gradient: Callable, h: float, cos, chi, psi, phi, q0, p0, n_steps: int):
    """(2.5) with (2.3); returns q_n, p_n for n = 0 … n_steps."""
    g = lambda q: -gradient(phi * q)  # noqa: E731
    qs = [q0, cos * q0 + h * chi * p0 + 0.5 * h**2 * psi * g(q0)]
    for n in range(1, n_steps + 1):
        qs.append(2 * cos * qs[n] - qs[n - 1] + h**2 * psi * g(qs[n]))
    q = np.array(qs)
    p = np.empty((n_steps + 1, q0.size))
    p[0] = p0
    p[1:] = (q[2:] - q[:-2]) / (2 * h * chi)
    return q[:-1], p


def one_step(gradient: Callable, h: float, cos, sin, chi, psi, phi, q0, p0, n_steps: int):
    """The velocity form [GNI XIII (2.7)–(2.9)] with Ψ₁ = Ψ/χ, Ψ₀ = cos·Ψ/χ and the rotation
    −sin²/(hχ) (= −Ω sin(hΩ) when χ = sinc(hΩ))."""
    g = lambda q: -gradient(phi * q)  # noqa: E731
    q, p = [q0], [p0]
    gn = g(q0)
    for _ in range(n_steps):
        qn = cos * q[-1] + h * chi * p[-1] + 0.5 * h**2 * psi * gn
        gnext = g(qn)
        pn = -(sin**2) / (h * chi) * q[-1] + cos * p[-1] + 0.5 * h * (cos * psi / chi * gn + psi / chi * gnext)
        q.append(qn)
        p.append(pn)
        gn = gnext
    return np.array(q), np.array(p)


def alpha_direct(gradient: Callable, h: float, omega, alpha: float, q0, p0, n_steps: int):
    """(2.6) as written: (I + αh²Ω²)(q_{n+1} − 2q_n + q_{n−1}) + h²Ω² q_n = h² g(q_n),
    2h p_n = (I + αh²Ω²)(q_{n+1} − q_{n−1}); q_{−1} eliminated with p_0.

    Solved for the differences Δ_{n+1} = q_{n+1} − q_n (the recursion's first line reads
    (I + αh²Ω²)(Δ_{n+1} − Δ_n) = h²(g(q_n) − Ω²q_n)), which avoids the cancellation of the
    plain three-term form; mathematically it is the same recursion.
    """
    a = 1 + alpha * h**2 * omega**2
    rhs = lambda q: h**2 * (-gradient(q) - omega**2 * q)  # noqa: E731
    # n = 0 with Δ_0 = q_0 − q_{−1} = Δ_1 − 2h p_0 / a:  a (2Δ_1 − 2h p_0/a) = rhs(q_0).
    deltas = [None, h * p0 / a + 0.5 * rhs(q0) / a]
    qs = [q0, q0 + deltas[1]]
    for n in range(1, n_steps + 1):
        deltas.append(deltas[n] + rhs(qs[n]) / a)
        qs.append(qs[n] + deltas[n + 1])
    q = np.array(qs)
    p = np.empty((n_steps + 1, q0.size))
    p[0] = p0
    d = np.array(deltas[1:])
    p[1:] = a * (d[1:] + d[:-1]) / (2 * h)
    return q[:-1], p


def imex_one_step(gradient: Callable, h: float, omega, q0, p0, n_steps: int):
    """IMEX in its one-step form (the paper's α-family of §2 with α = 1/4): p⁺ = p_n + ½h g(q_n);
    (I + ¼h²Ω²) q_{n+1} = (I − ¼h²Ω²) q_n + h p⁺; p_{n+1} = p⁺ − ½hΩ²(q_n + q_{n+1}) + ½h g(q_{n+1})."""
    w2 = omega**2
    q, p = [q0], [p0]
    for _ in range(n_steps):
        plus = p[-1] - 0.5 * h * gradient(q[-1])
        qn = ((1 - 0.25 * h**2 * w2) * q[-1] + h * plus) / (1 + 0.25 * h**2 * w2)
        p.append(plus - 0.5 * h * w2 * (q[-1] + qn) - 0.5 * h * gradient(qn))
        q.append(qn)
    return np.array(q), np.array(p)
