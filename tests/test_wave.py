"""The semilinear wave equation on the torus: the spectral map, exact oracles on the linear
equation, order 2 against an accurate solution of the semi-discrete system, the invariants, the
ensemble lanes, and the errors."""
from __future__ import annotations

import pickle

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import trigint as ti

METHODS = ["A", "B", "C", "D", "E"]


def wavenumbers(shape):
    return np.meshgrid(*[np.fft.fftfreq(n, 1.0 / n) for n in shape], indexing="ij")


def semi_discrete_rhs(shape, rho, dv):
    """u_tt = Δu − ρu − V'(u) on the grid with numpy's FFT: an independent right-hand side."""
    k2 = sum(k**2 for k in wavenumbers(shape))

    def rhs(_, y):
        n = y.size // 2
        u, v = y[:n].reshape(shape), y[n:]
        lap = np.real(np.fft.ifftn(-k2 * np.fft.fftn(u)))
        return np.concatenate([v, (lap - rho * u - dv(u)).reshape(-1)])

    return rhs


def smooth_data(shape, seed=0):
    rng = np.random.default_rng(seed)
    x = np.meshgrid(*[2 * np.pi * np.arange(n) / n for n in shape], indexing="ij")
    u = 0.3 * np.cos(x[0] + 0.4) + 0.2 * np.sin(2 * x[0])
    v = 0.1 * np.sin(x[0])
    if len(shape) > 1:
        u = u + 0.15 * np.cos(x[0] - x[1]) + 0.1 * np.sin(x[1] + 1.0)
        v = v + 0.05 * np.cos(2 * x[1])
    return u + 0.01 * rng.standard_normal(shape), v


def exact_linear(shape, rho, u0, v0, t):
    """The semi-discrete linear solution: every Fourier mode an harmonic oscillator."""
    w = np.sqrt(rho + sum(k**2 for k in wavenumbers(shape)))
    uh, vh = np.fft.fftn(u0), np.fft.fftn(v0)
    ws = np.where(w > 0, w, 1.0)
    sin_over_w = np.where(w > 0, np.sin(w * t) / ws, t)
    return np.real(np.fft.ifftn(uh * np.cos(w * t) + vh * sin_over_w)), \
        np.real(np.fft.ifftn(-uh * w * np.sin(w * t) + vh * np.cos(w * t)))


@pytest.mark.parametrize("shape", [(16,), (8, 6), (4, 4, 6)])
def test_the_fourier_coordinates_are_the_normalized_coefficients(shape):
    prob = ti.problems.wave(shape if len(shape) > 1 else shape[0], rho=1.0)
    u = np.random.default_rng(1).standard_normal(shape)
    q = prob.fourier(u)
    # mean_x u² = |q|², the map is invertible, and the grid comes back
    assert np.isclose(np.mean(u**2), np.sum(q**2), rtol=1e-13)
    back = prob.coordinate_map.to_user(q[None, :])[0]
    assert np.max(np.abs(back - u.reshape(-1))) < 1e-13
    # each block's energy with p = 0 is ω_j² (|û_j|² + |û_−j|²)/2 (numpy's FFT, independently)
    uh = np.fft.fftn(u) / u.size
    e = 0.5 * prob.omega**2 * q**2
    for b, j in list(enumerate(prob.modes))[:10]:
        per_block = e[prob.blocks == b + 1].sum()
        jj = tuple(int(c) % n for c, n in zip(j, shape, strict=True))
        mj = tuple(int(-c) % n for c, n in zip(j, shape, strict=True))
        want = 0.5 * prob.mode_frequencies[b] ** 2 * (abs(uh[jj]) ** 2 + (abs(uh[mj]) ** 2 if mj != jj else 0.0))
        assert np.isclose(per_block, want, rtol=1e-12, atol=1e-16)


def test_the_grid_map_permutes_in_the_core_as_numpy_would_and_refuses_a_bad_order():
    prob = ti.problems.wave((8, 6), rho=1.0)
    cmap = prob.coordinate_map
    grid, order = prob.fourier_grid, cmap.__reduce__()[1][1]  # (the grid and the order it was made of)
    assert cmap.kind == "fourier" and cmap.dim == 48
    rng = np.random.default_rng(3)
    q, u = rng.standard_normal((3, 48)), rng.standard_normal((2, 48))
    canonical = np.empty_like(q)
    canonical[:, order] = q
    # the permutation is data movement only: the same bits as permuting in NumPy
    assert np.array_equal(grid.to_grid(q, order), grid.to_grid(canonical))
    assert np.array_equal(grid.from_grid(u, order), grid.from_grid(u)[:, order])
    # the problem's coordinate map (the core's) keeps the order checked once (and through a
    # pickle), on states of any leading shape
    ordered = grid.ordered(order)
    for g in (cmap, pickle.loads(pickle.dumps(cmap))):
        assert np.array_equal(g.to_user(q), grid.to_grid(q, order))
        assert np.array_equal(g.to_core(u), grid.from_grid(u, order))
        assert np.array_equal(g.to_user(q.reshape(3, 1, 48)), grid.to_grid(q, order).reshape(3, 1, 48))
    for g in (ordered, pickle.loads(pickle.dumps(ordered))):
        assert np.array_equal(g.to_grid(q), grid.to_grid(q, order))
        assert np.array_equal(g.from_grid(u), grid.from_grid(u, order))
    assert np.array_equal(pickle.loads(pickle.dumps(grid)).to_grid(canonical), grid.to_grid(canonical))
    # a non-contiguous or column-major input gives what its contiguous copy gives
    assert np.array_equal(grid.to_grid(q[:, ::-1], order), grid.to_grid(np.ascontiguousarray(q[:, ::-1]), order))
    assert np.array_equal(grid.to_grid(np.asfortranarray(q), order), grid.to_grid(q, order))
    assert np.array_equal(cmap.to_user(np.asfortranarray(q)), cmap.to_user(q))
    for bad, match in [(np.zeros(48, dtype=np.int64), "repeated"), (np.arange(47), "47 entries"),
                       (np.arange(48) + 1, "out of range")]:
        with pytest.raises(ValueError, match=match):
            grid.to_grid(q, bad)
        with pytest.raises(ValueError, match=match):
            grid.ordered(bad)


@pytest.mark.filterwarnings("ignore:numerical resonance")
@pytest.mark.parametrize("shape", [(1 << 15,), (12, 10), (6, 4, 8)])
def test_repeated_calls_give_the_same_bits(shape):
    # Big buffers freed by one call are handed to the next (zeroed where the core asks for
    # zeros), and the wave potential keeps its workspace from one run for the next: what a run
    # on other data left in them changes no bit of the next run, against a new problem's.
    def problem():
        return ti.problems.wave(shape if len(shape) > 1 else shape[0], rho=1.0, potential="u**4/4")

    def run(prob, u0, v0):
        return ti.integrate(prob, "B", u0, v0, h=0.01, n_steps=6, save_every=3)

    prob = problem()
    u0, v0 = smooth_data(shape)
    first = run(prob, u0, v0)
    run(prob, 2.0 * u0 + 0.1, -v0)
    ti.ensemble(prob, "B", np.array([u0, -u0]), np.array([v0, v0]), h=0.02, n_steps=4, save_every=2)
    for sol in (run(prob, u0, v0), run(prob, u0, v0), run(problem(), u0, v0)):
        assert np.array_equal(sol.q, first.q) and np.array_equal(sol.p, first.p)
        assert np.array_equal(sol.max_deviation.to_numpy(), first.max_deviation.to_numpy())
        assert np.array_equal(sol.energies["action"].values, first.energies["action"].values)


def test_the_first_sample_is_the_initial_state_as_given():
    # not the state taken to the Fourier coordinates and back, which differs by rounding
    prob = ti.problems.wave((12, 10), rho=1.0, potential="u**4/4")
    u0, v0 = smooth_data((12, 10), seed=3)
    sol = ti.integrate(prob, "C", u0, v0, h=0.05, n_steps=4, save_every=2)
    assert np.array_equal(sol.q[0].reshape(u0.shape), u0) and np.array_equal(sol.p[0].reshape(v0.shape), v0)
    back = prob.coordinate_map.to_user(prob.coordinate_map.to_core(u0.reshape(1, -1)))
    assert not np.array_equal(back[0], u0.reshape(-1))  # the round trip this saves does round
    ds = ti.ensemble(prob, "C", np.array([u0, 2 * u0]), np.array([v0, v0]), h=0.05, n_steps=4, save_every=2)
    assert np.array_equal(ds["q"].values[1, 0].reshape(u0.shape), 2 * u0)
    assert np.array_equal(ds["q"].values[0], sol.q) and np.array_equal(ds["p"].values[0], sol.p)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("shape", [(32,), (8, 10)])
def test_the_linear_equation_is_solved_exactly_and_its_actions_are_kept(method, shape):
    prob = ti.problems.wave(shape if len(shape) > 1 else shape[0], rho=0.7)
    u0, v0 = smooth_data(shape)
    h, n = 0.37, 40
    sol = ti.integrate(prob, method, u0, v0, h=h, n_steps=n, save_every=n)
    u, v = exact_linear(shape, 0.7, u0, v0, n * h)
    assert np.max(np.abs(sol.q[-1] - u.reshape(-1))) < 1e-12
    assert np.max(np.abs(sol.p[-1] - v.reshape(-1))) < 1e-11
    actions = sol.energies["action"].values
    assert np.max(np.abs(actions[-1] - actions[0])) <= 1e-13 * np.max(actions[0])
    # streamed every step: every mode's energy kept to rounding
    blocks = [v for k, v in sol.max_deviation.items() if k.startswith("oscillatory_")]
    assert len(blocks) == prob.modes.shape[0]
    assert max(abs(b) for b in blocks) <= 1e-13 * sol.initial_energies["total"]
    # momentum, streamed at every step: conserved by the linear flow and by every method
    k = sol.energies["momentum"].values
    assert k.shape == (2, len(shape)) and np.max(np.abs(k[0])) > 1e-4
    for m in range(len(shape)):
        assert abs(sol.max_deviation[f"momentum_{m + 1}"]) < 1e-15 * (1 + np.max(np.abs(k[0])))


def test_the_streamed_momentum_is_the_momentum_of_the_samples_and_changes_nothing_else():
    shape = (8, 6)
    prob = ti.problems.wave(shape, rho=1.0, potential="u**4/4 + u**3/3")
    u0, v0 = smooth_data(shape, seed=6)
    for form in ("two-step", "one-step"):
        sol = ti.integrate(prob, "C", u0, v0, h=0.05, n_steps=60, save_every=20, form=form)
        assert np.allclose(sol.energies["momentum"].values, prob.momentum(sol.q, sol.p), rtol=1e-12, atol=1e-16)
        # the same run without the momentum channels: the same states and energies, bit for bit
        plain = ti.problems.wave(shape, rho=1.0, potential="u**4/4 + u**3/3")
        plain.pair_forms, plain.n_axes = None, 0
        other = ti.integrate(plain, "C", u0, v0, h=0.05, n_steps=60, save_every=20, form=form)
        assert np.array_equal(sol.q, other.q) and np.array_equal(sol.p, other.p)
        assert np.array_equal(sol.energies["total"].values, other.energies["total"].values)
        assert sol.max_deviation["total"] == other.max_deviation["total"]
        assert "momentum_1" not in other.max_deviation


@pytest.mark.parametrize("shape", [(2,), (2, 2), (2, 2, 2), (2, 4)])
def test_grids_of_two_points_along_an_axis_run_with_no_momentum_along_it(shape):
    # Two points along an axis give its modes no sine part: no mode moves along it, the
    # momentum's component is the empty sum, 0 (these grids were once refused by the core:
    # "0 first and 0 second indices"), and the others are those of the samples.
    prob = ti.problems.wave(shape if len(shape) > 1 else shape[0], rho=1.0, potential="u**4/4")
    u0, v0 = smooth_data(shape, seed=2)
    sol = ti.integrate(prob, "B", u0, v0, h=0.05, n_steps=20, save_every=5)
    got = np.atleast_2d(sol.energies["momentum"].values.T).T
    want = prob.momentum(sol.q, sol.p)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-16)
    at_rest = ti.energies(prob, u0, v0)
    for axis, n in enumerate(shape):
        if n == 2:
            assert np.all(got[:, axis] == 0.0) and sol.max_deviation[f"momentum_{axis + 1}"] == 0.0
            assert float(at_rest[f"momentum_{axis + 1}"]) == 0.0
    if shape == (2, 4):
        assert np.abs(got[:, 1]).max() > 1e-4  # a mode moves along the second axis
    lanes = ti.ensemble(prob, "B", u0, v0, h=[0.05, 0.04], n_steps=20)
    assert np.array_equal(lanes.max_deviation.values[0], [sol.max_deviation[k] for k in lanes.energy.values])


def test_energies_and_tangent_maps_take_grid_values_as_integrate_does():
    shape = (8, 6)
    prob = ti.problems.wave(shape, rho=1.0, potential="u**4/4")
    u0, v0 = smooth_data(shape, seed=4)
    grid = ti.energies(prob, u0, v0)
    flat = ti.energies(prob, u0.ravel(), v0.ravel())
    assert all(np.array_equal(grid[k].values, flat[k].values) for k in flat.data_vars)
    stacked = ti.energies(prob, np.stack([u0, v0]), np.stack([v0, u0]))
    assert np.array_equal(stacked["total"].values[0], flat["total"].values)
    du, dv = smooth_data(shape, seed=5)
    dq, dp = ti.tangent_map(prob, "B", u0, v0, du, dv, h=0.05, n_steps=3)
    fq, fp = ti.tangent_map(prob, "B", u0, v0, du.ravel(), dv.ravel(), h=0.05, n_steps=3)
    assert dq.shape == dp.shape == shape
    assert np.array_equal(dq.ravel(), fq) and np.array_equal(dp.ravel(), fp)
    many_q, many_p = ti.tangent_map(prob, "B", u0, v0, np.stack([du, dv]), np.stack([dv, du]), h=0.05, n_steps=3)
    assert many_q.shape == (2, *shape) and np.array_equal(many_q[0], dq)
    with pytest.raises(ValueError, match=r"dq: expected grid values of shape \(8, 6\)"):
        ti.tangent_map(prob, "B", u0, v0, du[:4], dv[:4], h=0.05)


def test_momentum_is_minus_the_mean_of_v_times_grad_u():
    shape = (12, 8)
    prob = ti.problems.wave(shape, rho=1.0)
    u, v = smooth_data(shape, seed=3)
    kx, ky = wavenumbers(shape)
    kx = np.where(np.abs(kx) == shape[0] // 2, 0.0, kx)
    ky = np.where(np.abs(ky) == shape[1] // 2, 0.0, ky)
    ux = np.real(np.fft.ifftn(1j * kx * np.fft.fftn(u)))
    uy = np.real(np.fft.ifftn(1j * ky * np.fft.fftn(u)))
    want = [-np.mean(v * ux), -np.mean(v * uy)]
    got = prob.momentum(u.reshape(1, -1), v.reshape(1, -1))[0]
    assert np.allclose(got, want, rtol=1e-12, atol=1e-15)
    assert abs(want[0]) > 1e-3


@pytest.mark.parametrize("shape", [(16,), (6, 8)])
def test_every_method_has_order_two(shape):
    rho = 1.0
    prob = ti.problems.wave(shape if len(shape) > 1 else shape[0], rho=rho, potential="u**4/4 + u**3/3")
    u0, v0 = smooth_data(shape, seed=2)
    t_end = 1.0
    ref = solve_ivp(semi_discrete_rhs(shape, rho, lambda u: u**3 + u**2), (0, t_end),
                    np.concatenate([u0.reshape(-1), v0.reshape(-1)]), method="DOP853", rtol=1e-13, atol=1e-13)
    exact = ref.y[: u0.size, -1]
    for method in METHODS:
        errors = []
        for n in (40, 80):
            sol = ti.integrate(prob, method, u0, v0, h=t_end / n, n_steps=n, save_every=n)
            errors.append(np.max(np.abs(sol.q[-1] - exact)))
        rate = np.log2(errors[0] / errors[1])
        assert 1.8 < rate < 2.3, (method, errors)


def test_energy_actions_and_momentum_are_nearly_kept_on_a_weakly_nonlinear_equation():
    # Cohen, Hairer, Lubich (2008), §6: u_tt = u_xx − ρu − u², small data, hω far from π
    prob = ti.problems.wave(64, rho=0.5, potential="u**3/3")
    x, = prob.grid
    u0 = 0.01 * (x - np.pi) ** 2 * np.sin(x) ** 2 + 0.01 * np.cos(3 * x + 1)
    v0 = 0.01 * np.sin(x)
    sol = ti.integrate(prob, "B", u0, v0, h=0.05, n_steps=10000, save_every=1000)
    # measured 2.5e-5 (energy), 8.3e-2 (actions of the 6 lowest modes), 5e-9 (momentum)
    assert abs(sol.max_deviation["total"]) < 1e-4 * sol.initial_energies["total"]
    a = sol.energies["action"].sel(mode=slice(0, 5)).values
    assert np.max(np.abs(a - a[0])) < 0.15 * np.max(a[0])
    k = sol.energies["momentum"].values[:, 0]
    # the collocation's aliasing breaks translation invariance: K is not exact, but close
    # (streamed: its maximal deviation over every step)
    assert 0 < np.ptp(k) <= sol.max_deviation["momentum_1"] * 2 < 1e-7 * abs(k[0])


def test_the_grid_potential_agrees_with_python_callables():
    shape = (8, 6)
    compiled = ti.problems.wave(shape, rho=2.0, potential="c*sin(u) + u**4", params={"c": 0.5})
    python = ti.problems.wave(shape, rho=2.0, potential=(lambda u: 0.5 * np.sin(u) + u**4,
                                                         lambda u: 0.5 * np.cos(u) + 4 * u**3))
    u0, v0 = smooth_data(shape, seed=4)
    a = ti.integrate(compiled, "C", u0, v0, h=0.05, n_steps=20, save_every=20)
    b = ti.integrate(python, "C", u0, v0, h=0.05, n_steps=20, save_every=20)
    assert np.max(np.abs(a.q - b.q)) < 1e-13
    assert abs(a.energies["total"][-1] - b.energies["total"][-1]) < 1e-13


def quartic(**wrong):
    """(V, V', V'') of V(u) = u⁴/4, with the functions named in `wrong` replaced."""
    functions = {"V": lambda u: u**4 / 4, "V'": lambda u: u**3, "V''": lambda u: 3 * u**2, **wrong}
    return tuple(functions.values())


@pytest.mark.parametrize(("wrong", "message"), [
    ({"V'": lambda u: np.ones(5)}, r"V' \(function 2 of the potential tuple\) returned an array of shape \(5,\)"),
    ({"V": lambda u: 1.0}, r"V \(function 1 of the potential tuple\) returned a single number"),
    ({"V": lambda u: None}, r"V \(function 1 of the potential tuple\) returned None"),
    ({"V'": lambda u: "u**3"}, r"V' \(function 2 of the potential tuple\) returned str, not real numbers"),
])
def test_python_functions_that_return_the_wrong_shape_are_named(wrong, message):
    prob = ti.problems.wave(16, rho=1.0, potential=quartic(**wrong)[:2])
    u0, v0 = smooth_data((16,))
    with pytest.raises((ValueError, TypeError), match=f"^potential: {message}.*; it must return one value per "
                                                      r"grid point, an array of the shape of u, here \(1, 16\)$"):
        ti.integrate(prob, "B", u0, v0, h=0.05, n_steps=2)


def test_a_python_wave_potential_gives_the_tangent_map_its_second_derivative():
    u0, v0 = smooth_data((16,))
    pair = ti.problems.wave(16, rho=1.0, potential=quartic()[:2])
    with pytest.raises(ValueError, match=r"^potential: the wave's potential is a pair \(V, V'\) of Python functions, "
                                         r"which gives no second derivative .* give V'' too, "
                                         r"potential=\(V, V', V''\), .* \(finite_differences=True\)$"):
        ti.lyapunov(pair, "B", u0, v0, h=0.05, n_steps=10)
    exact = ti.lyapunov(ti.problems.wave(16, rho=1.0, potential="u**4/4"), "B", u0, v0, h=0.05, n_steps=400,
                        n_exponents=2)
    given = ti.lyapunov(ti.problems.wave(16, rho=1.0, potential=quartic()), "B", u0, v0, h=0.05, n_steps=400,
                        n_exponents=2)
    differenced = ti.lyapunov(pair, "B", u0, v0, h=0.05, n_steps=400, n_exponents=2, finite_differences=True)
    assert given.second_derivatives == "user hessian_vector"
    np.testing.assert_allclose(given.exponents, exact.exponents, rtol=1e-10)
    np.testing.assert_allclose(differenced.exponents, exact.exponents, rtol=1e-5)
    bad = ti.problems.wave(16, rho=1.0, potential=quartic(**{"V''": lambda u: 3.0}))
    with pytest.raises(ValueError, match=r"V'' \(function 3 of the potential tuple\) returned a single number"):
        ti.lyapunov(bad, "B", u0, v0, h=0.05, n_steps=10)
    with pytest.raises(TypeError, match=r"give a tuple \(V, V'\) or \(V, V', V''\)"):
        ti.problems.wave(16, potential=[lambda u: u**4 / 4, lambda u: u**3])


@pytest.mark.parametrize("shape", [(16,), (6, 4), (4, 2, 4)])
def test_ensemble_lanes_equal_integrate_bit_for_bit(shape):
    # On grids of several axes the momentum's pairs come in runs that ride along the sweep of
    # the lanes as of one trajectory.
    prob = ti.problems.wave(shape if len(shape) > 1 else shape[0], rho=1.0, potential="u**4/4")
    u0, v0 = smooth_data(shape, seed=5)
    axes = len(shape)
    deltas = [0.0, 1e-3, -2e-3]
    q0 = np.array([u0 + d for d in deltas])
    p0 = np.array([v0] * 3)
    ds = ti.ensemble(prob, "B", q0, p0, h=np.array([0.1, 0.1, 0.07]), n_steps=50, save_every=25, threads=2)
    for t, h in enumerate([0.1, 0.1, 0.07]):
        sol = ti.integrate(prob, "B", q0[t], p0[t], h=h, n_steps=50, save_every=25)
        kept = ds["step"].values[t] >= 0
        assert np.array_equal(ds["q"].values[t][kept], sol.q)
        assert np.array_equal(ds["energies"].values[t][kept][:, 0], sol.energies["total"].values)
        assert np.array_equal(ds["energies"].values[t][kept][:, -axes:], sol.energies["momentum"].values)
        assert np.array_equal(ds["max_deviation"].values[t], np.array(list(sol.max_deviation.values())))
        assert np.array_equal(ds["action"].values[t][kept], sol.energies["action"].values)
        assert np.array_equal(ds["action"].wavenumber.values, sol.energies["action"].wavenumber.values)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"n": 7}, "even"),
    ({"n": 0}, "n"),
    ({"n": (4, 5)}, "even"),
    ({"n": (2, 2, 2, 2)}, "tuple of 2 or 3"),
    ({"n": 8, "rho": -1.0}, "rho"),
    ({"n": 8, "potential": "u*x"}, "x"),
    ({"n": 8, "potential": "__import__('os')"}, "potential"),
    ({"n": 8, "potential": lambda u: u}, "derivative"),
    ({"n": 8, "modes": [100]}, "not a wavevector"),
    ({"n": 8, "modes": [1, 2.5]}, r"modes: expected wavevectors of integers, such as \[1, 2, 5\], got \[1, 2.5\]"),
    ({"n": 8, "modes": 2**70}, "wavevectors of integers"),  # once an OverflowError
    ({"n": 8, "modes": float("inf")}, "wavevectors of integers"),
    ({"n": 8, "modes": [[1, 0]]}, r"ints on a 1-D grid.*shape \(1, 2\)"),
    ({"n": (8, 6), "modes": [(1, 2, 3)]}, r"2-tuples on a 2-D grid"),
])
def test_bad_wave_problems_are_refused(kwargs, match):
    n = kwargs.pop("n")
    with pytest.raises((ValueError, TypeError), match=match):
        ti.problems.wave(n, **kwargs)


def test_bad_initial_data_and_resonant_step_sizes_are_refused():
    prob = ti.problems.wave(16, rho=0.0, potential="u**4/4")
    u0, v0 = smooth_data((16,))
    with pytest.raises(ValueError, match=r"shape \(16,\)"):
        ti.integrate(prob, "B", u0[:8], v0, h=0.1, n_steps=1)
    bad = u0.copy()
    bad[3] = np.nan
    with pytest.raises(ValueError, match="finite"):
        ti.integrate(prob, "B", bad, v0, h=0.1, n_steps=1)
    # ρ = 0: ω_2 = 2, so h = π/2 puts hω_2 on π, where sinc(hω) of the two-step form vanishes
    with pytest.raises(ValueError, match="multiples of pi"):
        ti.integrate(prob, "B", u0, v0, h=np.pi / 2, n_steps=1)


def test_energies_of_given_grid_states_match_the_streamed_ones():
    prob = ti.problems.wave((8, 6), rho=1.0, potential="u**4/4")
    u0, v0 = smooth_data((8, 6), seed=7)
    sol = ti.integrate(prob, "B", u0, v0, h=0.05, n_steps=10, save_every=10)
    e = ti.energies(prob, sol.q, sol.p)
    assert np.allclose(e["total"].values, sol.energies["total"].values, rtol=1e-14)
    action = sol.energies["action"].isel(mode=2)  # block 3
    assert np.allclose(e["oscillatory_3"].values, action.values * float(action.omega), rtol=1e-13)


def test_the_streamed_extremes_are_those_of_the_samples_of_every_step():
    # In 1-D the observing sweep takes each mode's extremes and the momentum along its pass over
    # the state; the samples are observed on their own. With a sample at every step the two must
    # give the same maximal deviations: bit for bit for H, H_ω, H_slow and the momentum.
    prob = ti.problems.wave(64, rho=1.0, potential="u**4/4 + u**3/3")
    u0, v0 = smooth_data((64,), seed=8)
    sol = ti.integrate(prob, "C", u0, v0, h=0.05, n_steps=150, save_every=1)
    e = sol.energies
    for name in ("total", "oscillatory", "slow"):
        assert sol.max_deviation[name] == np.max(np.abs(e[name].values - e[name].values[0]))
    k = e["momentum"].values[:, 0]
    assert sol.max_deviation["momentum_1"] == np.max(np.abs(k - k[0])) > 0
    action = e["action"]
    mode_energy = action.values * action.omega.values
    for b in range(action.sizes["mode"]):
        want = np.max(np.abs(mode_energy[:, b] - mode_energy[0, b]))
        assert sol.max_deviation[f"oscillatory_{b + 1}"] == pytest.approx(want, rel=1e-12, abs=1e-18)


@pytest.mark.filterwarnings("ignore:numerical resonance")  # the bits are compared, not judged
@pytest.mark.parametrize("shape", [(600,), (24, 20)])
@pytest.mark.parametrize("method", ["B", "C"])
def test_the_streamed_extremes_do_not_depend_on_where_the_samples_are(shape, method):
    # Between samples the sweep keeps p_n and the modes' energies in scratch (the first places of
    # their arrays) and takes the extremes, the momentum and H along its pass; at a sample it
    # stores them. Sampled at every step or every 13th, the same run: the same bits everywhere.
    # (Grids of more than one pass of the sweep, 256 coordinates: with one, the scratch is the
    # arrays' own places.)
    prob = ti.problems.wave(shape if len(shape) > 1 else shape[0], rho=1.0, potential="u**4/4 + u**3/3")
    u0, v0 = smooth_data(shape, seed=5)
    every = ti.integrate(prob, method, u0, v0, h=0.05, n_steps=156, save_every=1)
    sparse = ti.integrate(prob, method, u0, v0, h=0.05, n_steps=156, save_every=13)
    assert list(sparse.max_deviation) == list(every.max_deviation)
    assert np.array_equal(sparse.max_deviation.to_numpy(), every.max_deviation.to_numpy())
    assert np.array_equal(sparse.q, every.q[::13]) and np.array_equal(sparse.p, every.p[::13])
    assert np.array_equal(sparse.energies["action"].values, every.energies["action"].values[::13])
    assert np.max(sparse.max_deviation.to_numpy()) > 0


def test_the_deviation_of_the_momentum_and_of_every_action():
    prob = ti.problems.wave(16, rho=1.0, potential="u**4/4")
    x = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    sol = ti.integrate(prob, "B", 0.1 * np.sin(x) + 0.05 * np.cos(2 * x), 0.02 * np.sin(3 * x), h=0.01,
                       n_steps=200, save_every=20)
    action = sol.deviation("action")
    assert action.dims == ("t", "mode") and np.all(action.values[0] == 0.0)
    assert np.array_equal(action.values, sol.energies["action"].values - sol.energies["action"].values[0])
    assert np.max(np.abs(action.values)) > 0  # the actions move (u**4 couples the modes)
    momentum = sol.deviation("momentum")
    assert momentum.dims == ("t", "axis") and np.all(momentum.values[0] == 0.0)
