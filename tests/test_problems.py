"""The paper's problems, their energies, and time reversibility."""

import numpy as np
import pytest
import sympy as sp

import trigint as ti


def test_fpu_standard_energies(fpu):
    prob, q0, p0 = fpu
    e = ti.energies(prob, q0, p0)
    assert float(e["total"]) == pytest.approx(2.00120008, abs=1e-8)
    assert float(e["oscillatory"]) == pytest.approx(1.0, abs=1e-8)
    assert float(e["slow"]) == pytest.approx(1.00120008, abs=1e-8)
    sol = ti.integrate(prob, "B", q0, p0, h=0.01, n_steps=1)
    assert sol.initial_energies["total"] == pytest.approx(2.00120008, abs=1e-12)


def test_fpu_matches_original_variables():
    """GNI §I.5 in the original positions q_1 … q_2m, transformed back by hand."""
    m, w = 3, 50.0
    rng = np.random.default_rng(1)
    x = rng.normal(size=2 * m) * 0.3
    y = rng.normal(size=2 * m)
    # x_{0,i} = (q_2i + q_2i-1)/√2, x_{1,i} = (q_2i − q_2i-1)/√2
    q = np.empty(2 * m)
    q[1::2] = (x[:m] + x[m:]) / np.sqrt(2)  # q_2i
    q[0::2] = (x[:m] - x[m:]) / np.sqrt(2)  # q_2i-1
    p = np.empty(2 * m)
    p[1::2] = (y[:m] + y[m:]) / np.sqrt(2)
    p[0::2] = (y[:m] - y[m:]) / np.sqrt(2)
    qq = np.r_[0.0, q, 0.0]
    stiff = sum((qq[2 * i] - qq[2 * i - 1]) ** 2 for i in range(1, m + 1))
    soft = sum((qq[2 * i + 1] - qq[2 * i]) ** 4 for i in range(0, m + 1))
    h_original = 0.5 * np.sum(p**2) + w**2 / 4 * stiff + soft
    e = ti.energies(ti.problems.fpu(m, w), x, y)
    assert float(e["total"]) == pytest.approx(h_original, rel=1e-13)


def test_experiment_problems():
    prob = ti.problems.experiment1(omega=100.0)
    q0, p0 = ti.problems.experiment1_initial(omega=100.0)
    assert prob.potential.value([0.5]) == pytest.approx(0.5**3 + 0.5**4)
    assert float(ti.energies(prob, q0, p0)["oscillatory"]) == pytest.approx(0.5 * (1 + 0.01))
    prob = ti.problems.experiment3(omega=200.0)
    q0, p0 = ti.problems.experiment3_initial(omega=200.0)
    assert prob.n_blocks == 2
    assert prob.block_frequencies == pytest.approx([200.0, 200.0 * np.sqrt(2)])
    e = ti.energies(prob, q0, p0)
    assert float(e["oscillatory_1"]) == pytest.approx(0.5 * (0.36 + 0.09))
    assert float(e["oscillatory_2"]) == pytest.approx(0.5 * (0.49 + 2 * 0.64))
    assert float(e["slow"]) == pytest.approx(0.01 * 0.3 * 0.8 / 200**2)
    h = ti.problems.experiment3_step(200.0)
    assert h * 200 * (1 + np.sqrt(2)) == pytest.approx(2 * np.pi)


@pytest.mark.parametrize("form", ["two-step", "one-step"])
def test_time_reversibility(method, form, fpu):
    """Symmetric methods: stepping back from (q_n, −p_n) returns to (q_0, −p_0)."""
    prob, q0, p0 = fpu
    h = 1.5 / 50
    fwd = ti.integrate(prob, method, q0, p0, h=h, n_steps=500, save_every=500, form=form)
    back = ti.integrate(prob, method, fwd.q[-1], -fwd.p[-1], h=h, n_steps=500, save_every=500, form=form)
    assert np.max(np.abs(back.q[-1] - q0)) < 1e-10
    assert np.max(np.abs(back.p[-1] + p0)) < 1e-10


def test_polynomial_from_sympy_matches_direct():
    q0, q1, q2 = sp.symbols("q0 q1 q2")
    expr = q0**3 + q0**4 - 2 * q0 * q1**2 + sp.Rational(1, 100) * q1 * q2 + 3
    pot = ti.PolynomialPotential.from_sympy(expr, [q0, q1, q2])
    x = np.array([0.7, -1.3, 0.4])
    f = sp.lambdify([q0, q1, q2], expr)
    grad = sp.lambdify([q0, q1, q2], [sp.diff(expr, s) for s in (q0, q1, q2)])
    assert pot.value(x) == pytest.approx(f(*x), rel=1e-14)
    assert pot.gradient(x) == pytest.approx(np.array(grad(*x)), rel=1e-14)
    assert pot.value(np.array([x, 2 * x])) == pytest.approx([f(*x), f(*(2 * x))], rel=1e-14)


def test_python_potential_matches_native(fpu):
    from trigint._reference import fpu_gradient, fpu_value

    prob, q0, p0 = fpu
    slow = ti.OscillatoryProblem(prob.omega, ti.PythonPotential(fpu_value, fpu_gradient))
    a = ti.integrate(prob, "B", q0, p0, h=0.03, n_steps=300, save_every=30)
    b = ti.integrate(slow, "B", q0, p0, h=0.03, n_steps=300, save_every=30)
    assert np.max(np.abs(a.q - b.q)) < 1e-12
    assert b.max_deviation["total"] == pytest.approx(a.max_deviation["total"], rel=1e-9)


def _group_by_first_appearance(omega):
    """The grouping written as a loop (the reference): a label per distinct non-zero frequency."""
    distinct, out = [], []
    for w in omega:
        if w == 0.0:
            out.append(0)
            continue
        if w not in distinct:
            distinct.append(w)
        out.append(distinct.index(w) + 1)
    return out


def test_blocks_grouped_by_first_appearance_at_any_size():
    from trigint.problem import _check_blocks, _group

    rng = np.random.default_rng(3)
    for _ in range(20):  # repeats, zeros (also -0.0) and distinct values in random order
        omega = rng.choice([0.0, -0.0, 1.5, 2.0, 7.25, 3.0, 1e-300], size=int(rng.integers(1, 40)))
        omega = np.abs(omega) if rng.random() < 0.5 else np.where(omega == 0, omega, np.abs(omega))
        assert _group(omega).tolist() == _group_by_first_appearance(omega)
        assert _check_blocks(_group(omega), omega).tolist() == _group(omega).tolist()
    # 2·10⁵ coordinates, 10⁵ distinct frequencies, each twice: grouped and checked at once
    omega = np.repeat(np.linspace(1.0, 2.0, 100_000), 2)[::-1].copy()
    prob = ti.OscillatoryProblem(omega, ti.PolynomialPotential([1.0], [[2] + [0] * (omega.size - 1)]))
    assert prob.blocks[:4].tolist() == [1, 1, 2, 2] and prob.blocks.max() == 100_000
    blocks = prob.blocks.copy()
    blocks[[5, 7]] = blocks[[7, 5]]  # 3 and 4 swapped across a pair: each block two frequencies
    with pytest.raises(ValueError, match=r"blocks: block 3 holds the frequencies"):
        ti.OscillatoryProblem(omega, ti.PolynomialPotential([1.0], [[2] + [0] * (omega.size - 1)]), blocks=blocks)


def test_custom_blocks():
    omega = [0.0, 10.0, 10.0, 20.0]
    pot = ti.PolynomialPotential([1.0], [[2, 0, 0, 0]])
    assert ti.OscillatoryProblem(omega, pot).blocks.tolist() == [0, 1, 1, 2]
    prob = ti.OscillatoryProblem(omega, pot, blocks=[0, 1, 2, 3])  # frequency 10 split in two blocks
    assert prob.block_frequencies.tolist() == [10.0, 10.0, 20.0]
    q, p = np.array([0.1, 0.2, 0.3, 0.4]), np.array([1.0, 2.0, 3.0, 4.0])
    e = ti.energies(prob, q, p)
    assert float(e["oscillatory_1"]) == pytest.approx(0.5 * (4 + 100 * 0.04))
    assert float(e["oscillatory_2"]) == pytest.approx(0.5 * (9 + 100 * 0.09))
    assert float(e["oscillatory_3"]) == pytest.approx(0.5 * (16 + 400 * 0.16))
    # a block of two frequencies has no ω_j: refused, naming them
    with pytest.raises(ValueError, match=r"blocks: block 2 holds the frequencies \[10.0, 20.0\]"):
        ti.OscillatoryProblem(omega, pot, blocks=[0, 1, 2, 2])
    # labels in order and out of order are checked alike; a skipped or negative label is refused
    assert ti.OscillatoryProblem(omega, pot, blocks=[0, 2, 2, 1]).block_frequencies.tolist() == [20.0, 10.0]
    for bad, match in [([0, 1, 1, 3], r"none skipped, got \[1, 3\]"), ([0, 3, 3, 1], r"none skipped, got \[1, 3\]"),
                       ([0, 2, 2, 3], r"none skipped, got \[2, 3\]"), ([0, 1, -1, 2], r"blocks\[2\] = -1")]:
        with pytest.raises(ValueError, match=match):
            ti.OscillatoryProblem(omega, pot, blocks=bad)


def test_a_used_problem_pickles_as_a_fresh_one_and_runs_with_the_same_bits():
    # What calls keep on a problem (layout, methods, coefficients, the mode index) is keyed by
    # object ids and, on a large wave, tens of MB: a pickle (an ensemble's task) leaves it out.
    import pickle

    wave = ti.problems.wave(256, rho=1.0, potential="u**4/4")
    u0 = 0.1 * np.cos(2 * np.pi * np.arange(256) / 256)
    fpu = ti.problems.fpu(m=3, omega=50.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
    for prob, q, p in ((wave, u0, np.zeros(256)), (fpu, q0, p0)):
        fresh = len(pickle.dumps(prob))
        first = ti.integrate(prob, "B", q, p, h=0.01, n_steps=20, save_every=5, progress=False)
        assert any(k in prob.__dict__ for k in prob.KEPT_FOR_CALLS)  # the calls kept something
        assert len(pickle.dumps(prob)) == fresh
        again = ti.integrate(pickle.loads(pickle.dumps(prob)), "B", q, p, h=0.01, n_steps=20, save_every=5,
                             progress=False)
        assert np.array_equal(first.q.view(np.int64), again.q.view(np.int64))
        assert np.array_equal(first.p.view(np.int64), again.p.view(np.int64))
        assert first.max_deviation == again.max_deviation
