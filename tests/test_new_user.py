"""What a careful new user tripped over: the final sample of an ensemble, sizes the core could not
allocate, misspelt method names, strings where grid values belong."""

import numpy as np
import pytest
import scipy.sparse

import trigint as ti
from trigint.energies import energy_names

H = 2 * np.pi / 3 / 50


def fpu_case():
    prob = ti.problems.fpu(3, 50.0)
    q0, p0 = ti.problems.fpu_initial(3, 50.0)
    return prob, q0, p0, H


def krylov_case():
    n = 40
    a = scipy.sparse.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]).tocsr() * 100.0
    pot = ti.ChainPotential(n).add("y**4/4", "y", pairs=[(i, i + 1) for i in range(n - 1)])
    prob = ti.OscillatoryProblem(stiffness=a, potential=pot, path="krylov")
    x = np.linspace(0, 1, n)
    return prob, 0.1 * np.sin(np.pi * x), np.zeros(n), 0.02


def wave_case():
    prob = ti.problems.wave(32, rho=1.0)
    x = prob.grid[0]
    return prob, 0.1 * np.cos(x), 0.05 * np.sin(2 * x), 0.05


@pytest.mark.parametrize("case", [fpu_case, krylov_case, wave_case], ids=["fpu", "krylov", "wave"])
@pytest.mark.parametrize("n_steps, save_every", [(50, 50), (50, 10), (50, 7)])
def test_the_last_sample_of_an_ensemble_is_the_final_state_of_integrate(case, n_steps, save_every):
    prob, q0, p0, h = case()
    Q0, P0 = ti.perturb(q0, p0, [0.0, 1e-9])
    ds = ti.ensemble(prob, "B", Q0, P0, h=h, n_steps=n_steps, save_every=save_every, threads=1)
    one = ti.integrate(prob, "B", Q0[1], P0[1], h=h, n_steps=n_steps, save_every=save_every)
    expected = list(range(0, n_steps + 1, save_every)) + ([n_steps] if n_steps % save_every else [])
    # no padding where the trajectories share n_steps: the last sample is the final state
    assert ds.step.values[1].tolist() == expected
    np.testing.assert_array_equal(ds.q.values[1, -1], np.asarray(one.q)[-1].reshape(-1))
    np.testing.assert_array_equal(ds.p.values[1, -1], np.asarray(one.p)[-1].reshape(-1))
    assert np.all(np.isfinite(ds.q.values[:, -1]))
    np.testing.assert_array_equal(ds.last_sample.values, [len(expected) - 1] * 2)


def test_an_ensemble_over_step_sizes_pads_its_shorter_lanes_and_last_sample_selects_each_final_state():
    prob, q0, p0, _ = fpu_case()
    Q0, P0 = ti.perturb(q0, p0, [0.0, 0.0])
    ds = ti.ensemble(prob, "B", Q0, P0, h=[2.0 / 50, 2.1 / 50], t_end=1.0, save_every=10)
    n = ds.n_steps.values
    assert n[0] != n[1]
    final = ds.q.isel(sample=ds.last_sample)
    for lane in range(2):
        one = ti.integrate(prob, "B", q0, p0, h=float(ds.h.values[lane]), n_steps=int(n[lane]), save_every=10)
        np.testing.assert_array_equal(final.values[lane], np.asarray(one.q)[-1])
        assert int(ds.step.values[lane, int(ds.last_sample[lane])]) == n[lane]


@pytest.mark.parametrize("make", [
    lambda: ti.ChainPotential(10**12),
    lambda: ti.FPUPotential(10**12),
    lambda: ti.PythonPotential(lambda q: 0.0, lambda q: q, dim=10**12),
    lambda: ti.problems.wave((2**20, 2**20), rho=1.0),
], ids=["chain", "fpu", "python", "wave"])
def test_sizes_no_machine_can_hold_are_refused_before_anything_is_allocated(make):
    with pytest.raises(ValueError, match=r"would need at least .*iB .*more than this machine's"):
        make()


def test_a_dense_stiffness_no_machine_can_hold_is_refused_with_its_size():
    with pytest.raises(ValueError, match=r"m: a dense 20000000 x 20000000 matrix would need 2.84 PiB"):
        ti.problems.fpu_stiffness(10**7, 50.0)


def test_a_misspelt_method_name_gets_the_closest_valid_one():
    prob, q0, p0, h = fpu_case()
    with pytest.raises(ValueError, match="did you mean 'stormer-verlet'"):
        ti.integrate(prob, "stormer_verlett", q0, p0, h=h, n_steps=2)


def test_a_string_as_grid_values_names_its_type():
    prob = ti.problems.wave(16, rho=1.0)
    with pytest.raises(TypeError, match=r"q0: expected grid values.*got str"):
        ti.integrate(prob, "B", "zeros", np.zeros(16), h=0.1, n_steps=2)


def test_an_ordinary_wave_run_is_silent_and_an_energy_carrying_resonance_warns():
    import warnings

    prob = ti.problems.wave(1024, rho=1.0, potential="u**4/4")
    x = prob.grid[0]
    # hK = 5.12 > pi: mode 314 has h*omega near pi, but carries no energy to move
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sol = ti.integrate(prob, "B", 0.01 * (x - np.pi) ** 2 * np.sin(x) ** 2, 0.01 * np.sin(x), h=0.01,
                           n_steps=500, save_every=500)
    assert sol.max_deviation["total"] < 1e-6 * sol.initial_energies["total"]
    h = np.pi / np.sqrt(10) - 1e-4  # h*omega_3 near pi, and mode 3 carries the energy
    with pytest.warns(RuntimeWarning, match=r"mode j = \(3,\).*energy_resonances"):
        ti.integrate(prob, "B", 0.1 * np.cos(3 * x), 0 * x, h=h, n_steps=50, save_every=50)
    # the same step size on the linear equation (V = u²/2): no mode drives another, no warning
    linear = ti.problems.wave(1024, rho=1.0, potential="u**2/2")
    assert linear.linear and not prob.linear
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ti.integrate(linear, "B", 0.1 * np.cos(3 * x), 0 * x, h=h, n_steps=50, save_every=50)


def test_energy_resonances_rank_the_combinations_driven_by_energetic_modes():
    prob = ti.problems.wave(64, rho=1.0)
    omega = prob.mode_frequencies
    e = np.zeros(len(prob.modes))
    assert prob.modes[1].tolist() == [1] and prob.modes[2].tolist() == [2]
    e[1] = 1.0  # mode 1 carries the energy; the triple (2; 1, 1) moves it into mode 2
    combo = omega[2] - 2 * omega[1]  # omega_2 - omega_1 - omega_1
    h = 2 * np.pi / abs(combo) * (1 + 1e-4)
    ranked = ti.resonance.energy_resonances(prob, h, e, tolerance=0.05)
    assert ranked and ranked[0].affected == (2,)
    assert sorted(abs(m[0]) for m in ranked[0].modes) == [1, 1, 2]
    assert all(a.weight >= b.weight for a, b in zip(ranked[:-1], ranked[1:], strict=True))
    assert ti.resonance.energy_resonances(prob, h, np.zeros(len(prob.modes))) == []


def test_a_wave_solution_prints_a_summary_with_everything_still_reachable():
    prob = ti.problems.wave(1024, rho=1.0, potential="u**3/3")
    x = prob.grid[0]
    sol = ti.integrate(prob, "B", 0.01 * np.cos(x), 0 * x, h=0.01, n_steps=20, save_every=10)
    assert len(repr(sol)) < 600 and "per-block entries" in repr(sol)
    assert len(repr(sol.max_deviation)) < 400
    # the whole-state channels, one per mode, momentum_1
    assert len(sol.max_deviation) == len(energy_names(len(prob.modes), 1))
    assert list(sol.energies.channel.values) == ["momentum_1"]  # axis 0 is momentum_1


def test_the_guides_two_dimensional_example_runs_as_written():
    import re
    from pathlib import Path

    guide = (Path(__file__).parent.parent / "docs" / "guide.md").read_text(encoding="utf-8")
    section = guide[guide.index("### Two and three dimensions"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    scope = {"np": np, "ti": ti}
    exec(code, scope)
    sol, ds, (x, y) = scope["sol"], scope["ds"], scope["prob"].mesh
    assert sol.u.dims == ("t", "x", "y") and sol.u.shape == (6, 64, 64)
    np.testing.assert_allclose(sol.u.values[0], scope["u0"], rtol=0, atol=1e-15)  # through the FFTs
    assert scope["Q0"].shape == (2, 64, 64) and scope["Q0"][1, 3, 5] == scope["u0"][3, 5] + 1e-8
    assert float(ds.max_deviation.sel(energy="total")[0]) == sol.max_deviation["total"]  # lane 0 is sol
    assert float(x[1, 0]) == 2 * np.pi / 64 and float(y[0, 1]) == 2 * np.pi / 64


def test_the_guides_blocks_run_top_to_bottom_in_one_session():
    """Each block of docs/guide.md sees the names the earlier ones left (as a reader pasting them
    in order would): the stiffness-matrix example leaves the FPU's q0 to the scan that follows.
    The scan runs to t = 10 instead of 10⁵."""
    import re
    from pathlib import Path

    guide = (Path(__file__).parent.parent / "docs" / "guide.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", guide, re.S)
    scan = next(i for i, b in enumerate(blocks) if "ti.scan(" in b)
    scope = {}
    for code in blocks[:scan + 1]:
        exec(code.replace("t_end=1e5", "t_end=10.0"), scope)
    assert scope["q0"].shape == (6,) and scope["q0_chain"].shape == (50,)
    assert scope["s"].sizes["h_omega"] == 591 and set(scope["s"].status.values) == {"completed"}
