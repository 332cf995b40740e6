"""ti.energies comes from the core (the channel table and the observing sweep a run uses): checked
here against an independent NumPy evaluation of paper §2.1 and (3.4), and bit for bit against
what a run streams where the coordinates need no rounding map."""

import numpy as np
import pytest

import trigint as ti


def numpy_energies(problem, q, p, coefficients=None) -> dict:
    """The channels of rows of q, p from the formulas, in NumPy: I_j = Σ_{i in block j}
    ½(p_i² + ω_i² q_i²) (in the modal or Fourier coordinates of a stiffness matrix or a wave
    equation, whose potential takes the Fourier coordinates), H_slow = ½|p₀|² + U(q),
    H = H_ω + H_slow, H* = Σ ½(a_i p_i² + b_i q_i²), T_slow = ½|p₀|² (``kinetic``)."""
    q, p = np.atleast_2d(q), np.atleast_2d(p)
    if problem.coordinate_map is not None:  # a wave equation's potential takes these coordinates
        q, p = problem.coordinate_map.to_core(q), problem.coordinate_map.to_core(p)
    u = np.array([float(problem.potential.value(row)) for row in q])
    if problem.basis is not None:
        q, p = q @ problem.basis, p @ problem.basis
    omega, blocks = problem.omega, np.asarray(problem.blocks)
    terms = 0.5 * (p**2 + omega**2 * q**2)
    out = {"total": None, "oscillatory": terms[:, blocks > 0].sum(axis=1),
           "slow": 0.5 * (p[:, blocks == 0] ** 2).sum(axis=1) + u}
    out["total"] = out["oscillatory"] + out["slow"]
    out["kinetic"] = 0.5 * (p[:, blocks == 0] ** 2).sum(axis=1)
    if coefficients is not None:
        fast = omega > 0
        a, b = coefficients.modified_p[fast], coefficients.modified_q[fast]
        out["modified_oscillatory"] = 0.5 * (a * p[:, fast] ** 2 + b * q[:, fast] ** 2).sum(axis=1)
    for j in range(1, problem.n_blocks + 1):
        out[f"oscillatory_{j}"] = terms[:, blocks == j].sum(axis=1)
    return out


def _wave():
    prob = ti.problems.wave(32, rho=1.0, potential="u**4/4")
    x = np.linspace(0, 2 * np.pi, 32, endpoint=False)
    return prob, 0.1 * np.cos(x) + 0.05 * np.sin(3 * x), 0.02 * np.sin(x) + 0.01 * np.cos(2 * x)


def _problems():
    fpu = ti.problems.fpu(m=3, omega=50.0)
    yield "fpu", fpu, *ti.problems.fpu_initial(m=3, omega=50.0)
    three = ti.problems.experiment3(omega=200.0)
    yield "two blocks", three, *ti.problems.experiment3_initial(omega=200.0)
    pot = ti.PolynomialPotential([1.0, 0.5], [[2, 0, 0, 0], [1, 1, 1, 0]])
    mixed = ti.OscillatoryProblem([10.0, 0.0, 20.0, 10.0], pot)  # permuted into the core's order
    yield "permuted", mixed, np.array([0.1, -0.2, 0.3, 0.05]), np.array([1.0, 0.5, -2.0, 0.25])
    original = ti.problems.fpu(2, 50.0, coordinates="original")
    yield "stiffness", original, *ti.problems.fpu_initial(2, 50.0, coordinates="original")
    yield "wave", *_wave()


@pytest.mark.parametrize("case", list(_problems()), ids=lambda c: c[0])
@pytest.mark.parametrize("method", [None, "A", "D"])
def test_energies_agree_with_an_independent_numpy_evaluation(case, method):
    _, prob, q0, p0 = case
    h = 0.02 if method else None
    rng = np.random.default_rng(3)
    q = q0 + 0.01 * rng.normal(size=(4, q0.size))
    p = p0 + 0.01 * rng.normal(size=(4, p0.size))
    co = ti.Trigonometric(method).coefficients(h, prob.omega) if method else None
    want = numpy_energies(prob, q, p, co)
    got = ti.energies(prob, q, p, method, h)
    assert set(want) <= set(got.data_vars)
    for name in want:
        np.testing.assert_allclose(got[name].values, want[name], rtol=1e-13, atol=1e-15, err_msg=name)


def test_the_momentum_agrees_with_its_pair_form_in_numpy():
    prob, u, v = _wave()
    e = ti.energies(prob, u, v)
    forms = prob.pair_forms
    x, y = prob.coordinate_map.to_core(u), prob.coordinate_map.to_core(v)
    a, b, w = np.asarray(forms["a"]), np.asarray(forms["b"]), np.asarray(forms["weights"])
    want = (w.reshape(-1, a.size) * (x[a] * y[b] - x[b] * y[a])).sum(axis=1)
    np.testing.assert_allclose(float(e["momentum_1"]), want[0], rtol=1e-13)
    assert abs(want[0]) > 1e-4


@pytest.mark.parametrize("method", ["B", "D"])
def test_energies_of_a_runs_samples_are_the_streamed_ones_bit_for_bit(method):
    # The FPU's and the permuted problem's core coordinates are the user's (up to a permutation):
    # the same sums in the same order as the run's observing sweep.
    for _, prob, q0, p0 in list(_problems())[:3]:
        sol = ti.integrate(prob, method, q0, p0, h=0.003, n_steps=40, save_every=10)
        e = ti.energies(prob, sol.q, sol.p, method, 0.003)
        for name in sol.energies.data_vars:
            np.testing.assert_array_equal(e[name].values, sol.energies[name].values, err_msg=name)


@pytest.mark.parametrize("omega", [[30.0, 50.0, 50.0, 50.0], [50.0, 50.0, 50.0, 30.0], [0.0, 30.0, 40.0, 50.0, 50.0]],
                         ids=["1+3", "3+1", "slow+1+1+2"])
@pytest.mark.parametrize("method", ["B", "D"])
def test_blocks_of_unequal_sizes_stream_their_own_energies(omega, method):
    # Blocks of 1 and 3 coordinates are as many coordinates as two blocks of two: the sweep's
    # flat loop over blocks of two once took them for such (the first block's energy then held
    # the second block's first coordinate after step 0).
    n = len(omega)
    names = [f"q{i}" for i in range(n)]
    terms = " + ".join(f"({a} - {b})**4/4" for a, b in zip(names, names[1:], strict=False))
    prob = ti.OscillatoryProblem(omega, ti.ExpressionPotential(terms + f" + {names[0]}*{names[-1]}", names))
    rng = np.random.default_rng(5)
    q0, p0 = 0.1 * rng.normal(size=n), rng.normal(size=n)
    sol = ti.integrate(prob, method, q0, p0, h=0.004, n_steps=60, save_every=1)
    want = numpy_energies(prob, np.asarray(sol.q), np.asarray(sol.p))
    for j in range(1, prob.n_blocks + 1):
        name = f"oscillatory_{j}"
        np.testing.assert_allclose(sol.energies[name].values, want[name], rtol=1e-13, err_msg=name)
        deviation = np.abs(want[name] - want[name][0]).max()
        assert sol.max_deviation[name] == pytest.approx(deviation, rel=1e-9, abs=1e-15), name
