"""A non-diagonal stiffness: q'' + Aq = −∇U(q) with A symmetric positive semi-definite."""

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse
import sympy as sp

import trigint as ti
from trigint.problems import fpu_original_basis


def random_orthogonal(n, seed):
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(n, n)))
    return q * np.sign(np.diag(r))


def stiffness_with(eigenvalues, seed=0):
    """A = V diag(λ) Vᵀ for a random orthogonal V: a dense A without structure."""
    v = random_orthogonal(len(eigenvalues), seed)
    a = v @ np.diag(eigenvalues) @ v.T
    return 0.5 * (a + a.T)


# one zero eigenvalue, one repeated (twice) and a simple one: hω = 0.5, 0.5, 0.9, 1.2
EIGENVALUES = [0.0, 100.0, 100.0, 324.0, 576.0]
H = 0.05
SYMBOLS = sp.symbols("q0:5")
QUARTIC = sum((SYMBOLS[i + 1] - SYMBOLS[i]) ** 4 for i in range(4)) / 4 + SYMBOLS[0] ** 2 * SYMBOLS[2] / 3


def quartic():
    return ti.ExpressionPotential(QUARTIC, SYMBOLS)


def test_frequencies_from_a_with_a_zero_and_a_repeated_eigenvalue():
    prob = ti.OscillatoryProblem(stiffness=stiffness_with(EIGENVALUES), potential=quartic())
    f = prob.frequencies
    assert f.slow == 1
    np.testing.assert_allclose(f.values, [10.0, 18.0, 24.0], rtol=1e-13)
    assert f.multiplicities.tolist() == [2, 1, 1]
    # eigh's rounding is grouped away: the eigenvalue 0 came out at about 1e-13, not exactly
    assert 0 < f.largest_zeroed < 1e-11 and f.max_relative_change < 1e-13
    assert prob.n_blocks == 3 and prob.dim == 5
    assert "1 slow" in repr(prob) and "10 (x2)" in repr(prob)
    np.testing.assert_allclose(prob.basis @ np.diag(prob.omega**2) @ prob.basis.T, prob.stiffness, atol=1e-12)


def test_tolerances_decide_what_is_slow_and_what_is_one_block():
    a = np.diag([1e-7, 100.0, 100.0 * (1 + 1e-8)])
    pot = ti.ExpressionPotential("x*y*z", ["x", "y", "z"])
    default = ti.OscillatoryProblem(stiffness=a, potential=pot).frequencies
    assert (default.slow, default.multiplicities.tolist()) == (0, [1, 1, 1])
    loose = ti.OscillatoryProblem(stiffness=a, potential=pot, slow_tolerance=1e-8,
                                  equal_tolerance=1e-7).frequencies
    assert (loose.slow, loose.multiplicities.tolist()) == (1, [2])
    assert loose.largest_zeroed == 1e-7
    assert loose.max_relative_change == pytest.approx(0.25e-8, rel=1e-3)


def exact_flow(a, q0, p0, t):
    """(q(t), p(t)) of q'' + Aq = 0 by the matrix exponential of [[0, I], [−A, 0]]."""
    n = a.shape[0]
    generator = np.block([[np.zeros((n, n)), np.eye(n)], [-a, np.zeros((n, n))]])
    y = scipy.linalg.expm(t * generator) @ np.r_[q0, p0]
    return y[:n], y[n:]


def flow_by_eigenvectors(v, lam, q0, p0, t):
    """The same flow from the decomposition A = V diag(λ) Vᵀ the test built A from (exact λ = 0)."""
    w = np.sqrt(np.asarray(lam, dtype=float))
    x0, y0 = v.T @ q0, v.T @ p0
    safe = np.where(w > 0, w, 1.0)
    x = np.cos(t * w) * x0 + np.where(w > 0, np.sin(t * w) / safe, t) * y0
    y = -w * np.sin(t * w) * x0 + np.cos(t * w) * y0
    return v @ x, v @ y


@pytest.mark.parametrize("method", ["A", "B", "C", "D", "E"])
def test_u_zero_is_solved_exactly(method):
    """With U = 0 every trigonometric method is exact: q_n = cos(nhΩ)q₀ + Ω⁻¹sin(nhΩ)p₀."""
    a = stiffness_with(EIGENVALUES, seed=1)
    zero = ti.ExpressionPotential("0", SYMBOLS)
    prob = ti.OscillatoryProblem(stiffness=a, potential=zero)
    rng = np.random.default_rng(2)
    q0, p0 = rng.normal(size=5), rng.normal(size=5)
    sol = ti.integrate(prob, method, q0, p0, h=H, n_steps=1000, save_every=125)
    for n, q, p in zip(sol.steps, sol.q, sol.p, strict=True):
        # the zero eigenvalue's mode drifts (q grows like t p₀): errors relative to the size of q
        scale = max(1.0, np.abs(q).max())
        if n <= 250:
            # A's rounded zero eigenvalue (about 1e-14) moves expm's solution by (t√λ)²/6 < 1e-12 here
            qe, pe = exact_flow(a, q0, p0, n * H)
            np.testing.assert_allclose(q, qe, rtol=0, atol=1e-12 * scale)
            np.testing.assert_allclose(p, pe, rtol=0, atol=1e-12 * scale)
        qe, pe = flow_by_eigenvectors(random_orthogonal(5, 1), EIGENVALUES, q0, p0, n * H)
        np.testing.assert_allclose(q, qe, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(p, pe, rtol=0, atol=1e-12 * scale)
    assert sol.max_deviation["oscillatory"] < 1e-11


def test_a_diagonal_stiffness_is_the_omega_problem():
    omega = np.array([0.0, 50.0, 50.0, 70.0])
    pot = ti.ExpressionPotential("(a - b)**4 + c*d**2 + a**2*d/5", ["a", "b", "c", "d"])
    q0, p0 = np.array([0.3, 0.02, -0.01, 0.01]), np.array([0.5, 1.0, -0.5, 0.2])
    diag = ti.integrate(ti.OscillatoryProblem(omega, pot), "C", q0, p0, h=0.03, n_steps=1000, save_every=100)
    full = ti.integrate(ti.OscillatoryProblem(stiffness=np.diag(omega**2), potential=pot), "C", q0, p0,
                        h=0.03, n_steps=1000, save_every=100)
    np.testing.assert_allclose(full.q, diag.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(full.p, diag.p, rtol=0, atol=1e-11)
    for name in diag.energies:
        np.testing.assert_allclose(full.energies[name], diag.energies[name], rtol=0, atol=1e-12)


def rotated_problem(r):
    """The problem of `quartic()` in the coordinates q' = R q: A' = RARᵀ, U'(q') = U(Rᵀq')."""
    primed = sp.symbols("r0:5")
    back = sp.Matrix(r.T) * sp.Matrix(primed)
    expr = QUARTIC.subs(dict(zip(SYMBOLS, back, strict=True)), simultaneous=True)
    a = stiffness_with(EIGENVALUES)
    return ti.OscillatoryProblem(stiffness=r @ a @ r.T, potential=ti.ExpressionPotential(expr, primed))


@pytest.mark.parametrize("method", ["B", "E"])
def test_an_orthogonal_change_of_coordinates_changes_nothing(method):
    prob = ti.OscillatoryProblem(stiffness=stiffness_with(EIGENVALUES), potential=quartic())
    r = random_orthogonal(5, 7)
    rotated = rotated_problem(r)
    q0, p0 = np.array([0.1, 0.05, -0.05, 0.02, 0.0]), np.array([0.3, -0.4, 0.5, 0.1, -0.2])
    kw = dict(h=H, n_steps=1000, save_every=100)
    sol, sol_r = ti.integrate(prob, method, q0, p0, **kw), ti.integrate(rotated, method, r @ q0, r @ p0, **kw)
    np.testing.assert_allclose(sol_r.q, sol.q @ r.T, rtol=0, atol=1e-12)
    for name in sol.energies:
        np.testing.assert_allclose(sol_r.energies[name], sol.energies[name], rtol=0, atol=1e-12)
    assert sol.max_deviation["total"] > 1e-8  # the potential acts: energies are not trivially equal


def test_the_basis_inside_a_block_of_equal_frequency_does_not_matter():
    prob = ti.OscillatoryProblem(stiffness=stiffness_with(EIGENVALUES), potential=quartic())
    other = ti.OscillatoryProblem(stiffness=stiffness_with(EIGENVALUES), potential=quartic())
    block = np.flatnonzero(other.blocks == 1)
    assert block.size == 2
    c, s = np.cos(0.7), np.sin(0.7)
    basis = other.basis.copy()
    basis[:, block] = basis[:, block] @ np.array([[c, -s], [s, c]])
    other.basis = basis
    q0, p0 = np.array([0.1, 0.05, -0.05, 0.02, 0.0]), np.array([0.3, -0.4, 0.5, 0.1, -0.2])
    for method in ("A", "C"):
        a = ti.integrate(prob, method, q0, p0, h=H, n_steps=1000, save_every=500)
        b = ti.integrate(other, method, q0, p0, h=H, n_steps=1000, save_every=500)
        assert np.max(np.abs(a.q - b.q)) < 1e-12
        assert np.max(np.abs(a.q - q0)) > 1e-2
        np.testing.assert_allclose(b.energies["oscillatory_1"], a.energies["oscillatory_1"], atol=1e-12)


def one_step_jacobian(prob, method):
    """One step of a linear problem is a linear map: its columns are the images of unit vectors."""
    n = prob.dim
    cols = []
    for e in np.eye(2 * n):
        sol = ti.integrate(prob, method, e[:n], e[n:], h=0.1, n_steps=1, form="one-step")
        cols.append(np.r_[sol.q[-1], sol.p[-1]])
    return np.array(cols).T


@pytest.mark.parametrize(("method", "symplectic"), [("B", True), ("C", True), ("A", False)])
def test_symplecticity_with_a_non_diagonal_stiffness(method, symplectic):
    a = stiffness_with([0.0, 144.0, 144.0, 225.0], seed=3)
    quadratic = ti.ExpressionPotential("0.3*x**2 + 0.2*x*y - 0.1*z*w + 0.4*y*w", ["x", "y", "z", "w"])
    m = one_step_jacobian(ti.OscillatoryProblem(stiffness=a, potential=quadratic), method)
    j = np.block([[np.zeros((4, 4)), np.eye(4)], [-np.eye(4), np.zeros((4, 4))]])
    defect = np.max(np.abs(m.T @ j @ m - j))
    if symplectic:
        assert defect < 1e-12
    else:
        assert defect > 1e-4


OTHER_METHODS = {
    "imex": ti.IMEX(),
    "alpha 0.3": ti.AlphaMethod(0.3),
    "modified, McLachlan-Stern": ti.ModifiedTrigonometric(lambda x: 2 * np.arctan(x / 2), chi="mclachlan-stern"),
    "custom filters": ti.Trigonometric(psi=lambda x: ti.sinc(x) ** 3, phi=lambda x: ti.sinc(x)),
}


@pytest.mark.parametrize("method", ["A", "B", "C", "D", "E", *OTHER_METHODS])
def test_fpu_in_original_coordinates_is_the_diagonal_fpu(method):
    method = OTHER_METHODS.get(method, method)
    m, omega, h = 3, 50.0, 0.02
    diag = ti.integrate(ti.problems.fpu(m, omega), method, *ti.problems.fpu_initial(m, omega),
                        h=h, n_steps=1000, save_every=100)
    orig_prob = ti.problems.fpu(m, omega, coordinates="original")
    orig = ti.integrate(orig_prob, method, *ti.problems.fpu_initial(m, omega, coordinates="original"),
                        h=h, n_steps=1000, save_every=100)
    t = fpu_original_basis(m)
    np.testing.assert_allclose(orig.q @ t, diag.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(orig.p @ t, diag.p, rtol=0, atol=1e-10)
    for name in diag.energies:
        np.testing.assert_allclose(orig.energies[name], diag.energies[name], rtol=0, atol=1e-12)
        assert orig.max_deviation[name] == pytest.approx(diag.max_deviation[name], rel=1e-9, abs=1e-13)


def test_fpu_original_stiffness_and_potential():
    prob = ti.problems.fpu(2, 50.0, coordinates="original")
    assert prob.frequencies.slow == 2 and prob.frequencies.values.tolist() == pytest.approx([50.0], rel=1e-15)
    # U = Σ (q₂ᵢ₊₁ − q₂ᵢ)⁴ with q₀ = q₅ = 0
    q = np.array([0.3, -0.1, 0.2, 0.4])
    want = q[0] ** 4 + (q[2] - q[1]) ** 4 + q[3] ** 4
    assert prob.potential.value(q) == pytest.approx(want, rel=1e-14)
    # ½qᵀAq = (ω²/4) Σ (q₂ᵢ − q₂ᵢ₋₁)²
    assert 0.5 * q @ prob.stiffness @ q == pytest.approx(625.0 * ((q[1] - q[0]) ** 2 + (q[3] - q[2]) ** 2))
    e = ti.energies(prob, *ti.problems.fpu_initial(2, 50.0, coordinates="original"))
    assert float(e["oscillatory"]) == pytest.approx(1.0, rel=1e-14)


def test_every_potential_kind_in_original_coordinates():
    """The same U as native, expression, chain and Python potential gives the same run."""
    m, omega = 2, 40.0
    q = sp.symbols("q0:4")
    chain_expr = q[0] ** 4 + (q[2] - q[1]) ** 4 + q[3] ** 4
    kinds = {
        "native": ti.FPUPotential(m, coordinates="original"),
        "expression": ti.ExpressionPotential(chain_expr, q),
        "chain": ti.ChainPotential(4).add("y**4", "y", matrix=np.array(
            [[1.0, 0, 0, 0], [0, -1.0, 1.0, 0], [0, 0, 0, 1.0]])),
        "python": ti.PythonPotential(sp.lambdify([q], chain_expr),
                                     sp.lambdify([q], [chain_expr.diff(x) for x in q]), 4),
    }
    a = ti.problems.fpu_stiffness(m, omega)
    q0, p0 = ti.problems.fpu_initial(m, omega, coordinates="original")
    runs = {k: ti.integrate(ti.OscillatoryProblem(stiffness=a, potential=u), "B", q0, p0, h=0.03,
                            n_steps=1000, save_every=100) for k, u in kinds.items()}
    for k, sol in runs.items():
        np.testing.assert_allclose(sol.q, runs["native"].q, rtol=0, atol=1e-12, err_msg=k)
        np.testing.assert_allclose(sol.energies["total"], runs["native"].energies["total"], atol=1e-12)


def test_ensemble_lanes_are_integrate_bit_for_bit():
    prob = ti.OscillatoryProblem(stiffness=stiffness_with(EIGENVALUES), potential=quartic())
    rng = np.random.default_rng(5)
    q0 = 0.1 * rng.normal(size=(7, 5))
    p0 = rng.normal(size=(7, 5))
    h = np.linspace(0.04, 0.05, 7)
    for threads in (1, 2):
        ds = ti.ensemble(prob, "B", q0, p0, h=h, n_steps=300, save_every=100, threads=threads)
        for t in (0, 3, 6):
            sol = ti.integrate(prob, "B", q0[t], p0[t], h=float(h[t]), n_steps=300, save_every=100)
            kept = ds["step"].values[t] >= 0
            assert np.array_equal(ds["step"].values[t][kept], sol.steps)
            assert np.array_equal(ds["q"].values[t][kept], sol.q)
            assert np.array_equal(ds["p"].values[t][kept], sol.p)


def test_resonance_analysis_takes_the_problem():
    prob = ti.problems.fpu(3, 50.0, coordinates="original")
    h = 2 * np.pi / 3 / 50 * 1.001
    r = ti.resonance.analyze(h, prob)
    assert r.N == ti.resonance.analyze(h, [50.0]).N
    assert r.kappa == pytest.approx(abs(np.sin(h * 50.0)), rel=1e-12)


def test_sparse_stiffness_is_accepted_for_the_dense_path():
    a = scipy.sparse.csr_matrix(ti.problems.fpu_stiffness(3, 50.0))
    prob = ti.OscillatoryProblem(stiffness=a, potential=ti.FPUPotential(3, coordinates="original"))
    assert prob.frequencies.multiplicities.tolist() == [3]
    # a block-diagonal A gets a sparse basis: two entries per eigenvector
    assert np.count_nonzero(prob.basis) == 12


@pytest.mark.parametrize(("stiffness", "message"), [
    (np.ones((2, 3)), "square"),
    (np.array([[1.0, 0.5], [0.4, 1.0]]),
     r"symmetric; \|A - A\^T\| is 0.1 .* largest at A\[0, 1\] = 0.5 vs A\[1, 0\] = 0.4$"),
    (np.diag([1.0, -0.5]), "eigenvalue -0.5"),
    (np.array([[1.0, np.nan], [np.nan, 1.0]]), "finite"),
    (np.array([[1.0, 2j], [-2j, 1.0]]), "complex"),
    (scipy.sparse.identity(6000, format="csr"), r"6000 x 6000 is too large to diagonalize densely.*path='krylov'"),
])
def test_bad_stiffness(stiffness, message):
    with pytest.raises((ValueError, TypeError), match=message):
        ti.OscillatoryProblem(stiffness=stiffness, potential=ti.ExpressionPotential("x*y", ["x", "y"]), path="dense")


def test_bad_combinations():
    pot = ti.ExpressionPotential("x*y", ["x", "y"])
    with pytest.raises(ValueError, match="exactly one"):
        ti.OscillatoryProblem([1.0, 2.0], pot, stiffness=np.eye(2))
    with pytest.raises(ValueError, match="exactly one"):
        ti.OscillatoryProblem(potential=pot)
    with pytest.raises(ValueError, match="acts on 2 coordinates, but the problem"):
        ti.OscillatoryProblem(stiffness=np.eye(3), potential=pot)
    with pytest.raises(ValueError, match="blocks: not allowed"):
        ti.OscillatoryProblem(stiffness=np.eye(2), potential=pot, blocks=[1, 1])
    with pytest.raises(ValueError, match="slow_tolerance"):
        ti.OscillatoryProblem(stiffness=np.eye(2), potential=pot, slow_tolerance=2.0)
    prob = ti.OscillatoryProblem(stiffness=np.eye(2), potential=pot)
    with pytest.raises(ValueError, match=r"q0: expected shape \(2,\)"):
        ti.integrate(prob, "B", np.zeros(3), np.zeros(2), h=0.1, n_steps=2)
    with pytest.raises(ValueError, match="coordinates"):
        ti.problems.fpu(3, 50.0, coordinates="modal")


def chain_problem(n, path, omega=10.0):
    """n particles between fixed walls, stiff harmonic springs (A = ω² tridiag(−1, 2, −1)) and soft
    quartic springs and an on-site 1 − cos term."""
    a = scipy.sparse.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]) * omega**2
    pot = (ti.ChainPotential(n).add("y**4 / 4", "y", pairs=[(i, i + 1) for i in range(n - 1)])
           .add("1 - cos(y)", "y", sites=range(n)))
    return ti.OscillatoryProblem(stiffness=a.tocsr(), potential=pot, path=path)


@pytest.mark.parametrize("method", ["B", "C", "E"])
def test_the_krylov_path_agrees_with_the_dense_path(method):
    n = 500
    dense, krylov = chain_problem(n, "dense"), chain_problem(n, "krylov")
    x = np.linspace(0, 1, n)
    q0, p0 = 0.1 * np.sin(3 * np.pi * x), np.sin(2 * np.pi * x) * np.exp(-x)
    kw = dict(h=0.05, n_steps=100, save_every=50, form="one-step")
    d, k = ti.integrate(dense, method, q0, p0, **kw), ti.integrate(krylov, method, q0, p0, **kw)
    assert k.status == "completed" and k.steps.tolist() == [0, 50, 100]
    np.testing.assert_allclose(k.q, d.q, rtol=0, atol=1e-10)
    np.testing.assert_allclose(k.p, d.p, rtol=0, atol=1e-10)
    np.testing.assert_allclose(k.energies["total"], d.energies["total"], rtol=1e-10)
    # A is positive definite: ½(|p|² + qᵀAq) is H_ω on both paths
    np.testing.assert_allclose(k.energies["oscillatory"], d.energies["oscillatory"], rtol=1e-10)
    info = k.info
    assert info["products"] >= 3 * 100 and 5 < info["iterations_per_product"] < 60
    assert np.max(np.abs(k.q[-1] - q0)) > 1e-2


def test_the_krylov_path_needs_no_dense_matrix_and_says_what_it_cannot_do():
    n = 20000
    prob = chain_problem(n, "auto")
    assert prob.path == "krylov" and "Krylov path" in repr(prob)
    x = np.linspace(0, 1, n)
    sol = ti.integrate(prob, "B", 0.1 * np.sin(np.pi * x), np.zeros(n), h=0.05, n_steps=5)
    assert sol.status == "completed" and sol.info["iterations_per_product"] > 1
    assert sol.max_deviation["total"] < 1e-3 * sol.initial_energies["total"]
    with pytest.raises(ValueError, match="scan without omega_ref: not available for a stiffness matrix on the "
                                         "Krylov path"):
        ti.scan(prob, "B", np.zeros(n), np.zeros(n), h_omega=[0.5], t_end=1.0)
    with pytest.raises(ValueError, match="needs the problem's frequencies, which a problem on the Krylov path"):
        ti.resonance.analyze(0.05, prob)


def test_the_krylov_path_stops_at_a_blow_up_keeping_the_last_finite_state():
    n = 50
    a = (scipy.sparse.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]) * 100.0).tocsr()
    pot = ti.ChainPotential(n).add("-exp(3*y)", "y", sites=range(n))
    prob = ti.OscillatoryProblem(stiffness=a, potential=pot, path="krylov")
    with pytest.warns(RuntimeWarning, match="the state at step [0-9]+ is not finite"):
        sol = ti.integrate(prob, "B", np.full(n, 1.0), np.zeros(n), h=0.05, n_steps=2000, save_every=100)
    assert sol.status == "blow-up" and 0 < sol.n_steps < 2000
    assert sol.steps.tolist() == [0, sol.n_steps] and np.all(np.isfinite(sol.q))


def test_the_native_fpu_through_a_map_when_its_coordinates_do_not_diagonalize_a():
    """A's pairs also coupled to their neighbours: the FPU's own basis no longer diagonalizes A,
    so Q from eigh is composed into the native FPU's map; the same U as an expression agrees."""
    m, omega = 2, 30.0
    a = ti.problems.fpu_stiffness(m, omega) + 5.0 * (2 * np.eye(4) - np.eye(4, k=1) - np.eye(4, k=-1))
    q = sp.symbols("q0:4")
    expr = ti.ExpressionPotential(q[0] ** 4 + (q[2] - q[1]) ** 4 + q[3] ** 4, q)
    native = ti.OscillatoryProblem(stiffness=a, potential=ti.FPUPotential(m, coordinates="original"))
    assert not np.array_equal(native.basis, fpu_original_basis(m))
    q0, p0 = ti.problems.fpu_initial(m, omega, coordinates="original")
    kw = dict(h=0.03, n_steps=1000, save_every=100)
    a_run = ti.integrate(native, "C", q0, p0, **kw)
    b_run = ti.integrate(ti.OscillatoryProblem(stiffness=a, potential=expr), "C", q0, p0, **kw)
    np.testing.assert_allclose(a_run.q, b_run.q, rtol=0, atol=1e-12)
    assert np.max(np.abs(a_run.q - q0)) > 0.1


def test_a_krylov_product_that_cannot_converge_stops_the_run_keeping_its_samples(monkeypatch):
    from trigint import _krylov

    prob = chain_problem(40, "krylov")
    monkeypatch.setattr(_krylov, "MAX_ITERATIONS", 3)
    with pytest.warns(RuntimeWarning, match="did not reach the tolerance"):
        sol = ti.integrate(prob, "B", np.full(40, 0.1), np.zeros(40), h=0.05, n_steps=10)
    assert sol.status == "blow-up" and sol.steps.tolist() == [0]


def test_a_vectorized_python_potential_gives_each_lane_the_bits_of_integrate():
    def value(q):
        return 0.25 * np.sum(np.diff(q, axis=-1) ** 4, axis=-1) + 0.1 * q[..., 0] ** 3

    def gradient(q):
        d3 = np.diff(q, axis=-1) ** 3
        g = np.zeros_like(q)
        g[..., :-1] -= d3
        g[..., 1:] += d3
        g[..., 0] += 0.3 * q[..., 0] ** 2
        return g

    prob = ti.OscillatoryProblem(stiffness=stiffness_with(EIGENVALUES, seed=4),
                                 potential=ti.PythonPotential(value, gradient, 5, vectorized=True))
    rng = np.random.default_rng(8)
    q0, p0 = 0.1 * rng.normal(size=(5, 5)), rng.normal(size=(5, 5))
    ds = ti.ensemble(prob, "C", q0, p0, h=0.05, n_steps=200, save_every=100, threads=2)
    for t in (0, 4):
        sol = ti.integrate(prob, "C", q0[t], p0[t], h=0.05, n_steps=200, save_every=100)
        assert np.array_equal(ds["q"].values[t][ds["step"].values[t] >= 0], sol.q)
