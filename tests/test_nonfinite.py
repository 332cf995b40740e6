"""No silent non-finite results: on every path (diagonal, dense stiffness, Krylov, ensembles)
a potential or force that turns non-finite stops the run with status "blow-up", a message
naming the step, and every sample up to the last finite state."""

import warnings

import numpy as np
import pytest

import trigint as ti

N = 4
A = 100.0 * (2 * np.eye(N) - np.eye(N, k=1) - np.eye(N, k=-1))
Q0 = np.array([0.5, 0.1, 0.0, 0.0])
P0 = np.array([-20.0, 0.0, 0.0, 0.0])  # q0[0] crosses 0 between steps 2 and 3
H = 0.01
LOG = ti.ExpressionPotential("log(q0) + q1**2", ["q0", "q1", "q2", "q3"])


def _value(q):
    return float(q[0] + q[1] ** 2)


def _gradient(q):
    """Finite U everywhere, but no force once q0 < 0 (a NaN force with a finite value)."""
    g = np.array([1.0, 2.0 * q[1], 0.0, 0.0])
    if q[0] < 0:
        g[0] = np.nan
    return g


NAN_FORCE = ti.PythonPotential(_value, _gradient, N)


def _infinite_value(sign):
    """A finite force everywhere, but U = ±inf once q0 < 0: the state stays finite and only the
    energies say the run has left the potential's domain."""

    def value(q):
        return sign * np.inf if q[0] < 0 else float(q[0] + q[1] ** 2)

    return ti.PythonPotential(value, lambda q: np.array([1.0, 2.0 * q[1], 0.0, 0.0]), N)


def _problem(path, potential):
    if path == "diagonal":
        return ti.OscillatoryProblem([0.0, 10.0, 10.0, 10.0], potential)
    return ti.OscillatoryProblem(stiffness=A, potential=potential, path=path)


def _run(prob, **kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sol = ti.integrate(prob, "B", Q0, P0, h=H, n_steps=200, **kwargs)
    return sol, [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]


@pytest.mark.parametrize("potential", [LOG, NAN_FORCE, _infinite_value(1.0), _infinite_value(-1.0)],
                         ids=["log-of-negative", "nan-force", "infinite-U", "minus-infinite-U"])
@pytest.mark.parametrize("path", ["diagonal", "dense", "krylov"])
@pytest.mark.parametrize("save_every", [1, 10])
def test_each_path_stops_with_blow_up_and_keeps_the_finite_samples(path, potential, save_every):
    sol, caught = _run(_problem(path, potential), save_every=save_every)
    assert sol.status == "blow-up"
    last = sol.n_steps
    assert 0 < last < 200
    assert f"not finite at step {last + 1}" in sol.message or f"at step {last + 1} is not finite" in sol.message
    assert f"kept the samples up to step {last}, the last finite state" in sol.message
    assert caught == [sol.message]
    expected = list(range(last + 1)) if save_every == 1 else [0, last]
    assert sol.steps.tolist() == expected
    assert np.all(np.isfinite(sol.q)) and np.all(np.isfinite(sol.p))
    assert np.all(np.isfinite(sol.energies["total"].values))
    assert sol.q[-1, 0] > 0  # the last kept state is the last one before q0 turned negative


@pytest.mark.parametrize("potential", [LOG, NAN_FORCE], ids=["log-of-negative", "nan-force"])
def test_dense_and_krylov_stop_at_the_same_step_with_the_same_states(potential):
    dense, _ = _run(_problem("dense", potential), save_every=1)
    krylov, _ = _run(_problem("krylov", potential), save_every=1)
    assert krylov.n_steps == dense.n_steps
    np.testing.assert_allclose(krylov.q, dense.q, rtol=0, atol=1e-10)
    np.testing.assert_allclose(krylov.p, dense.p, rtol=0, atol=1e-8)


@pytest.mark.parametrize("track", [True, False])
def test_krylov_reports_a_non_finite_potential_even_when_energies_are_not_tracked(track):
    sol, _ = _run(_problem("krylov", LOG), save_every=50, track_energies=track)
    assert sol.status == "blow-up" and sol.n_steps == 2
    assert sol.message == ("the solution blew up: the state at step 3 is not finite; kept the samples "
                           "up to step 2, the last finite state")
    assert sol.steps.tolist() == [0, 2]


@pytest.mark.parametrize("path", ["dense", "krylov"])
def test_a_non_finite_initial_potential_integrates_nothing(path):
    prob = _problem(path, LOG)
    with pytest.warns(RuntimeWarning, match=r"not finite at the initial state \(U\(q0\) = NaN\); nothing was"):
        sol = ti.integrate(prob, "B", [-0.5, 0.1, 0.0, 0.0], np.zeros(N), h=H, n_steps=20)
    assert sol.status == "blow-up" and sol.n_steps == 0 and sol.t.size == 0


@pytest.mark.parametrize("path", ["diagonal", "dense"])
@pytest.mark.parametrize("potential", [LOG, NAN_FORCE, _infinite_value(1.0), _infinite_value(-1.0)],
                         ids=["log-of-negative", "nan-force", "infinite-U", "minus-infinite-U"])
def test_ensemble_lanes_blow_up_like_integrate(path, potential):
    prob = _problem(path, potential)
    q0 = np.array([Q0, Q0, [1.0, 2.0, 2.0, 1.0]])
    p0 = np.array([P0, 0.5 * P0, np.zeros(N)])
    with pytest.warns(RuntimeWarning, match="2 of 3 trajectories blew up"):
        ds = ti.ensemble(prob, "B", q0, p0, h=H, n_steps=12, save_every=1, threads=1, progress=False)
    assert ds.status.values.tolist() == ["blow-up", "blow-up", "completed"]
    for t in range(3):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            sol = ti.integrate(prob, "B", q0[t], p0[t], h=H, n_steps=12, save_every=1)
        assert ds.steps_done.values[t] == sol.n_steps
        assert np.array_equal(ds.q.values[t, : sol.t.size], sol.q)
        assert np.all(np.isnan(ds.q.values[t, sol.t.size:]))


@pytest.mark.parametrize("potential", [LOG, _infinite_value(1.0), _infinite_value(-1.0)],
                         ids=["log-of-negative", "infinite-U", "minus-infinite-U"])
def test_lanes_stop_at_the_first_non_finite_energy_between_samples(potential):
    """Only the energies turn non-finite (the state stays finite): the lanes' tight loop between
    samples must see it, and every lane stops where its own integrate() stops."""
    prob = _problem("diagonal", potential)
    q0 = np.array([Q0, Q0, Q0, [1.0, 2.0, 2.0, 1.0]])
    p0 = np.array([P0, 0.5 * P0, 0.25 * P0, np.zeros(N)])
    with pytest.warns(RuntimeWarning, match="3 of 4 trajectories blew up"):
        ds = ti.ensemble(prob, "B", q0, p0, h=H, n_steps=100, save_every=100, threads=1, progress=False)
    for t in range(4):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            sol = ti.integrate(prob, "B", q0[t], p0[t], h=H, n_steps=100, save_every=100)
        assert ds.status.values[t] == sol.status
        assert ds.steps_done.values[t] == sol.n_steps
    assert ds.status.values.tolist() == ["blow-up"] * 3 + ["completed"]
    assert 0 < ds.steps_done.values[0] < ds.steps_done.values[1] < ds.steps_done.values[2] < 100
