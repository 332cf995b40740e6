"""The core's coordinate map (`_core.CoordinateMap`): states in and out, a method's numbers, and
the composition of a potential's input map, against NumPy and SciPy written independently."""

import pickle
import warnings

import numpy as np
import pytest
import scipy.sparse
from test_stiffness import EIGENVALUES, stiffness_with

import trigint as ti
from trigint import _core, _native
from trigint._method_names import resolve_method
from trigint._native import core_layout
from trigint.integrate import method_coefficients


def test_a_diagonal_problem_out_of_order_is_permuted_and_back():
    prob = ti.OscillatoryProblem([50.0, 0.0, 70.0, 50.0], ti.PolynomialPotential([1.0], [[1, 0, 0, 0]]))
    cmap = core_layout(prob).map
    assert (cmap.kind, cmap.dim) == ("permuted", 4)
    perm = np.argsort(prob.blocks, kind="stable")
    x = np.random.default_rng(0).standard_normal((3, 2, 4))
    for m in (cmap, pickle.loads(pickle.dumps(cmap))):
        assert np.array_equal(m.to_core(x), x[..., perm])
        assert np.array_equal(m.to_user(m.to_core(x)), x)
        assert np.array_equal(m.numbers_to_core(x), x[..., perm])
    # a column-major array is read by its values, not its memory order; lists and integers are
    # taken as floats
    f = np.asfortranarray(x[0])
    assert np.array_equal(cmap.to_core(f), x[0][..., perm])
    assert np.array_equal(cmap.to_core([[1, 2, 3, 4]]), np.array([[1.0, 2.0, 3.0, 4.0]])[..., perm])
    with pytest.raises(ValueError, match="4 coordinates along the last axis"):
        cmap.to_user([1.0, 2.0])
    # an input map of user coordinates reads the same coordinates among the core's
    m = {"rows": 2, "cols": 4, "ptr": [0, 2, 3], "idx": [3, 0, 2], "vals": np.array([1.0, -1.0, 2.0])}
    c = cmap.compose(m, 2)
    inverse = np.argsort(perm)
    assert c["idx"] == [int(inverse[j]) for j in m["idx"]] and np.array_equal(c["vals"], m["vals"])
    assert ti.OscillatoryProblem([0.0, 1.0], ti.PolynomialPotential([1.0], [[2, 0]])).dim == 2
    assert core_layout(ti.problems.fpu(m=2)).map.is_identity


def test_the_modal_map_is_the_basis_and_composes_as_scipy_multiplies():
    prob = ti.OscillatoryProblem(stiffness=stiffness_with(EIGENVALUES, seed=4),
                                 potential=ti.PolynomialPotential([1.0], [[1, 1, 0, 0, 0]]))
    cmap = core_layout(prob).map
    q_basis = prob.basis
    assert cmap.kind == "modal" and np.array_equal(cmap.basis, q_basis)
    q = np.random.default_rng(1).standard_normal((4, 5))
    # x = Qᵀq, each row summed in order: the bits of the loop written out
    want = np.zeros_like(q)
    for r in range(4):
        for k in range(5):
            want[r] += q[r, k] * q_basis[k]
    assert np.array_equal(cmap.to_core(q), want)
    assert np.max(np.abs(cmap.to_user(cmap.to_core(q)) - q)) < 1e-14
    assert np.array_equal(cmap.numbers_to_core(q), q)  # the frequencies are listed modally already
    # M Q with the product's rounding noise dropped, as SciPy's sparse product gives it
    m = {"rows": 2, "cols": 5, "ptr": [0, 2, 3], "idx": [1, 0, 4], "vals": np.array([1.0, -1.0, 0.5])}
    left = scipy.sparse.csr_matrix((m["vals"], m["idx"], m["ptr"]), shape=(2, 5))
    dense = np.asarray(left @ q_basis)
    dense[np.abs(dense) <= 1e-15 * np.max(np.abs(dense), axis=1, keepdims=True)] = 0.0
    want = scipy.sparse.csr_matrix(dense)
    got = cmap.compose(m, 2)
    assert got["ptr"] == want.indptr.tolist() and got["idx"] == want.indices.tolist()
    assert np.array_equal(got["vals"], want.data)
    ident = cmap.compose(None, 5)  # no map: the identity, so Q itself
    assert np.array_equal(scipy.sparse.csr_matrix((ident["vals"], ident["idx"], ident["ptr"])).toarray(),
                          np.where(np.abs(q_basis) <= 1e-15 * np.max(np.abs(q_basis), axis=1, keepdims=True),
                                   0.0, q_basis))


@pytest.mark.parametrize(("make", "match"), [
    (lambda: _core.CoordinateMap.permuted(np.array([0, 0, 1])), "out of range or repeated"),
    (lambda: _core.CoordinateMap.permuted(np.array([0, 3, 1])), "out of range or repeated"),
    (lambda: _core.CoordinateMap.permuted(np.array([0, -2, 1])), "-2 is out of range"),
    (lambda: _core.CoordinateMap.modal(np.zeros((2, 3))), "square"),
    (lambda: _core.CoordinateMap.modal(np.full((2, 2), np.nan)), "not finite"),
    (lambda: _core.CoordinateMap.identity(3).to_core(np.zeros((2, 4))), "3 coordinates"),
    (lambda: _core.CoordinateMap.identity(3).compose({"rows": 1, "cols": 3, "ptr": [0, 1], "idx": [5],
                                                       "vals": [1.0]}, 1), "column 5 out of range"),
    (lambda: _core.CoordinateMap.identity(3).compose({"rows": 1, "cols": 4, "ptr": [0, 0], "idx": [],
                                                       "vals": []}, 1), "reads 4 coordinates"),
])
def test_bad_maps_are_refused_with_what_was_wrong(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_samples_go_to_the_users_coordinates_in_place_with_the_bits_of_to_user():
    # every kind of map that moves numbers: a permutation, a modal basis, a wave's Fourier grid
    problems = [
        ti.OscillatoryProblem([50.0, 0.0, 70.0, 50.0], ti.PolynomialPotential([1.0], [[1, 0, 0, 0]])),
        ti.OscillatoryProblem(stiffness=stiffness_with(EIGENVALUES, seed=4),
                              potential=ti.PolynomialPotential([1.0], [[1, 1, 0, 0, 0]])),
        ti.problems.wave(32, rho=1.0, potential="u**4/4"),
    ]
    rng = np.random.default_rng(3)
    for prob in problems:
        lay = core_layout(prob)
        x = rng.standard_normal((4, prob.dim))
        for first in (0, 1, 4):
            y = x.copy()
            assert lay.map.to_user_in_place(y, first) is None
            np.testing.assert_array_equal(y[:first], x[:first])
            np.testing.assert_array_equal(y[first:], lay.map.to_user(x[first:]).reshape(-1, prob.dim))
        # a run's samples: step 0 is the user's initial state, the others mapped; a read-only or
        # strided array is mapped into a new one instead, with the same numbers
        x0 = rng.standard_normal(prob.dim)
        expect = np.vstack([x0, lay.map.to_user(x[1:])])
        for given in (x.copy(), np.asfortranarray(x)):
            np.testing.assert_array_equal(lay.samples_to_user(np.array([0, 1, 2, 3]), given, x0), expect)
        frozen = x.copy()
        frozen.flags.writeable = False
        np.testing.assert_array_equal(lay.samples_to_user(np.array([0, 1, 2, 3]), frozen, x0), expect)
        np.testing.assert_array_equal(frozen, x)  # not written
        np.testing.assert_array_equal(lay.samples_to_user(np.array([2, 3, 4, 5]), x.copy(), x0),
                                      lay.map.to_user(x))
        # rows marked done (in the user's coordinates already) are left as they are
        y, done = x.copy(), np.array([False, True, False, True])
        lay.map.to_user_in_place(y, 0, done)
        np.testing.assert_array_equal(y[done], x[done])
        np.testing.assert_array_equal(y[~done], lay.map.to_user(x[~done]).reshape(-1, prob.dim))
        with pytest.raises(ValueError, match=r"done: one flag per row expected \(4\), got 1"):
            lay.map.to_user_in_place(x.copy(), 0, np.array([True]))
        with pytest.raises(ValueError, match="not a writeable array"):
            lay.map.to_user_in_place(frozen, 1)
        with pytest.raises(ValueError, match="C-contiguous"):
            lay.map.to_user_in_place(np.asfortranarray(x), 1)
        with pytest.raises(ValueError, match="coordinates along the last axis"):
            lay.map.to_user_in_place(np.zeros((2, prob.dim + 1)), 0)



def _through_the_transform(prob, method, u0, v0, h, n_steps, save_every, form):
    """A run's samples made with every q row in the core's coordinates, transformed back by the
    map (step 0 is the user's q0): the samples as they were before the grid values were kept."""
    lay = _native.core_layout(prob)
    co = method_coefficients(prob, resolve_method(method), h, form)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a blow-up is the point of one case
        out = _core.integrate(_native.problem_potential(prob, lay), lay.spec, _native.core_method(prob, co, lay),
                              lay.to_core(u0), lay.to_core(v0), n_steps, save_every, form, True, 1 << 20, None)
    s = out.samples[0]
    assert not s["q_in_user"].any()
    return s["steps"], lay.samples_to_user(s["steps"], s["q"], u0), lay.samples_to_user(s["steps"], s["p"], v0)


@pytest.mark.parametrize("shape", [64, (8, 6)])
@pytest.mark.parametrize("form", ["two-step", "one-step"])
def test_a_waves_q_samples_from_the_force_grid_have_the_bits_of_the_transform_back(shape, form):
    # φ = 1 (B, E): each sample's q is the force evaluation's grid values; φ = sinc (C): the force
    # is evaluated at φq, so the rows are transformed back. Either way the bits of transforming
    # every row back. A run that blows up keeps its last good state through the transform.
    prob = ti.problems.wave(shape, rho=1.0, potential="u**4/4")
    grid = np.meshgrid(*[2 * np.pi * np.arange(n) / n for n in prob.shape], indexing="ij")
    u0 = (0.3 * np.cos(grid[0]) + 0.2 * np.sin(2 * grid[-1])).reshape(-1)
    v0 = (0.1 * np.sin(grid[0] + grid[-1])).reshape(-1)
    for method in ("B", "E", "C"):
        steps, expect, expect_p = _through_the_transform(prob, method, u0, v0, 0.05, 20, 3, form)
        lay = _native.core_layout(prob)
        co = method_coefficients(prob, resolve_method(method), 0.05, form)
        raw = _core.integrate(_native.problem_potential(prob, lay), lay.spec, _native.core_method(prob, co, lay),
                              lay.to_core(u0), lay.to_core(v0), 20, 3, form, True, 1 << 20, None, q_from_grid=True)
        taken = raw.samples[0]["q_in_user"]
        assert taken.tolist() == [method != "C"] * len(steps)  # steps 0, 3, …, 18, 20
        sol = ti.integrate(prob, method, u0, v0, h=0.05, n_steps=20, save_every=3, form=form, progress=False)
        np.testing.assert_array_equal(sol.steps, steps)
        assert np.array_equal(sol.q.view(np.int64), expect.view(np.int64))
        assert np.array_equal(sol.p.view(np.int64), expect_p.view(np.int64))
    focusing = ti.problems.wave(32, rho=1.0, potential="-u**4/4")
    x = 2 * np.pi * np.arange(32) / 32
    # (from rest: p0 = 0 goes in as the kept image of zero, the transform's bits)
    steps, expect, expect_p = _through_the_transform(focusing, "B", 3 * np.cos(x), np.zeros(32), 0.05, 400, 7, form)
    with pytest.warns(RuntimeWarning, match="blew up"):
        sol = ti.integrate(focusing, "B", 3 * np.cos(x), np.zeros(32), h=0.05, n_steps=400, save_every=7,
                           form=form, progress=False)
    assert sol.status == "blow-up" and steps[-1] % 7 != 0  # the last good state, kept apart
    assert np.array_equal(sol.q.view(np.int64), expect.view(np.int64))
    assert np.array_equal(sol.p.view(np.int64), expect_p.view(np.int64))


def test_a_wave_state_at_rest_goes_in_as_the_kept_image_of_zero_with_the_transforms_bits():
    for prob in (ti.problems.wave(64, rho=1.0), ti.problems.wave((8, 6), rho=1.0)):
        lay = _native.core_layout(prob)
        zero = np.zeros(prob.dim)
        image = lay.state_to_core(zero)
        assert image is lay.state_to_core(np.zeros(prob.dim)) and not image.flags.writeable
        assert np.array_equal(image.view(np.int64), lay.to_core(zero).view(np.int64))
        # a −0.0 entry is not +0.0: it goes through the transform, whatever signs it gives
        signed = zero.copy()
        signed[3] = -0.0
        assert lay.state_to_core(signed) is not image
        assert np.array_equal(lay.state_to_core(signed).view(np.int64), lay.to_core(signed).view(np.int64))
        x = np.linspace(-1.0, 1.0, prob.dim)
        assert np.array_equal(lay.state_to_core(x).view(np.int64), lay.to_core(x).view(np.int64))
    fpu = _native.core_layout(ti.problems.fpu(m=2))  # no transform to save: the state itself
    assert np.array_equal(fpu.state_to_core(np.zeros(4)), np.zeros(4))
