"""SaveAt: one value for what a run keeps, checked when built, taken by integrate and ensemble."""

import numpy as np
import pytest

import trigint as ti

H = 2 * np.pi / 3 / 50


@pytest.fixture(scope="module")
def fpu():
    return ti.problems.fpu(m=3, omega=50.0), *ti.problems.fpu_initial(m=3, omega=50.0)


def test_integrate_takes_a_saveat_as_its_two_arguments(fpu):
    prob, q0, p0 = fpu
    a = ti.integrate(prob, "B", q0, p0, h=H, n_steps=200, save_every=7, track_energies=False)
    b = ti.integrate(prob, "B", q0, p0, h=H, n_steps=200, saveat=ti.SaveAt(every=7, track_energies=False))
    assert np.array_equal(a.t, b.t) and np.array_equal(a.q, b.q)
    assert a.t.size == 200 // 7 + 2 and np.isnan(b.max_deviation["total"])


def test_integrate_keeps_the_ends_only_with_every_none(fpu):
    prob, q0, p0 = fpu
    sol = ti.integrate(prob, "B", q0, p0, h=H, n_steps=123, saveat=ti.SaveAt(every=None))
    assert sol.t.tolist() == [0.0, 123 * H]
    full = ti.integrate(prob, "B", q0, p0, h=H, n_steps=123)
    assert np.array_equal(sol.q[-1], full.q[-1])


def test_ensemble_takes_the_same_value(fpu):
    prob, q0, p0 = fpu
    Q0, P0 = ti.perturb(q0, p0, [0.0, 1e-9])
    a = ti.ensemble(prob, "B", Q0, P0, h=H, n_steps=100, save_every=10)
    b = ti.ensemble(prob, "B", Q0, P0, h=H, n_steps=100, saveat=ti.SaveAt(every=10))
    assert a.q.shape == (2, 11, 6) and np.array_equal(a.q.values, b.q.values, equal_nan=True)
    none = ti.ensemble(prob, "B", Q0, P0, h=H, n_steps=100, saveat=ti.SaveAt(every=None))
    assert "q" not in none and np.array_equal(none.max_deviation.values, a.max_deviation.values)


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"every": 0}, ValueError, "save_every: must be an integer >= 1 or None, got 0"),
        ({"every": 2.5}, ValueError, "save_every: must be an integer >= 1 or None, got 2.5"),
        ({"every": True}, ValueError, "save_every: must be an integer >= 1 or None, got True"),
        ({"every": 2**60}, ValueError, "save_every: .* more than 2\\*\\*53"),
        ({"track_energies": "yes"}, TypeError, "track_energies: expected True or False"),
    ],
)
def test_a_bad_saveat_is_refused_when_built(kwargs, error, match):
    with pytest.raises(error, match=match):
        ti.SaveAt(**kwargs)


def test_saveat_must_be_a_saveat(fpu):
    prob, q0, p0 = fpu
    with pytest.raises(TypeError, match="saveat: expected a trigint.SaveAt, got dict"):
        ti.integrate(prob, "B", q0, p0, h=H, n_steps=10, saveat={"every": 2})
