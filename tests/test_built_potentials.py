"""A potential is built (its tape compiled to machine code, its FFTs planned) once and reused:
by its own value() and gradient(), by every run of a problem and by every chunk of an ensemble.
The built potential pickles as its description."""

from __future__ import annotations

import pickle
import re

import numpy as np
import pytest

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


def test_a_problem_converts_its_layout_and_methods_once_and_they_pickle_as_descriptions():
    prob = ti.problems.wave(64, rho=1.0, potential="u**4/4")
    x = prob.grid[0]
    u0, v0 = 0.1 * np.cos(x), 0.05 * np.sin(2 * x)
    a = ti.integrate(prob, "B", u0, v0, h=0.05, n_steps=20, save_every=10)
    lay = _native.core_layout(prob)
    (co, handle), = prob.__dict__["_core_methods"].values()
    b = ti.integrate(prob, "B", u0, v0, h=0.05, n_steps=20, save_every=10)
    assert _native.core_layout(prob) is lay and prob.__dict__["_core_methods"][id(co)][1] is handle
    assert np.array_equal(a.q, b.q)
    layout, method = pickle.loads(pickle.dumps((lay.spec, handle)))
    assert isinstance(layout, _core.Layout) and isinstance(method, _core.Method)
    assert np.array_equal(method.spec["chi"], handle.spec["chi"])
    # the unpickled handles run the same trajectory as the descriptions they came from
    out = _core.integrate(_native.problem_potential(prob, lay), layout, method, lay.to_core(u0), lay.to_core(v0),
                          20, 10, "two-step", True, 1024)
    s = out.samples[0]
    assert np.array_equal(lay.samples_to_user(s["steps"], s["q"], u0), a.q)
    # the kept handles are checked once and keep the kernels' rows (made at the first call):
    # a third call, a fresh problem's run and the one-step form agree bit for bit
    fresh = ti.problems.wave(64, rho=1.0, potential="u**4/4")
    for form in ("two-step", "one-step", "two-step"):
        c = ti.integrate(prob, "B", u0, v0, h=0.05, n_steps=20, save_every=10, form=form)
        d = ti.integrate(fresh, "B", u0, v0, h=0.05, n_steps=20, save_every=10, form=form)
        assert np.array_equal(c.q, d.q) and np.array_equal(c.p, d.p)
    assert np.array_equal(c.q, a.q)
    # ... and a state of another size is refused at every call, as before
    for _ in range(2):
        with pytest.raises(ValueError, match="has 63 entries for 64 coordinates"):
            _core.integrate(_native.problem_potential(prob, lay), lay.spec, handle, lay.to_core(u0)[:63],
                            lay.to_core(v0)[:63], 20, 10, "two-step", True, 1024)


def test_every_native_kind_is_read_from_its_description_by_the_core():
    """The binding converts a description as plain data; the core reads each kind's fields and
    says which one is wrong."""
    fpu = _core.Potential({"kind": "fpu", "m": np.int64(2)})
    x = np.array([[0.3, -0.1, 0.2, 0.05]])
    u, g = fpu.evaluate(x)
    assert u[0] == ti.FPUPotential(2).value(x[0]) and np.array_equal(g[0], -ti.FPUPotential(2).gradient(x[0]))
    bad = [({"kind": "spline"}, "unknown potential kind \"spline\"; expected one of fpu, program, chain, wave"),
           ({"kind": "fpu"}, "`m`: missing from the description"),
           ({"kind": "fpu", "m": 2.5}, "`m`: expected an integer, got a float"),
           ({"kind": "fpu", "m": -1}, "`m`: expected a non-negative integer, got -1"),
           ({"kind": "program", "n": 1, "output": 0, "ops": [("cbrt", 0)]},
            "program operation 0 (\"cbrt\"): unknown operation")]
    for spec, message in bad:
        with pytest.raises(ValueError, match=re.escape(message)):
            _core.Potential(spec)
    with pytest.raises(TypeError, match=re.escape('description["map"]["vals"]: a value of type object')):
        _core.Potential({"kind": "fpu", "m": 2, "map": {"vals": object()}})
    with pytest.raises(TypeError, match=re.escape('description["shape"]: a 2-d array')):
        _core.Potential({"kind": "wave", "shape": np.zeros((2, 2))})
    # the arrays of a SciPy CSR matrix (int32 indices) are taken as they are
    from scipy.sparse import csr_matrix
    perm = csr_matrix(np.eye(4)[[2, 0, 3, 1]])
    assert perm.indices.dtype == np.int32
    mapped = _core.Potential({"kind": "fpu", "m": 2, "map": {"rows": 4, "cols": 4, "ptr": perm.indptr,
                                                             "idx": perm.indices, "vals": perm.data}})
    u, _ = mapped.evaluate(x[:, [1, 3, 0, 2]])
    assert u[0] == fpu.evaluate(x)[0][0]
