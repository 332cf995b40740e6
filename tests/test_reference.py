"""The core against the pure-NumPy reference (_reference.py) on FPU, every method, both forms.

The reference runs the textbook recursions in extended precision (np.longdouble), so that it
is an oracle for the recursion itself: in double precision the three-term form
q_{n+1} = 2c q_n − q_{n−1} + … accumulates rounding errors of 2–6·10⁻¹² over 10³ steps (the
core's summed form about 10⁻¹³), which would hide the comparison.
"""

import numpy as np
import pytest

import trigint as ti
from trigint import _reference as ref


@pytest.mark.parametrize("h_omega", [1.5, 2 * np.pi / 3])
@pytest.mark.parametrize("form", ["two-step", "one-step"])
def test_core_matches_numpy_reference(method, form, h_omega, fpu):
    prob, q0, p0 = fpu
    if isinstance(method, ti.AlphaMethod) and h_omega >= method.h_omega_limit:
        h_omega = 1.5
    h = h_omega / 50.0
    n = 1000
    sol = ti.integrate(prob, method, q0, p0, h=h, n_steps=n, form=form)
    co = method.coefficients(h, prob.omega)
    ld = lambda x: np.asarray(x, dtype=np.longdouble)  # noqa: E731
    cos = 1 - ld(co.one_minus_cos)
    args = (ref.fpu_gradient, ld(h), cos, ld(co.chi), ld(co.psi), ld(co.phi), ld(q0), ld(p0), n)
    if form == "two-step":
        q, p = ref.two_step(*args)
    else:
        q, p = ref.one_step(*args[:3], ld(co.sin), *args[3:])
    assert np.max(np.abs(sol.q - q)) < 1e-12
    assert np.max(np.abs(sol.p - p)) < 1e-12
    q, p = q.astype(float), p.astype(float)
    u = np.array([ref.fpu_value(x) for x in q])
    assert np.allclose(sol.energies["slow"], 0.5 * np.sum(p[:, :3] ** 2, axis=1) + u, rtol=0, atol=1e-12)
    assert np.allclose(sol.energies["oscillatory"], 0.5 * np.sum(p[:, 3:] ** 2 + 2500 * q[:, 3:] ** 2, axis=1),
                       rtol=0, atol=1e-12)
