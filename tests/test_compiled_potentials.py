"""Compiled potentials: ExpressionPotential, ChainPotential, vectorized PythonPotential.

Values and gradients are checked against SymPy's own evaluation (lambdify of the expression and
of its symbolic derivatives); trajectories against the same potential as Python callables; the
FPU written as an expression against the native FPU; ensembles against integrate(), bit for bit.
"""

from __future__ import annotations

import threading
import warnings

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

import trigint as ti
from trigint.potentials import fpu_linear_forms

X = sp.symbols("x0:3", real=True)
A, B = sp.symbols("a b")
PARAMS = {"a": 0.7, "b": -1.3}

# Every supported function, nested, with parameters; each finite on the sampled box [-1, 1]^3.
BATTERY = [
    X[0] ** 2 + X[1] * X[2] - X[2] / (2 + X[0]),
    sp.sqrt(2 + X[0] ** 2 + X[1] ** 2),
    sp.exp(A * X[0]) * sp.cos(X[1] - X[2]),
    sp.log(3 + X[0] * X[1]) + sp.sin(X[2]) ** 3,
    sp.tan(X[0] / 2) + sp.sinh(X[1]) - sp.cosh(B * X[2]),
    sp.tanh(X[0] + X[1] * X[2]) * sp.Abs(X[1] - 0.25),
    (2 + X[0]) ** sp.Rational(3, 2) + (3 - X[1]) ** sp.Rational(-1, 3) + (1.5 + X[2]) ** -2,
    sp.exp(sp.sin(sp.cos(X[0] * X[1]) + X[2])) / (1 + (X[0] - X[2]) ** 4),
    A * (X[0] - X[1]) ** 4 / 4 + B * (X[1] + X[2]) ** 3 / 3 + sp.pi * X[0],
    1 / sp.sqrt(1 + (X[0] - X[1]) ** 2) - sp.Rational(1, 7) * X[2] ** 6,
]


def reference(expr, point):
    """U and ∇U by SymPy (lambdify of the expression and of its symbolic gradient)."""
    e = expr.subs({A: PARAMS["a"], B: PARAMS["b"]})
    u = sp.lambdify(X, e, "math")(*point)
    g = [sp.lambdify(X, sp.diff(e, x), "math")(*point) for x in X]
    return u, np.array(g)


@pytest.mark.parametrize("k", range(len(BATTERY)))
def test_values_and_gradients_match_sympy(k):
    expr = BATTERY[k]
    pot = ti.ExpressionPotential(expr, X, params=PARAMS)
    rng = np.random.default_rng(k)
    for point in rng.uniform(-1, 1, size=(20, 3)):
        u, g = reference(expr, point)
        assert pot.value(point) == pytest.approx(u, rel=1e-13, abs=1e-14)
        np.testing.assert_allclose(pot.gradient(point), g, rtol=1e-13, atol=1e-13)


@settings(max_examples=40, deadline=None)
@given(
    k=st.integers(0, len(BATTERY) - 1),
    j=st.integers(0, len(BATTERY) - 1),
    point=st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 3),
    c=st.floats(-3, 3, allow_nan=False),
)
def test_random_compositions_match_sympy(k, j, point, c):
    """Sums and products of battery members with a random constant: shared subexpressions,
    constants folded, gradients through products."""
    expr = BATTERY[k] * (c + BATTERY[j] ** 2 / 8) + BATTERY[j]
    pot = ti.ExpressionPotential(expr, X, params=PARAMS)
    u, g = reference(expr, point)
    assert pot.value(np.array(point)) == pytest.approx(u, rel=1e-12, abs=1e-12)
    np.testing.assert_allclose(pot.gradient(np.array(point)), g, rtol=1e-12, atol=1e-12)


def test_strings_and_parameters():
    pot = ti.ExpressionPotential("k*(q1 - q0)**2/2 + g*(1 - cos(q0))", ["q0", "q1"], params={"k": 4.0, "g": 2.0})
    assert pot.value([0.5, 1.0]) == pytest.approx(0.5 + 2 * (1 - np.cos(0.5)), rel=1e-15)
    np.testing.assert_allclose(pot.gradient([0.5, 1.0]), [-2.0 + 2 * np.sin(0.5), 2.0], rtol=1e-15)


def fpu_expression(m: int):
    x = sp.symbols(f"x0:{2 * m}")
    forms = [sum(c * x[i] for i, c in row) for row in fpu_linear_forms(m)]
    return sp.Rational(1, 4) * sum(y**4 for y in forms), x


def test_fpu_as_expression_stays_factored_and_matches_native():
    expr, x = fpu_expression(3)
    pot = ti.ExpressionPotential(expr, x)
    # four fourth powers of linear forms: no expansion into ~80 monomials
    assert pot.instructions <= 30
    fpu = ti.FPUPotential(3)
    pts = np.random.default_rng(1).normal(size=(50, 6))
    np.testing.assert_allclose(pot.value(pts), fpu.value(pts), rtol=1e-14)
    np.testing.assert_allclose(pot.gradient(pts), fpu.gradient(pts), rtol=1e-13, atol=1e-15)
    # from_sympy no longer expands either
    poly = ti.PolynomialPotential.from_sympy(expr, x)
    assert isinstance(poly, ti.ExpressionPotential) and poly.instructions == pot.instructions


def test_fpu_expression_trajectory_matches_native_over_short_times():
    expr, x = fpu_expression(3)
    native = ti.problems.fpu()
    prob = ti.OscillatoryProblem(native.omega, ti.ExpressionPotential(expr, x))
    q0, p0 = ti.problems.fpu_initial()
    h = 2 * np.pi / 3 / 50
    a = ti.integrate(native, "B", q0, p0, h=h, n_steps=1000, save_every=100)
    b = ti.integrate(prob, "B", q0, p0, h=h, n_steps=1000, save_every=100)
    np.testing.assert_allclose(b.q, a.q, rtol=0, atol=1e-12)
    assert b.max_deviation["total"] == pytest.approx(a.max_deviation["total"], rel=1e-9)


def pendulum_chain(n: int = 4):
    q = sp.symbols(f"q0:{n}")
    expr = sum(1 - sp.cos(qi) for qi in q) + sum(sp.exp(q[i + 1] - q[i]) - 1 - (q[i + 1] - q[i])
                                                  for i in range(n - 1))
    return expr, q


def python_twin(expr, q):
    u = sp.lambdify([q], expr, "numpy")
    g = sp.lambdify([q], [sp.diff(expr, qi) for qi in q], "numpy")
    return ti.PythonPotential(lambda x: float(u(x)), lambda x: np.array(g(x), dtype=float))


@pytest.mark.parametrize("form", ["two-step", "one-step"])
def test_trajectory_matches_python_potential(form):
    expr, q = pendulum_chain()
    omega = [0.0, 0.0, 20.0, 20.0]
    compiled = ti.OscillatoryProblem(omega, ti.ExpressionPotential(expr, q))
    python = ti.OscillatoryProblem(omega, python_twin(expr, q))
    q0, p0 = np.array([0.3, -0.2, 0.05, 0.0]), np.array([0.1, 0.4, 1.0, -1.0])
    a = ti.integrate(compiled, "C", q0, p0, h=0.02, n_steps=1000, save_every=50, form=form)
    b = ti.integrate(python, "C", q0, p0, h=0.02, n_steps=1000, save_every=50, form=form)
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.p, b.p, rtol=0, atol=1e-11)


def test_chain_potential_matches_expression_and_dense_matrix():
    expr, q = pendulum_chain(6)
    chain = (ti.ChainPotential(6).add("1 - cos(y)", "y", sites=range(6))
             .add("exp(y) - 1 - y", "y", pairs=[(i, i + 1) for i in range(5)]))
    L = np.zeros((5, 6))
    for i in range(5):
        L[i, i], L[i, i + 1] = -1.0, 1.0
    dense = (ti.ChainPotential(6).add("1 - cos(y)", "y", sites=range(6))
             .add("exp(y) - 1 - y", "y", matrix=L))
    ref = ti.ExpressionPotential(expr, q)
    pts = np.random.default_rng(2).uniform(-1, 1, size=(30, 6))
    for pot in (chain, dense):
        np.testing.assert_allclose(pot.value(pts), ref.value(pts), rtol=1e-14)
        np.testing.assert_allclose(pot.gradient(pts), ref.gradient(pts), rtol=1e-13, atol=1e-15)


def test_long_fpu_chain_matches_native():
    m = 200
    L = np.zeros((m + 1, 2 * m))
    for k, row in enumerate(fpu_linear_forms(m)):
        for i, c in row:
            L[k, i] = c
    chain = ti.ChainPotential(2 * m).add("y**4/4", "y", matrix=L)
    fpu = ti.FPUPotential(m)
    pts = np.random.default_rng(3).normal(size=(5, 2 * m))
    np.testing.assert_allclose(chain.value(pts), fpu.value(pts), rtol=1e-13)
    np.testing.assert_allclose(chain.gradient(pts), fpu.gradient(pts), rtol=1e-12, atol=1e-14)


def ensemble_matches_integrate(prob, q0, p0, hs, method="B"):
    Q0 = np.array([q0 + 1e-9 * k for k in range(len(hs))])
    ds = ti.ensemble(prob, method, Q0, p0, h=hs, n_steps=300, save_every=100, progress=False)
    ds1 = ti.ensemble(prob, method, Q0[::-1], p0, h=hs[::-1], n_steps=300, save_every=100, threads=1,
                      progress=False)
    for k, h in enumerate(hs):
        sol = ti.integrate(prob, method, Q0[k], p0, h=h, n_steps=300, save_every=100)
        k1 = len(hs) - 1 - k
        assert np.array_equal(ds.q.values[k][: sol.t.size], sol.q)
        assert np.array_equal(ds1.q.values[k1][: sol.t.size], sol.q)
        assert np.all(np.isnan(ds.q.values[k][sol.t.size :]))
        assert ds.max_deviation.values[k, 0] == sol.max_deviation["total"]


@pytest.mark.parametrize("kind, method", [("expression", "A"), ("expression", "B"), ("chain", "B"),
                                          ("vectorized-python", "B")])
def test_ensemble_lanes_equal_integrate_bit_for_bit(kind, method):
    """Bundles of lanes (on a shape known at run time) against one trajectory each."""
    expr, q = pendulum_chain(4)
    if kind == "expression":
        pot = ti.ExpressionPotential(expr, q)
    elif kind == "chain":
        pot = (ti.ChainPotential(4).add("1 - cos(y)", "y", sites=range(4))
               .add("exp(y) - 1 - y", "y", pairs=[(0, 1), (1, 2), (2, 3)]))
    else:
        u = sp.lambdify([q], expr, "numpy")
        g = sp.lambdify([q], [sp.diff(expr, qi) for qi in q], "numpy")
        pot = ti.PythonPotential(lambda x: u(x.T), lambda x: np.stack(np.broadcast_arrays(*g(x.T)), axis=-1),
                                 vectorized=True)
    # slow coordinates last in the user's order: the core's permutation is exercised too
    prob = ti.OscillatoryProblem([20.0, 20.0, 0.0, 0.0], pot)
    q0, p0 = np.array([0.05, 0.0, 0.3, -0.2]), np.array([1.0, -1.0, 0.1, 0.4])
    ensemble_matches_integrate(prob, q0, p0, np.array([0.02, 0.021, 0.019, 0.0205, 0.0195, 0.022, 0.018,
                                                       0.0201, 0.0199, 0.017]), method)


@pytest.mark.parametrize("method", ["A", "B"])
@pytest.mark.parametrize("track", [True, False])
def test_an_expressions_lane_loop_equals_integrate_bit_for_bit(method, track):
    """On the FPU's compile-time shape (6 coordinates, 3 slow) an expression's ensemble runs the
    lane loop with its force a call on the bundle's rows (phi = 1 in method A, phi q in B) and U
    written in place: each trajectory with the bits integrate() gives it."""
    x = sp.symbols("x0:6")
    forms = [sum(c * x[i] for i, c in row) for row in fpu_linear_forms(3)]
    expr = sp.Rational(1, 4) * sum(y**4 for y in forms) + sum(sp.cos(v) for v in x[:3]) / 10
    prob = ti.OscillatoryProblem(ti.problems.fpu().omega, ti.ExpressionPotential(expr, x))
    q0, p0 = ti.problems.fpu_initial()
    hs = 0.03 * (1 + 0.01 * np.arange(11))  # a bundle of 8 and one of 3
    Q0 = np.array([q0 * (1 + 1e-3 * k) for k in range(hs.size)])
    ds = ti.ensemble(prob, method, Q0, p0, h=hs, n_steps=500, save_every=100, track_energies=track, threads=1)
    for k in (0, 7, 8, 10):
        sol = ti.integrate(prob, method, Q0[k], p0, h=float(hs[k]), n_steps=500, save_every=100,
                           track_energies=track)
        assert np.array_equal(ds.q.values[k], sol.q) and np.array_equal(ds.p.values[k], sol.p)
        assert np.array_equal(ds.energies.values[k], np.asarray(sol.energies.to_array().T))
        if track:
            assert list(ds.max_deviation.values[k]) == list(sol.max_deviation.values())


def test_vectorized_python_potential_gets_blocks():
    calls = []

    def grad(x):
        calls.append((x.shape, x.flags.f_contiguous))
        return x**3

    pot = ti.PythonPotential(lambda x: np.sum(x**4, axis=-1) / 4, grad, vectorized=True)
    prob = ti.OscillatoryProblem([0.0, 10.0], pot)
    ti.ensemble(prob, "B", np.random.default_rng(0).normal(size=(300, 2)), [0.0, 0.0], h=0.01, n_steps=5,
                threads=1, progress=False)
    # 300 trajectories: two bundles of 256 rows (the second padded), one call each per step, each
    # block column-major
    assert set(calls) == {((256, 2), True)} and len(calls) == 2 * 6


@pytest.mark.parametrize("vectorized", [False, True])
def test_python_callables_keep_one_thread_state_per_worker(vectorized):
    """A worker of ensemble() keeps one interpreter thread state for the whole batch, not one
    per call: what a call leaves in a threading.local is there in the next call."""
    local, counts = threading.local(), []

    def grad(x):
        local.calls = getattr(local, "calls", 0) + 1
        counts.append(local.calls)
        return x**3

    value = (lambda x: np.sum(x**4, axis=-1) / 4) if vectorized else (lambda x: float(np.sum(x**4)) / 4)
    prob = ti.OscillatoryProblem([0.0, 10.0], ti.PythonPotential(value, grad, vectorized=vectorized))
    ti.ensemble(prob, "B", np.random.default_rng(0).normal(size=(6, 2)), [0.0, 0.0], h=0.01, n_steps=5,
                threads=1, progress=False)
    # one thread state: the count goes on from call to call (a new one per call restarts at 1)
    assert len(counts) >= 6 and counts == list(range(1, len(counts) + 1))


def test_overflow_stops_with_blow_up_and_keeps_samples():
    prob = ti.OscillatoryProblem([0.0], ti.ExpressionPotential("-exp(x**2)", ["x"]))
    with pytest.warns(RuntimeWarning):
        sol = ti.integrate(prob, "B", [1.0], [1.0], h=0.01, n_steps=10**5, save_every=10)
    assert sol.status == "blow-up" and 0 < sol.n_steps < 10**5
    assert np.all(np.isfinite(sol.q)) and sol.t.size >= 2
    # the last finite state is kept as a final sample, between the regular ones
    assert sol.steps[-1] == sol.n_steps and sol.n_steps % 10 != 0


@pytest.mark.parametrize(
    ("args", "kwargs", "error", "match"),
    [
        (("Piecewise((x, x > 0), (0, True))", ["x"]), {}, ValueError, "Piecewise"),
        (("f(x)", ["x"]), {}, ValueError, "undefined function"),
        ((sp.Derivative(sp.Function("f")(sp.Symbol("x")), sp.Symbol("x")), ["x"]), {}, ValueError, "derivative"),
        (("x + y", ["x"]), {}, ValueError, "symbol y is neither in coordinates"),
        (("k*x", ["x"]), {"params": {"k": float("nan")}}, ValueError, "k = nan is not finite"),
        (("k*x", ["x"]), {"params": {"k": 1j}}, ValueError, "complex"),
        (("k*x", ["x"]), {"params": {"k": "one"}}, TypeError, "k = 'one' is not a number"),
        (("I*x", ["x"]), {}, ValueError, "imaginary unit|complex"),
        (("x**y", ["x", "y"]), {}, ValueError, "non-constant exponent"),
        (("x +", ["x"]), {}, ValueError, "could not parse"),
        ((3.5j, ["x"]), {}, TypeError, "expected a SymPy expression"),
        (("x", []), {}, ValueError, "at least one symbol"),
        (("x", ["x", "x"]), {}, ValueError, "repeated"),
    ],
)
def test_bad_expressions(args, kwargs, error, match):
    with pytest.raises(error, match=match):
        ti.ExpressionPotential(*args, **kwargs)


def test_dimension_mismatch_and_bad_chains():
    pot = ti.ExpressionPotential("x**2 + y**2", ["x", "y"])
    with pytest.raises(ValueError, match=r"acts on 2 coordinates, but the problem \(omega or stiffness, q\) has 3"):
        ti.OscillatoryProblem([0.0, 1.0, 2.0], pot)
    with pytest.raises(ValueError, match="index 5 is outside"):
        ti.ChainPotential(3).add("y**2", "y", pairs=[(0, 5)])
    with pytest.raises(ValueError, match="exactly one of"):
        ti.ChainPotential(3).add("y**2", "y")
    with pytest.raises(ValueError, match="symbol z is neither"):
        ti.ChainPotential(3).add("y*z", "y", sites=[0])
    with pytest.raises(ValueError, match="no terms"):
        ti.ChainPotential(3).value([0.0, 0.0, 0.0])


def test_vectorized_python_blocks_with_unequal_lengths_equal_integrate():
    """A full bundle of 256 lanes and a part of a second, whose trajectories end at different
    steps (a step size each, one t_end), and two that blow up: every lane equals integrate()
    on it alone, lanes beyond 64 and 128 (beyond one word of the lane sets) included."""
    u = lambda x: np.sum(x**4, axis=-1) / 4 - 0.5 * x[..., 0] ** 6  # noqa: E731
    g = lambda x: x**3 - np.where(np.arange(x.shape[-1]) == 0, 3.0 * x[..., :1] ** 5, 0.0)  # noqa: E731
    vec = ti.OscillatoryProblem([0.0, 30.0], ti.PythonPotential(u, g, vectorized=True))
    one = ti.OscillatoryProblem([0.0, 30.0], ti.PythonPotential(lambda x: float(u(x)), g))
    rng = np.random.default_rng(7)
    Q0 = rng.normal(scale=0.3, size=(300, 2))
    Q0[[5, 200], 0] = 1.6  # runs away under the −x⁶ term
    h = rng.uniform(0.01, 0.03, 300)
    with pytest.warns(RuntimeWarning):
        ds = ti.ensemble(vec, "B", Q0, [0.0, 0.0], h=h, t_end=3.0, save_every=25, threads=1, progress=False)
    assert list(ds.status.values[[5, 200]]) == ["blow-up"] * 2
    blown = np.flatnonzero(ds.status.values == "blow-up")
    for k in sorted({0, 5, 63, 64, 127, 128, 200, 255, 256, 299, *blown[:6]}):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            sol = ti.integrate(one, "B", Q0[k], [0.0, 0.0], h=h[k], t_end=3.0, save_every=25)
        assert ds.status.values[k] == sol.status
        assert np.array_equal(ds.q.values[k][: sol.t.size], sol.q)


def test_a_short_chain_runs_as_one_program_with_the_chains_numbers():
    """At most ONE_PROGRAM_TERMS terms in all: one compiled program (Toda, m = 3: 2.7x -> 1.2x the C
    loop in `make bench`); its U and force agree with the term-by-term chain evaluation."""
    from trigint import _native
    from trigint.potentials import ONE_PROGRAM_TERMS

    short = (ti.ChainPotential(5).add("exp(y) - 1 - y", "y", pairs=[(0, 1), (1, 2), (3, 4)])
             .add("1 - cos(y)", "y", sites=range(5))
             .add("a*y**3", "y", matrix=np.array([[0.5, 0.0, -2.0, 0.0, 1.0]]), params={"a": 0.3}))
    assert short.describe(5)["kind"] == "program"
    x = np.random.default_rng(1).normal(scale=0.4, size=(7, 5))
    values, forces = _native.evaluate(short, x)
    chain_values, chain_forces = _native.evaluator({"kind": "chain", "n": 5, "terms": short.terms}).evaluate(x)
    np.testing.assert_allclose(values, chain_values, rtol=1e-14)
    np.testing.assert_allclose(forces, chain_forces, rtol=0, atol=1e-14)
    size = ONE_PROGRAM_TERMS + 2
    long = ti.ChainPotential(size).add("y**4/4", "y", pairs=[(i, i + 1) for i in range(size - 1)])
    assert long.describe(long.dim)["kind"] == "chain"
