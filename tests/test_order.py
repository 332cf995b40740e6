"""Fitted order of convergence against an independent high-accuracy solution (DOP853)."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import trigint as ti
from trigint._reference import fpu_gradient

OMEGA = 5.0
T_END = 1.0


@pytest.fixture(scope="module")
def exact():
    prob = ti.problems.fpu(m=2, omega=OMEGA)
    q0, p0 = ti.problems.fpu_initial(m=2, omega=OMEGA)
    w2 = prob.omega**2

    def rhs(_, y):
        q, p = y[:4], y[4:]
        return np.r_[p, -w2 * q - fpu_gradient(q)]

    sol = solve_ivp(rhs, (0, T_END), np.r_[q0, p0], method="DOP853", rtol=1e-13, atol=1e-14)
    return prob, q0, p0, sol.y[:4, -1], sol.y[4:, -1]


@pytest.mark.parametrize("form", ["two-step", "one-step"])
def test_second_order(method, form, exact):
    prob, q0, p0, q_exact, p_exact = exact
    steps = np.array([40, 80, 160, 320])
    errors = []
    for n in steps:
        sol = ti.integrate(prob, method, q0, p0, h=T_END / n, n_steps=int(n), save_every=int(n), form=form)
        errors.append(np.max(np.abs(sol.q[-1] - q_exact)) + np.max(np.abs(sol.p[-1] - p_exact)) / OMEGA)
    slope = -np.polyfit(np.log(T_END / steps), np.log(errors), 1)[0] * -1
    assert abs(slope - 2.0) < 0.1, f"fitted order {slope:.3f}, errors {errors}"
