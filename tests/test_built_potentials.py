"""A potential is built (its tape compiled to machine code, its FFTs planned) once and reused:
by its own value() and gradient(), by every run of a problem and by every chunk of an ensemble.
The built potential pickles as its description."""

from __future__ import annotations

import pickle

import numpy as np

import trigint as ti
from trigint import _core, _native


def test_a_potential_is_built_once_and_rebuilt_when_it_changes():
    U = ti.ExpressionPotential("x**4/4 + x*y", ["x", "y"])
    first = _native.built_potential(U, 2)
    U.value([0.1, 0.2])
    U.gradient([[0.1, 0.2], [0.3, 0.4]])
    assert _native.built_potential(U, 2) is first
    chain = ti.ChainPotential(3).add("y**4/4", "y", pairs=[(0, 1)])
    before = _native.built_potential(chain, 3)
    assert chain.value([0.0, 1.0, 0.0]) == 0.25
    chain.add("y**2/2", "y", sites=[2])
    assert _native.built_potential(chain, 3) is not before
    assert chain.value([0.0, 1.0, 2.0]) == 0.25 + 2.0


def test_a_problem_reuses_its_built_potential_across_runs_and_chunks():
    prob = ti.problems.fpu(m=3, omega=50.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
    a = ti.integrate(prob, "B", q0, p0, h=0.01, n_steps=100)
    lay = _native.core_layout(prob)
    built = _native.problem_potential(prob, lay)
    b = ti.integrate(prob, "B", q0, p0, h=0.01, n_steps=100)
    assert _native.problem_potential(prob, lay) is built
    assert np.array_equal(a.q, b.q)
    ds = ti.ensemble(prob, "B", np.array([q0, q0]), np.array([p0, p0]), h=0.01, n_steps=100, chunk_size=1,
                     save_every=100)
    assert _native.problem_potential(prob, lay) is built
    kept = ds["step"].values[0] >= 0
    assert np.array_equal(ds["q"].values[0][kept][-1], a.q[-1])


def test_a_built_potential_pickles_as_its_description():
    U = ti.ExpressionPotential("sin(x) * y**2", ["x", "y"])
    built = _native.built_potential(U, 2)
    again = pickle.loads(pickle.dumps(built))
    assert isinstance(again, _core.Potential)
    x = np.array([[0.3, -1.2], [2.0, 0.5]])
    v1, f1 = built.evaluate(x)
    v2, f2 = again.evaluate(x)
    assert np.array_equal(v1, v2) and np.array_equal(f1, f2)
    assert again.spec["kind"] == "program"
