"""Sampling, streamed diagnostics, blow-up and interruption."""

import numpy as np
import pytest

import trigint as ti
from trigint.energies import energy_names


def test_samples_include_first_and_last_step(fpu):
    prob, q0, p0 = fpu
    sol = ti.integrate(prob, "B", q0, p0, h=0.01, n_steps=1000, save_every=300)
    assert sol.steps.tolist() == [0, 300, 600, 900, 1000]
    assert sol.t == pytest.approx(sol.steps * 0.01)
    assert sol.q.shape == (5, 6) and sol.p.shape == (5, 6)
    assert list(sol.energies.data_vars) == energy_names(1)  # the core's channel table, in order
    assert np.array_equal(sol.q[0], q0) and np.array_equal(sol.p[0], p0)


def test_max_deviation_is_over_every_step(fpu):
    prob, q0, p0 = fpu
    every = ti.integrate(prob, "A", q0, p0, h=0.03, n_steps=2000, save_every=1)
    sparse = ti.integrate(prob, "A", q0, p0, h=0.03, n_steps=2000, save_every=500)
    for name in every.energies.data_vars:
        from_samples = float(np.max(np.abs(every.energies[name] - every.initial_energies[name])))
        assert sparse.max_deviation[name] == from_samples  # bit for bit
        assert sparse.max_deviation[name] >= float(np.max(np.abs(sparse.deviation(name))))
    assert np.array_equal(every.q[::500], sparse.q)


def test_energies_agree_with_numpy_formulas(fpu):
    prob, q0, p0 = fpu
    method = ti.Trigonometric("D")
    sol = ti.integrate(prob, method, q0, p0, h=0.03, n_steps=300, save_every=30)
    e = ti.energies(prob, sol.q, sol.p, method, 0.03)
    for name in sol.energies.data_vars:
        assert np.allclose(sol.energies[name].values, e[name].values, rtol=1e-13, atol=1e-14)


def test_many_steps_keep_memory_flat(fpu):
    prob, q0, p0 = fpu
    sol = ti.integrate(prob, "B", q0, p0, h=2 * np.pi / 3 / 50, n_steps=10**7, save_every=10**6,
                       progress=False)
    assert sol.t.size == 11 and sol.status == "completed" and sol.n_steps == 10**7


def test_untracked_run_has_nan_deviation_but_sampled_energies(fpu):
    prob, q0, p0 = fpu
    sol = ti.integrate(prob, "B", q0, p0, h=0.03, n_steps=100, save_every=10, track_energies=False)
    assert np.isnan(sol.max_deviation["total"])
    assert float(sol.energies["total"][0]) == pytest.approx(2.00120008)


def test_blow_up_stops_and_keeps_samples():
    prob = ti.OscillatoryProblem([1.0], ti.PolynomialPotential([-1.0], [[4]]))
    with pytest.warns(RuntimeWarning, match="blew up"):
        sol = ti.integrate(prob, "B", [2.0], [1.0], h=0.1, n_steps=100_000, save_every=5)
    assert sol.status == "blow-up" and not sol.success
    assert 0 < sol.n_steps < 1000
    assert np.all(np.isfinite(sol.q)) and sol.steps[-1] <= sol.n_steps
    assert "step" in sol.message


def test_progress_callback_can_stop_the_run(fpu):
    prob, q0, p0 = fpu
    seen = []

    def progress(done):
        seen.append(done)
        return len(seen) < 2

    with pytest.warns(RuntimeWarning, match="interrupted"):
        sol = ti.integrate(prob, "B", q0, p0, h=0.03, n_steps=5 * 2**20, save_every=2**20,
                           progress=progress)
    assert sol.status == "interrupted"
    assert seen == [2**20, 2**21] and sol.n_steps == 2**21
    assert sol.steps.tolist() == [0, 2**20, 2**21]


def test_python_potential_exception_reaches_the_user():
    def gradient(q):
        raise ZeroDivisionError("boom in gradient")

    prob = ti.OscillatoryProblem([0.0, 5.0], ti.PythonPotential(lambda q: 0.0, gradient))
    with pytest.raises(ZeroDivisionError, match="boom in gradient"):
        ti.integrate(prob, "B", [0.0, 0.0], [1.0, 1.0], h=0.1, n_steps=10)


def test_ctrl_c_interrupts_a_long_run(tmp_path):
    """Ctrl-C stops a run of 10¹⁰ steps and returns its samples (how fast it does is measured by
    benchmarks/run.py, not here: a loaded machine must not fail the test)."""
    import signal
    import subprocess
    import sys
    import time

    from conftest import with_default_sigint

    script = tmp_path / "long.py"
    script.write_text(with_default_sigint(
        "import numpy as np, trigint as ti\n"
        "prob = ti.problems.fpu(); q0, p0 = ti.problems.fpu_initial()\n"
        "print('started', flush=True)\n"
        "sol = ti.integrate(prob, 'B', q0, p0, h=0.01, n_steps=10**10, save_every=10**6, progress=False)\n"
        "print(sol.status, sol.n_steps, sol.t.size, flush=True)\n"
    ))
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "started"
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=600)  # a guard against a hang, not a speed test
    status, steps, samples = out.split()
    # every 10**6-th step, and the state where the run stopped
    last = 1 if int(steps) % 10**6 else 0
    assert status == "interrupted" and int(steps) > 0 and int(samples) == int(steps) // 10**6 + 1 + last
    assert "interrupted after step" in err


def test_energies_built_when_read_survive_pickling_and_a_wave_problem():
    """The Dataset of energies is made when first read (a short call's fixed cost): a solution
    pickled before that reads the same numbers as one read at once, a wave problem's actions
    included, and both hold the streamed channels at the samples."""
    import pickle

    prob = ti.problems.wave(64, rho=1.0, potential="u**4/4")
    (x,) = prob.grid
    sol = ti.integrate(prob, "B", 0.3 * np.cos(x), 0 * x, h=0.05, n_steps=40, save_every=20)
    early = pickle.loads(pickle.dumps(sol))
    read = sol.energies
    assert sol.energies is read  # built once
    late = early.energies
    assert list(late.data_vars) == list(read.data_vars)
    for name in read.data_vars:
        assert np.array_equal(late[name].values, read[name].values)
    assert late["action"].dims == ("t", "mode") and late.sizes["t"] == 3
    # the streamed total at the first sample is the initial energy, bit for bit
    assert float(read["total"][0]) == sol.initial_energies["total"]
