"""The Krylov path in the core: the Lanczos products against the dense path for every named
filter and for a method given by its own functions, ensembles equal to integrate() bit for bit at
any thread count, scans, stores, and the progress callback."""

import numpy as np
import pytest
import scipy.sparse

import trigint as ti
from trigint import _krylov
from trigint._filters import sinc


def chain(n, path, omega=10.0):
    """n particles between fixed walls: A = ω² tridiag(−1, 2, −1), quartic springs and 1 − cos."""
    a = scipy.sparse.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]) * omega**2
    pot = (ti.ChainPotential(n).add("y**4 / 4", "y", pairs=[(i, i + 1) for i in range(n - 1)])
           .add("1 - cos(y)", "y", sites=range(n)))
    return ti.OscillatoryProblem(stiffness=a.tocsr(), potential=pot, path=path)


def initial(n, scale=1.0):
    x = np.linspace(0, 1, n)
    return scale * 0.1 * np.sin(3 * np.pi * x), scale * np.sin(2 * np.pi * x) * np.exp(-x)


def user_b():
    """Method B given by its functions (not by name): the core calls back into Python."""
    return ti.Trigonometric(psi=sinc, name="B by its functions")


@pytest.mark.parametrize("method", ["A", "D", user_b(), ti.Trigonometric(psi=lambda x: sinc(x) ** 2, phi=sinc)])
def test_every_kind_of_method_agrees_with_the_dense_path(method):
    n = 300
    dense, krylov = chain(n, "dense"), chain(n, "krylov")
    q0, p0 = initial(n)
    kw = dict(h=0.05, n_steps=60, save_every=30, form="one-step")
    d, k = ti.integrate(dense, method, q0, p0, **kw), ti.integrate(krylov, method, q0, p0, **kw)
    assert k.status == "completed" and k.steps.tolist() == [0, 30, 60]
    np.testing.assert_allclose(k.q, d.q, rtol=0, atol=1e-10)
    np.testing.assert_allclose(k.p, d.p, rtol=0, atol=1e-10)
    np.testing.assert_allclose(k.energies["total"], d.energies["total"], rtol=1e-10)
    assert np.max(np.abs(k.q[-1] - q0)) > 1e-2


def test_closed_forms_in_the_core_equal_the_methods_own_functions():
    """B by name (closed forms in the core) and B by its functions (Python at the Ritz values):
    the same products to rounding, so the same trajectory to rounding."""
    n = 400
    prob = chain(n, "krylov")
    q0, p0 = initial(n)
    kw = dict(h=0.05, n_steps=40, save_every=40)
    named, given = ti.integrate(prob, "B", q0, p0, **kw), ti.integrate(prob, user_b(), q0, p0, **kw)
    np.testing.assert_allclose(named.q, given.q, rtol=0, atol=1e-12)
    assert named.info["iterations"] == given.info["iterations"]


@pytest.mark.parametrize("method", ["B", "C", user_b()])
def test_ensemble_lanes_equal_integrate_bit_for_bit_at_any_thread_count(method):
    n = 120
    prob = chain(n, "krylov")
    q0, p0 = initial(n)
    rng = np.random.default_rng(3)
    Q0, P0 = q0 + 1e-3 * rng.normal(size=(4, n)), p0 + 1e-3 * rng.normal(size=(4, n))
    h = np.array([0.05, 0.04, 0.05, 0.03])
    kw = dict(t_end=2.0, save_every=20)
    one = ti.ensemble(prob, method, Q0, P0, h=h, threads=1, **kw)
    two = ti.ensemble(prob, method, Q0, P0, h=h, threads=2, chunk_size=3, **kw)
    for t in range(4):
        sol = ti.integrate(prob, method, Q0[t], P0[t], h=h[t], t_end=2.0, save_every=20, form="one-step")
        k = sol.q.shape[0]
        for ds in (one, two):
            assert ds.status.values[t] == "completed"
            np.testing.assert_array_equal(ds.q.values[t, :k], sol.q)
            np.testing.assert_array_equal(ds.p.values[t, :k], sol.p)
            np.testing.assert_array_equal(ds.max_deviation.values[t], np.array(list(sol.max_deviation.values())))


def test_a_scan_on_the_krylov_path_takes_omega_ref():
    n = 80
    prob = chain(n, "krylov")
    q0, p0 = initial(n, 0.5)
    with pytest.raises(ValueError, match="omega_ref"):
        ti.scan(prob, "B", q0, p0, h_omega=[0.5, 1.0], t_end=1.0)
    s = ti.scan(prob, "B", q0, p0, h_omega=[0.25, 0.5, 1.0], omega_ref=20.0, t_end=2.0, energy="total")
    assert s.dims == ("h_omega",) and np.all(s.status.values == "completed")
    # second order: the energy error falls with h (h = 0.0125 … 0.05)
    assert s.values[0] < s.values[1] < s.values[2]


def test_a_krylov_ensemble_resumes_from_its_store(tmp_path):
    n = 60
    prob = chain(n, "krylov")
    q0, p0 = initial(n)
    Q0 = q0 + np.linspace(0, 1e-3, 5)[:, None]
    kw = dict(h=0.05, t_end=1.0, save_every=10, chunk_size=2)
    first = ti.ensemble(prob, "B", Q0, p0, store=tmp_path / "s", **kw)
    again = ti.ensemble(prob, "B", Q0, p0, store=tmp_path / "s", **kw)
    np.testing.assert_array_equal(first.q.values, again.q.values)
    other = prob.stiffness * 1.01
    moved = ti.OscillatoryProblem(stiffness=other.tocsr(), potential=prob.potential, path="krylov")
    with pytest.raises(ValueError):
        ti.ensemble(moved, "B", Q0, p0, store=tmp_path / "s", **kw)


def test_the_progress_callback_can_stop_a_krylov_run_and_its_errors_are_raised():
    n = 50
    prob = chain(n, "krylov")
    q0, p0 = initial(n)
    seen = []

    def stop_at_128(step):
        seen.append(step)
        return step < 128

    with pytest.warns(RuntimeWarning, match="interrupted after step 128"):
        sol = ti.integrate(prob, "B", q0, p0, h=0.05, n_steps=1000, progress=stop_at_128)
    assert sol.status == "interrupted" and sol.n_steps == 128 and sol.steps[-1] == 128
    assert seen[:2] == [64, 128]

    def fails(step):
        raise ZeroDivisionError("no")

    with pytest.raises(RuntimeError, match="progress callback failed.*ZeroDivisionError"):
        ti.integrate(prob, "B", q0, p0, h=0.05, n_steps=1000, progress=fails)


def test_a_method_whose_functions_fail_says_so():
    n = 30
    prob = chain(n, "krylov")
    q0, p0 = initial(n)

    def psi(x):
        if np.any(x > 0.3):
            raise ArithmeticError("psi refuses large arguments")
        return sinc(x)

    with pytest.raises(ArithmeticError, match="psi refuses"):
        ti.integrate(prob, ti.Trigonometric(psi=psi), q0, p0, h=0.05, n_steps=5)


def test_method_specs_name_the_closed_forms_only_for_named_filters():
    assert _krylov.method_spec(ti.Trigonometric("deuflhard"), 0.1) == {"h": 0.1, "filter": "B"}
    spec = _krylov.method_spec(ti.IMEX(), 0.1)
    assert set(spec) == {"h", "functions", "phi_is_identity"}
    rows = spec["functions"](np.array([0.0, 100.0]))
    assert rows.shape == (7, 2) and rows[1, 0] == 1.0


def test_a_named_filter_added_in_python_runs_on_the_krylov_path(monkeypatch):
    """Adding a named filter is one entry in `_filters.FILTERS`: the Krylov path, which has only
    A–E in closed form (`_core.KRYLOV_FILTERS`), takes any other through its functions."""
    from trigint import _filters

    monkeypatch.setitem(_filters.FILTERS, "F", _filters.Filter("F", sinc, _filters.one, "a test", "psi = sinc"))
    method = ti.Trigonometric("F")
    assert method.named_filter == "F" and "F" not in ti._native.KRYLOV_FILTERS
    assert set(_krylov.method_spec(method, 0.05)) == {"h", "functions", "phi_is_identity"}
    prob = chain(40, "krylov")
    q0, p0 = initial(40)
    new = ti.integrate(prob, method, q0, p0, h=0.05, n_steps=200)
    b = ti.integrate(prob, "B", q0, p0, h=0.05, n_steps=200)  # the same ψ, φ in closed form
    assert new.status == "completed"
    assert np.max(np.abs(new.q[-1] - b.q[-1])) < 1e-10 * np.max(np.abs(b.q[-1]))


def test_energies_are_the_cores_and_equal_what_a_run_streams():
    """ti.energies on the Krylov path comes from the core (the formula its runs stream): the same
    bits as a run's samples, and an independent NumPy evaluation to rounding."""
    n = 80
    prob = chain(n, "krylov")
    q0, p0 = initial(n)
    sol = ti.integrate(prob, "B", q0, p0, h=0.05, n_steps=20, save_every=10)
    e = ti.energies(prob, sol.q, sol.p)
    for name in ("total", "oscillatory", "slow"):
        np.testing.assert_array_equal(np.asarray(e[name]), sol.energies[name].values)
    a = prob.stiffness
    quadratic = 0.5 * (np.einsum("ti,ti->t", sol.p, sol.p) + np.einsum("ti,ti->t", sol.q, (a @ sol.q.T).T))
    u = np.array([prob.potential.value(q) for q in sol.q])
    np.testing.assert_allclose(np.asarray(e["oscillatory"]), quadratic, rtol=1e-13)
    np.testing.assert_allclose(np.asarray(e["slow"]), u, rtol=1e-13)
    np.testing.assert_allclose(np.asarray(e["total"]), quadratic + u, rtol=1e-13)


def test_the_krylov_path_runs_the_one_step_form_and_has_no_modified_energy_as_the_guide_says():
    n = 60
    prob = chain(n, "krylov")
    q0, p0 = initial(n)
    kw = dict(h=0.05, n_steps=40, save_every=20)
    one, two, default = (ti.integrate(prob, "B", q0, p0, form="one-step", **kw),
                         ti.integrate(prob, "B", q0, p0, form="two-step", **kw), ti.integrate(prob, "B", q0, p0, **kw))
    assert np.array_equal(one.q, two.q) and np.array_equal(one.q, default.q)
    assert np.all(np.isnan(one.energies["modified_oscillatory"]))
    assert np.isnan(one.max_deviation["modified_oscillatory"])
    assert np.all(np.isfinite(one.energies["oscillatory"]))
