"""The tangent map of the integrator's step and the Lyapunov spectra built on it."""

import numpy as np
import pytest

import trigint as ti

METHODS = ["A", "B", "C", "D", "E", "imex", "stormer-verlet",
           ti.ModifiedTrigonometric(lambda x: 2 * np.arctan(x / 2), chi="mclachlan-stern")]


def toda(n=3):
    """A periodic Toda lattice as an expression, on frequencies (0, 3, 4)."""
    names = [f"x{i}" for i in range(n)]
    expr = " + ".join(f"exp({names[i]} - {names[(i + 1) % n]})" for i in range(n))
    return ti.OscillatoryProblem(omega=[0.0, 3.0, 4.0], potential=ti.ExpressionPotential(expr, names))


def chain():
    """A Toda chain with an on-site term, as a ChainPotential."""
    u = (ti.ChainPotential(4).add("exp(y) - 1 - y", "y", pairs=[(0, 1), (1, 2), (2, 3)])
         .add("1 - cos(y)", "y", sites=range(4)))
    return ti.OscillatoryProblem(omega=[0.0, 2.0, 7.0, 7.0], potential=u)


def dense_stiffness():
    """The FPU chain of m = 2 in its original coordinates: a dense stiffness matrix."""
    return ti.problems.fpu(m=2, omega=20.0, coordinates="original")


def python_potential(hvp=True):
    """U = Σ q⁴/4 + q0 q1² as Python callables, with or without its Hessian–vector product."""
    def value(q):
        return float(np.sum(q**4) / 4 + q[0] * q[1] ** 2)

    def gradient(q):
        g = q**3
        g[0] += q[1] ** 2
        g[1] += 2 * q[0] * q[1]
        return g

    def hessian_vector(q, v):
        h = np.diag(3 * q**2)
        h[0, 1] += 2 * q[1]
        h[1, 0] += 2 * q[1]
        h[1, 1] += 2 * q[0]
        return h @ v

    pot = ti.PythonPotential(value, gradient, hessian_vector=hessian_vector if hvp else None)
    return ti.OscillatoryProblem(omega=[0.0, 6.0, 9.0], potential=pot)


def krylov(n=30):
    """A chain of n = 30 with a sparse stiffness matrix, on the Krylov (Lanczos) path, its products
    to 1e-14 so that central differences of the step see its derivative."""
    import scipy.sparse as sparse

    a = sparse.diags([np.full(n, 2.0), np.full(n - 1, -1.0), np.full(n - 1, -1.0)], [0, -1, 1], format="csr") * 400
    names = [f"q{i}" for i in range(n)]
    u = " + ".join(f"({names[i]} - {names[i + 1]})**4/4" for i in range(n - 1)) + " + cos(q0)"
    return ti.OscillatoryProblem(stiffness=a, potential=ti.ExpressionPotential(u, names), path="krylov",
                                 krylov_tolerance=1e-14)


def state(problem, seed=1, scale=0.5):
    rng = np.random.default_rng(seed)
    return scale * rng.standard_normal(problem.dim), scale * rng.standard_normal(problem.dim)


def wave(shape):
    return ti.problems.wave(shape, rho=1.0, potential="u**4/4 + sin(u)")


PROBLEMS = {
    "fpu": (lambda: ti.problems.fpu(m=3, omega=30.0), 0.02),
    "toda expression": (toda, 0.1),
    "chain": (chain, 0.1),
    "dense stiffness": (dense_stiffness, 0.03),
    "python hvp": (python_potential, 0.05),
    "krylov": (krylov, 0.02),
    "wave 1-D": (lambda: wave((16,)), 0.1),
    "wave 2-D": (lambda: wave((8, 6)), 0.1),
}


def one_step(problem, method, q, p, h):
    s = ti.integrate(problem, method, q, p, h=h, n_steps=1, track_energies=False)
    return np.concatenate([s.q[-1], s.p[-1]])


def finite_difference(problem, method, q, p, dq, dp, h, eps=1e-5):
    """Central differences of one integrate() step along (dq, dp)."""
    plus = one_step(problem, method, q + eps * dq, p + eps * dp, h)
    minus = one_step(problem, method, q - eps * dq, p - eps * dp, h)
    return (plus - minus) / (2 * eps)


@pytest.mark.parametrize("name", list(PROBLEMS))
@pytest.mark.parametrize("method", METHODS, ids=lambda m: m if isinstance(m, str) else "modified")
def test_tangent_map_is_the_derivative_of_the_step(name, method):
    make, h = PROBLEMS[name]
    problem = make()
    q, p = state(problem)
    rng = np.random.default_rng(7)
    dq, dp = rng.standard_normal(problem.dim), rng.standard_normal(problem.dim)
    with np.errstate(all="ignore"):
        tq, tp = ti.tangent_map(problem, method, q, p, dq, dp, h=h)
    exact = np.concatenate([tq, tp])
    fd = finite_difference(problem, method, q, p, dq, dp, h)
    assert np.linalg.norm(fd - exact) <= 1e-7 * np.linalg.norm(exact), (name, method)


def test_tangent_map_of_several_steps_is_the_product():
    """Two steps of the map are the map of two steps (the chain rule, along the trajectory)."""
    problem = ti.problems.fpu(m=3, omega=30.0)
    q, p = state(problem)
    dq, dp = np.eye(6)[0], np.zeros(6)
    two = np.concatenate(ti.tangent_map(problem, "C", q, p, dq, dp, h=0.02, n_steps=2))
    fd = (one_n(problem, q + 1e-5 * dq, p, 2) - one_n(problem, q - 1e-5 * dq, p, 2)) / 2e-5
    assert np.linalg.norm(fd - two) <= 1e-7 * np.linalg.norm(two)


def one_n(problem, q, p, n):
    s = ti.integrate(problem, "C", q, p, h=0.02, n_steps=n, track_energies=False)
    return np.concatenate([s.q[-1], s.p[-1]])


def test_the_trajectory_is_integrates_bit_for_bit():
    problem = ti.problems.fpu(m=3, omega=50.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
    res = ti.lyapunov(problem, "B", q0, p0, h=0.03, n_steps=2000, n_exponents=2)
    sol = ti.integrate(problem, "B", q0, p0, h=0.03, n_steps=2000, save_every=2000)
    assert np.array_equal(res.q, sol.q[-1]) and np.array_equal(res.p, sol.p[-1])


def test_full_spectrum_sums_to_zero_and_comes_in_pairs():
    """Volume preservation: Σλ = 0 to round-off at any T. Symplectic (method B) on a chaotic FPU
    chain: sorted, λ_j + λ_{2n+1−j} → 0, the pairing error falling as T grows (a finite-time
    effect: 0.014 at T = 100, 0.0009 at T = 1600 when measured)."""
    problem = ti.problems.fpu(m=3, omega=5.0)
    q0, p0 = np.array([1.5, -1.2, 0.8, 0.5, 0.4, 0.3]), np.zeros(6)
    errors = []
    for t_end in (100.0, 1600.0):
        res = ti.lyapunov(problem, "B", q0, p0, h=0.02, t_end=t_end, n_exponents=12)
        assert abs(res.exponents.sum()) < 1e-12
        e = np.sort(res.exponents)
        errors.append(np.max(np.abs(e + e[::-1])))
        assert e[-1] > 0.15  # chaotic: the pairing is not of zeros
    assert errors[1] < 0.2 * errors[0]


def test_linear_problem_exponents_vanish_like_one_over_t():
    problem = ti.problems.wave((16,), rho=1.0, potential="0*u")
    u0 = 0.1 * np.cos(problem.mesh[0]) if isinstance(problem.mesh, tuple) else 0.1 * np.cos(problem.mesh)
    v0 = np.zeros(problem.dim)
    lead = []
    for t_end in (100.0, 1600.0):
        res = ti.lyapunov(problem, "B", u0.ravel(), v0, h=0.1, t_end=t_end, n_exponents=2)
        lead.append(res.leading)
    assert 0 < lead[1] < lead[0] / 5  # ~ log(t)/t: 16x the time, > 5x smaller


def test_fpu_chaos_is_seen_by_the_exponent_and_megno():
    """A strongly excited FPU chain is chaotic (λ > 0, MEGNO growing past 2); a weak one is
    regular (MEGNO near 2, λ falling)."""
    problem = ti.problems.fpu(m=3, omega=5.0)
    strong = ti.lyapunov(problem, "B", [1.5, -1.2, 0.8, 0.5, 0.4, 0.3], np.zeros(6), h=0.02, t_end=2000)
    weak = ti.lyapunov(problem, "B", [0.01, 0.0, 0.0, 0.01, 0.0, 0.0], np.zeros(6), h=0.02, t_end=2000)
    assert strong.leading > 0.02 and float(strong.megno[-1]) > 10
    assert weak.leading < 0.01 and float(weak.megno[-1]) < 3


def test_deviation_and_history():
    problem = ti.problems.fpu(m=1, omega=10.0)
    res = ti.lyapunov(problem, "B", [0.5, 0.1], [0.0, 0.0], h=0.05, n_steps=640, renormalize_every=8,
                      sample_every=64, deviation=([1.0, 0.0], [0.0, 0.0]))
    assert res.history.dims == ("t", "exponent")
    assert res.history.sizes["t"] == 10 and res.history["step"].values[-1] == 640
    assert np.isclose(np.linalg.norm(np.concatenate([res.dq[0], res.dp[0]])), 1.0)
    assert "exponents" in repr(res)


def test_python_potential_without_hessian_needs_permission():
    problem = python_potential(hvp=False)
    q, p = state(problem)
    with pytest.raises(ValueError, match="hessian_vector"):
        ti.lyapunov(problem, "B", q, p, h=0.05, n_steps=10)
    res = ti.lyapunov(problem, "B", q, p, h=0.05, n_steps=100, finite_differences=True)
    exact = ti.lyapunov(python_potential(), "B", q, p, h=0.05, n_steps=100)
    assert res.second_derivatives == "central differences" and exact.second_derivatives == "user hessian_vector"
    assert abs(res.leading - exact.leading) < 1e-6


@pytest.mark.parametrize("kwargs, message", [
    ({"n_exponents": 0}, "n_exponents"),
    ({"n_exponents": 13}, "n_exponents"),
    ({"renormalize_every": 0}, "renormalize_every"),
    ({"deviation": (np.zeros(6), np.zeros(6))}, "zero"),
    ({"deviation": (np.full(6, np.nan), np.zeros(6))}, "finite"),
    ({"sample_every": 5, "renormalize_every": 2}, "multiple"),
    ({"renormalize_every": 2**70}, r"renormalize_every: 1.18e\+21 steps is more than 2\*\*53"),  # not OverflowError
    ({"sample_every": 2**70}, r"sample_every: 1.18e\+21 steps is more than 2\*\*53"),
])
def test_bad_input(kwargs, message):
    problem = ti.problems.fpu(m=3, omega=30.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=30.0)
    with pytest.raises(ValueError, match=message):
        ti.lyapunov(problem, "B", q0, p0, h=0.02, n_steps=10, **kwargs)


def test_tangent_map_refuses_more_steps_than_it_can_count():
    problem = ti.problems.fpu(m=3, omega=30.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=30.0)
    with pytest.raises(ValueError, match=r"n_steps: 1.18e\+21 steps is more than 2\*\*53"):  # not OverflowError
        ti.tangent_map(problem, "B", q0, p0, q0, p0, h=0.02, n_steps=2**70)


@pytest.mark.parametrize("case", ["fpu", "krylov"])
def test_blow_up_stops_and_keeps_the_history_and_the_last_finite_state(case):
    if case == "fpu":
        # blows up after 37 steps, between two of the tight loop's tests of the state
        problem, q0, p0, h = ti.problems.fpu(m=1, omega=10.0), np.array([5.0, 0.0]), np.zeros(2), 0.2
    else:
        problem, q0, p0, h = krylov(), np.zeros(30), np.zeros(30), 0.3
        q0[5] = 30.0
    with pytest.warns(RuntimeWarning, match="not finite"):
        res = ti.lyapunov(problem, "B", q0, p0, h=h, n_steps=10_000)
    assert res.status == "blow-up" and 0 < res.steps_done < 10_000
    # the state returned is the one at steps_done, which integrate() reaches bit for bit
    sol = ti.integrate(problem, "B", q0, p0, h=h, n_steps=res.steps_done, save_every=res.steps_done)
    assert np.all(np.isfinite(res.q)) and np.all(np.isfinite(res.p))
    assert np.array_equal(res.q, sol.q[-1]) and np.array_equal(res.p, sol.p[-1])
    # and it is the last finite one, where integrate() stops too (the segment is replayed)
    with pytest.warns(RuntimeWarning, match="blew up"):
        alone = ti.integrate(problem, "B", q0, p0, h=h, n_steps=10_000)
    assert alone.status == "blow-up" and alone.n_steps == res.steps_done


def test_ensemble_lanes_are_lyapunov_alone_at_any_thread_count():
    problem = ti.problems.fpu(m=3, omega=30.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=30.0)
    hs = np.array([0.02, 0.05, 0.071, 0.09])
    one = ti.ensemble(problem, "C", q0, p0, h=hs, t_end=40.0, lyapunov=2, threads=1)
    two = ti.ensemble(problem, "C", q0, p0, h=hs, t_end=40.0, lyapunov=2, threads=2)
    assert np.array_equal(one.lyapunov.values, two.lyapunov.values)
    assert np.array_equal(one.megno.values, two.megno.values, equal_nan=True)
    for b in (0, 3):
        alone = ti.lyapunov(problem, "C", q0, p0, h=float(hs[b]), t_end=40.0, n_exponents=2)
        assert np.array_equal(one.lyapunov.values[b], alone.exponents)
    scan = ti.scan(problem, "C", q0, p0, h_omega=hs * 30.0, t_end=40.0, lyapunov=1)
    alone = ti.lyapunov(problem, "C", q0, p0, h=float(scan.h[2]), t_end=40.0)
    assert scan.lyapunov.values[2] == alone.exponents[0]


def test_ensemble_exponents_of_a_compiled_potential_and_of_a_lane_that_blows_up():
    """A compiled potential runs each trajectory's tangent alone, the FPU chain in bundles of
    lanes: either way each trajectory's exponents are those of lyapunov() on it. A lane that
    blows up has the exponents of its last re-orthonormalization, as lyapunov() alone gives
    them whatever its samples' spacing; its neighbours in the bundle keep their own numbers."""
    problem = toda()
    q0, p0 = np.array([0.5, 0.2, -0.1]), np.array([0.3, 0.0, 0.1])
    ds = ti.ensemble(problem, "B", q0, p0, h=np.array([0.05, 0.07]), t_end=20.0, lyapunov=1)
    alone = ti.lyapunov(problem, "B", q0, p0, h=0.07, t_end=20.0)
    assert ds.lyapunov.values[1, 0] == alone.exponents[0] and np.isfinite(alone.exponents[0])
    fpu = ti.problems.fpu(m=3, omega=30.0)
    q, p = ti.problems.fpu_initial(m=3, omega=30.0)
    q0 = np.tile(q, (9, 1))
    q0[4] = 6.0
    with pytest.warns(RuntimeWarning):
        ds = ti.ensemble(fpu, "B", q0, np.tile(p, (9, 1)), h=0.03, t_end=30.0, lyapunov=1)
    alone = ti.lyapunov(fpu, "B", q, p, h=0.03, t_end=30.0)
    assert np.all(ds.lyapunov.values[[0, 3, 5, 8], 0] == alone.exponents[0])
    with pytest.warns(RuntimeWarning, match="not finite"):
        dense = ti.lyapunov(fpu, "B", q0[4], p, h=0.03, t_end=30.0, sample_every=16)
    with pytest.warns(RuntimeWarning, match="not finite"):
        sparse = ti.lyapunov(fpu, "B", q0[4], p, h=0.03, t_end=30.0, sample_every=96)
    last = int(dense.history.step.values[-1])
    assert dense.status == "blow-up" and last > 96 and last % 96 != 0
    # the last sample is at the last re-orthonormalization before the blow-up, however sparse
    assert sparse.history.step.values[-1] == dense.history.step.values[-1]
    assert np.isfinite(dense.exponents[0]) and np.array_equal(sparse.exponents, dense.exponents)
    assert ds.lyapunov.values[4, 0] == dense.exponents[0]
    assert ds.megno.values[4] == dense.megno.values[-1]
    # two exponents: each trajectory's tangent on its own (sampled at its last step only)
    with pytest.warns(RuntimeWarning):
        two = ti.ensemble(fpu, "B", q0[3:6], np.tile(p, (3, 1)), h=0.03, t_end=30.0, lyapunov=2)
    with pytest.warns(RuntimeWarning, match="not finite"):
        both = ti.lyapunov(fpu, "B", q0[4], p, h=0.03, t_end=30.0, n_exponents=2)
    assert np.all(np.isfinite(both.exponents)) and np.array_equal(two.lyapunov.values[1], both.exponents)


def test_ensemble_exponents_on_a_client_and_in_a_store(tmp_path):
    """The exponents are computed in each chunk: an executor and a store give the bits of a run
    here, and a second call reads them back from the store."""
    from concurrent.futures import ThreadPoolExecutor

    problem = ti.problems.fpu(m=3, omega=30.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=30.0)
    hs = np.linspace(0.02, 0.09, 6)
    here = ti.ensemble(problem, "B", q0, p0, h=hs, t_end=30.0, lyapunov=2, chunk_size=2)
    with ThreadPoolExecutor(2) as pool:
        there = ti.ensemble(problem, "B", q0, p0, h=hs, t_end=30.0, lyapunov=2, chunk_size=2, client=pool)
    stored = ti.ensemble(problem, "B", q0, p0, h=hs, t_end=30.0, lyapunov=2, chunk_size=3, store=tmp_path / "s")
    again = ti.ensemble(problem, "B", q0, p0, h=hs, t_end=30.0, lyapunov=2, store=tmp_path / "s")
    for ds in (there, stored, again):
        assert np.array_equal(ds.lyapunov.values, here.lyapunov.values)
        assert np.array_equal(ds.megno.values, here.megno.values)
    assert list(here.exponent.values) == ["λ1", "λ2"]
    with pytest.raises(ValueError, match="store"):  # a store made without exponents is another sweep
        ti.ensemble(problem, "B", q0, p0, h=hs, t_end=30.0, lyapunov=1, store=tmp_path / "s")


def test_krylov_ensemble_exponents_match_lyapunov():
    problem = krylov()
    q, p = state(problem, scale=0.2)
    ds = ti.ensemble(problem, "B", q, p, h=np.array([0.02, 0.03]), t_end=2.0, lyapunov=1)
    alone = ti.lyapunov(problem, "B", q, p, h=0.03, t_end=2.0)
    assert ds.lyapunov.values[1, 0] == alone.exponents[0]


@pytest.mark.parametrize("kwargs, message", [
    ({"lyapunov": 0}, "lyapunov"),
    ({"lyapunov": 13}, "lyapunov"),
])
def test_ensemble_lyapunov_bad_input(kwargs, message):
    problem = ti.problems.fpu(m=3, omega=30.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=30.0)
    with pytest.raises(ValueError, match=message):
        ti.ensemble(problem, "B", q0, p0, h=0.02, n_steps=10, **kwargs)


def test_command_line(tmp_path):
    import subprocess
    import sys

    run = subprocess.run([sys.executable, "-m", "trigint.cli", "lyapunov", "--h-omega-range", "1.0", "3.0", "3",
                          "--t-end", "50", "--exponents", "2", "--out", str(tmp_path)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    rows = [line.split() for line in run.stdout.splitlines() if line[:1].isdigit()]
    assert len(rows) == 3 and all(r[-1] == "completed" for r in rows)
    prob = ti.problems.fpu()
    q0, p0 = ti.problems.fpu_initial()
    alone = ti.lyapunov(prob, "B", q0, p0, h=2.0 / 50.0, t_end=50.0, n_exponents=2)
    assert float(rows[1][1]) == pytest.approx(alone.exponents[0], rel=1e-3)
    assert (tmp_path / "fpu_lyapunov.png").exists()
    bad = subprocess.run([sys.executable, "-m", "trigint.cli", "lyapunov", "--h-omega", "-1"], capture_output=True,
                         text=True, timeout=300)
    assert bad.returncode != 0 and "h-omega" in bad.stderr


def test_wave_deviation_on_the_grid():
    """A 2-D wave problem takes its deviation as grid values, like its state."""
    problem = wave((8, 6))
    x, y = problem.mesh
    u0, v0 = 0.3 * np.cos(x) * np.sin(y), 0 * x
    du = np.zeros_like(x)
    du[2, 3] = 1.0
    grid = ti.lyapunov(problem, "B", u0, v0, h=0.05, n_steps=64, deviation=(du, 0 * du))
    flat = ti.lyapunov(problem, "B", u0, v0, h=0.05, n_steps=64, deviation=(du.ravel(), np.zeros(du.size)))
    assert np.array_equal(grid.exponents, flat.exponents)


def test_a_history_too_large_for_memory_is_refused_before_the_run():
    problem = ti.problems.fpu()
    q0, p0 = ti.problems.fpu_initial()
    with pytest.raises(ValueError, match=r"sample_every: \d+ samples of 12 exponents would need more than"):
        ti.lyapunov(problem, "B", q0, p0, h=0.02, n_steps=10**11, sample_every=16, n_exponents=12)


def test_ensemble_exponents_of_a_python_potential_without_second_derivative_are_refused_up_front():
    pot = ti.PythonPotential(lambda x: float(np.sum(x**4)) / 4, lambda x: x**3)
    prob = ti.OscillatoryProblem([10.0, 0.0], pot)
    with pytest.raises(ValueError, match=r"lyapunov: this Python potential has no second derivative.*"
                                         r"hessian_vector=f.*ti.lyapunov\(\.\.\., finite_differences=True\)"):
        ti.ensemble(prob, "B", [0.1, 0.2], [0.0, 0.0], h=[0.01, 0.02], n_steps=10, lyapunov=1)
    wave = ti.problems.wave(8, rho=1.0, potential=(lambda u: u**4 / 4, lambda u: u**3))
    with pytest.raises(ValueError, match=r"a wave's \(V, V', V''\) gives it"):
        ti.ensemble(wave, "B", np.full(8, 0.1), np.zeros(8), h=[0.01], n_steps=10, lyapunov=1)
