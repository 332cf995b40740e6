"""Ensembles and sweeps: bit-for-bit equal to single runs whatever the threads, chunks, workers
or batch composition; stores that survive SIGKILL; clear errors."""

import os
import signal
import subprocess
import sys
import textwrap
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import trigint as ti
from conftest import with_default_sigint

H = 2 * np.pi / 3 / 50


@pytest.fixture(scope="module")
def sweep_inputs():
    prob = ti.problems.fpu(m=3, omega=50.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
    Q0, P0 = ti.perturb(q0, p0, np.linspace(-7e-16, 7e-16, 7))
    hs = H * np.linspace(0.97, 1.03, 7)
    return prob, Q0, P0, hs


@pytest.mark.parametrize("method", ["A", "B", "D", "imex"])
def test_each_trajectory_equals_integrate_bit_for_bit(method, sweep_inputs):
    assert_ensemble_equals_integrate(method, *sweep_inputs)


@pytest.mark.parametrize("method", ["B", "D"])
def test_a_uniform_block_gives_the_same_bits_in_bundles_as_alone(method):
    """FPU m = 5: one trajectory alone runs on the uniform shape (one block, one frequency);
    a bundle of lanes on the general one, reading each coordinate's own (equal) numbers."""
    prob = ti.problems.fpu(m=5, omega=50.0)
    q0, p0 = ti.problems.fpu_initial(m=5, omega=50.0)
    Q0, P0 = ti.perturb(q0, p0, np.linspace(-7e-16, 7e-16, 9))
    assert_ensemble_equals_integrate(method, prob, Q0, P0, H * np.linspace(0.97, 1.03, 9))


def assert_ensemble_equals_integrate(method, prob, Q0, P0, hs):
    ds = ti.ensemble(prob, method, Q0, P0, h=hs, t_end=20.0, save_every=40)
    for t in range(len(hs)):
        sol = ti.integrate(prob, method, Q0[t], P0[t], h=hs[t], t_end=20.0, save_every=40)
        k = sol.t.size
        assert ds.n_steps.values[t] == sol.n_steps_requested
        assert np.array_equal(ds.q.values[t, :k], sol.q)
        assert np.array_equal(ds.p.values[t, :k], sol.p)
        assert np.array_equal(ds.step.values[t, :k], sol.steps)
        assert np.all(np.isnan(ds.q.values[t, k:]))
        channels = len(sol.max_deviation)
        assert [ds.max_deviation.values[t, j] for j in range(channels)] == list(sol.max_deviation.values())
        assert np.array_equal(ds.energies.values[t, :k], np.column_stack(list(sol.energies.data_vars.values())))


def test_threads_chunks_and_composition_do_not_change_bits(sweep_inputs):
    prob, Q0, P0, hs = sweep_inputs
    ref = ti.ensemble(prob, "B", Q0, P0, h=hs, t_end=20.0, threads=1)
    for kwargs in (dict(threads=2), dict(chunk_size=1), dict(chunk_size=3, threads=2)):
        other = ti.ensemble(prob, "B", Q0, P0, h=hs, t_end=20.0, **kwargs)
        assert np.array_equal(other.max_deviation.values, ref.max_deviation.values), kwargs
    sub = ti.ensemble(prob, "B", Q0[[5, 1]], P0[[5, 1]], h=hs[[5, 1]], t_end=20.0)
    assert np.array_equal(sub.max_deviation.values, ref.max_deviation.values[[5, 1]])


def test_executor_and_dask_cluster_match_local_run(sweep_inputs):
    prob, Q0, P0, hs = sweep_inputs
    ref = ti.ensemble(prob, "B", Q0, P0, h=hs, t_end=20.0, save_every=100)
    with ThreadPoolExecutor(2) as pool:
        viaexec = ti.ensemble(prob, "B", Q0, P0, h=hs, t_end=20.0, save_every=100, client=pool, chunk_size=2)
    assert viaexec.identical(ref)
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        viadask = ti.ensemble(prob, "B", Q0, P0, h=hs, t_end=20.0, save_every=100, client=client, chunk_size=2)
    assert viadask.identical(ref)


def test_store_resumes_and_refuses_other_calls(tmp_path, sweep_inputs):
    prob, Q0, P0, hs = sweep_inputs
    path = tmp_path / "sweep.zarr"
    first = ti.ensemble(prob, "B", Q0, P0, h=hs, t_end=20.0, chunk_size=2, store=path, save_every=50)
    assert (path / "zarr.json").exists()
    calls = []

    def counting_client():
        class Exec:
            def submit(self, fn, *a, **k):
                calls.append(1)
                from concurrent.futures import Future

                f = Future()
                f.set_result(fn(*a, **k))
                return f

        return Exec()

    again = ti.ensemble(prob, "B", Q0, P0, h=hs, t_end=20.0, chunk_size=2, store=path, save_every=50,
                        client=counting_client())
    assert calls == []  # every chunk was already there
    assert again.identical(first)
    with pytest.raises(ValueError, match=r"different call \(q0 differ\)"):
        ti.ensemble(prob, "B", Q0 * 1.001, P0, h=hs, t_end=20.0, chunk_size=2, store=path, save_every=50)
    with pytest.raises(ValueError, match="h, n_steps"):
        ti.ensemble(prob, "B", Q0, P0, h=hs * 1.1, t_end=20.0, chunk_size=2, store=path, save_every=50)


SWEEP_SCRIPT = textwrap.dedent("""
    import sys, numpy as np, trigint as ti
    prob = ti.problems.fpu(m=3, omega=50.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
    hs = 2 * np.pi / 3 / 50 * np.linspace(0.9, 1.1, 24)
    ds = ti.ensemble(prob, "B", q0, p0, h=hs, t_end=float(sys.argv[2]), chunk_size=2, threads=1,
                     store=sys.argv[1], progress=False)
    np.save(sys.argv[3], ds.max_deviation.values)
""")


#: the sweep's t_end: 12 chunks of 2 trajectories, each chunk long enough (about 30 ms on an AVX-512
#: EPYC; at t_end = 3000 it was 2 ms) that the rest cannot all finish between a poll of the store
#: and the signal
SWEEP_T_END = "60000"


def test_sigkill_loses_nothing_written(tmp_path):
    script = tmp_path / "sweep.py"
    script.write_text(SWEEP_SCRIPT)
    store = tmp_path / "killed.zarr"
    proc = subprocess.Popen([sys.executable, str(script), str(store), SWEEP_T_END, str(tmp_path / "a.npy")])
    import zarr

    deadline = time.time() + 120
    done = 0
    while time.time() < deadline and proc.poll() is None:
        time.sleep(0.05)
        try:
            done = int(np.sum(zarr.open_group(str(store), mode="r")["done"][:]))
        except Exception:
            continue
        if done >= 2:
            break
    assert proc.poll() is None, "the sweep finished before it could be killed; make it longer"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    written = zarr.open_group(str(store), mode="r")
    finished = np.asarray(written["done"][:])
    assert 2 <= finished.sum() < finished.size
    kept = np.asarray(written["max_deviation"][:])[np.repeat(finished, 2)]
    # Rerun with the same store: only the missing chunks are computed; the result equals a fresh run.
    subprocess.run([sys.executable, str(script), str(store), SWEEP_T_END, str(tmp_path / "b.npy")], check=True)
    subprocess.run([sys.executable, str(script), str(tmp_path / "fresh.zarr"), SWEEP_T_END, str(tmp_path / "c.npy")],
                   check=True)
    b, c = np.load(tmp_path / "b.npy"), np.load(tmp_path / "c.npy")
    assert np.array_equal(b, c)
    assert np.array_equal(b[np.repeat(finished, 2)], kept)


def test_ctrl_c_stops_and_keeps_finished_chunks(tmp_path):
    script = tmp_path / "sweep.py"
    script.write_text(with_default_sigint(SWEEP_SCRIPT + "print('statuses', sorted(set(ds.status.values)))\n"))
    store = tmp_path / "interrupted.zarr"
    proc = subprocess.Popen([sys.executable, str(script), str(store), SWEEP_T_END, str(tmp_path / "a.npy")],
                            stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    import zarr

    deadline = time.time() + 120
    while time.time() < deadline:
        time.sleep(0.05)
        try:
            if int(np.sum(zarr.open_group(str(store), mode="r")["done"][:])) >= 1:
                break
        except Exception:
            continue
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=600)  # a guard against a hang, not a speed test
    assert proc.returncode == 0, err
    assert "interrupted: kept" in err
    assert "interrupted" in out and "completed" in out


def test_blow_up_is_per_trajectory():
    prob = ti.OscillatoryProblem([1.0], ti.PolynomialPotential([-1.0], [[4]]))
    with pytest.warns(RuntimeWarning, match="1 of 2 trajectories blew up"):
        ds = ti.ensemble(prob, "B", [[2.0], [0.01]], [[1.0], [0.0]], h=0.1, n_steps=5000)
    assert ds.status.values.tolist() == ["blow-up", "completed"]
    assert ds.steps_done.values[0] < 1000 and ds.steps_done.values[1] == 5000


def test_scan_marks_resonances():
    prob = ti.problems.fpu(m=3, omega=50.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
    h_omega = np.linspace(2 * np.pi / 3 - 0.05, 2 * np.pi / 3 + 0.05, 41)
    s = ti.scan(prob, "B", q0, p0, h_omega=h_omega, t_end=300.0)
    assert s.dims == ("h_omega",) and s.sizes["h_omega"] == 41
    assert np.array_equal(s.n_steps.values, np.rint(300.0 / (h_omega / 50)).astype(int))
    single = ti.integrate(prob, "B", q0, p0, h=h_omega[7] / 50, t_end=300.0)
    assert float(s[7]) == single.max_deviation["oscillatory"]


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    (dict(q0=np.zeros((3, 6)), p0=np.zeros((2, 6))), ValueError, "batch sizes differ"),
    (dict(q0=np.zeros((0, 6))), ValueError, "empty"),
    (dict(q0=np.zeros((2, 5))), ValueError, r"shape \(6,\) or \(B, 6\)"),
    (dict(h=[0.01, -0.01]), ValueError, "trajectory 1 has step size -0.01"),
    (dict(h=[0.01, np.nan]), ValueError, "trajectory 1 has step size nan"),
    (dict(h=[0.01, np.pi / 50]), ValueError, r"trajectory 1 \(h = "),
    (dict(q0=np.array([[0.0] * 6, [np.inf] + [0.0] * 5])), ValueError, "trajectory 1, entry 0 is not finite"),
    (dict(chunk_size=0), ValueError, "chunk_size"),
    (dict(save_every=0), ValueError, "save_every"),
])
def test_bad_batches(kwargs, error, match):
    prob = ti.problems.fpu(m=3, omega=50.0)
    args = dict(q0=np.zeros(6), p0=np.zeros(6), h=0.01)
    args.update(kwargs)
    q0, p0, h = args.pop("q0"), args.pop("p0"), args.pop("h")
    with pytest.raises(error, match=match):
        ti.ensemble(prob, "B", q0, p0, h=h, n_steps=10, **args)


@pytest.mark.parametrize("method", ["A", "C", "D", "imex", "stormer-verlet"])
def test_step_sizes_evaluated_together_equal_one_at_a_time(method):
    """ensemble() evaluates every trajectory's coefficients in one elementwise call; each row
    must be bit for bit the numbers integrate() gets for that step size alone."""
    from trigint import _native
    from trigint._batch import prepare
    from trigint._method_names import resolve_method

    omega = np.array([0.0, 50.0, 50 * np.sqrt(2), 70.0, 0.0, 123.0, 3.0])
    prob = ti.OscillatoryProblem(omega, ti.PythonPotential(lambda q: 0.0, lambda q: 0 * q))
    h = np.random.default_rng(5).uniform(0.001, 0.015, 200)
    m = resolve_method(method)
    batch = prepare(prob, m, np.zeros(7), np.zeros(7), h, None, 10)
    for t in range(0, 200, 13):
        rows = _native.method_rows(m.coefficients(h[t], omega), omega > 0)
        for k in _native.METHOD_ROWS:
            assert np.array_equal(rows[k], getattr(batch, k)[t]), (k, t)


FAULT_SCRIPT = textwrap.dedent("""
    import os, signal, sys, numpy as np, trigint as ti
    store, out, chunk, threads, fault = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
    if fault != "none":  # die by SIGKILL at a chosen point of the store's creation
        import zarr
        from trigint import _store
        what, count = fault.split(":")
        calls = [0]
        def dying(original):
            def wrapper(*args, **kwargs):
                calls[0] += 1
                if calls[0] > int(count):
                    os.kill(os.getpid(), signal.SIGKILL)
                return original(*args, **kwargs)
            return wrapper
        if what == "array":
            zarr.Group.create_array = dying(zarr.Group.create_array)
        else:
            _store.os.rename = dying(_store.os.rename)
    prob = ti.problems.fpu(m=3, omega=50.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
    hs = 2 * np.pi / 3 / 50 * np.linspace(0.9, 1.1, 24)
    print("go", flush=True)
    ds = ti.ensemble(prob, "B", q0, p0, h=hs, t_end=300.0, chunk_size=chunk, threads=threads,
                     store=store, save_every=500, progress=False)
    np.save(out, np.concatenate([ds.max_deviation.values.ravel(), np.nan_to_num(ds.q.values.ravel(), nan=-7.0)]))
""")


def test_sigkill_at_any_moment_then_rerun_equals_a_fresh_run(tmp_path):
    """Killed while creating the store (after each array, just before it is renamed into
    place), in its first milliseconds, or later; then resumed with another chunk size and
    thread count: the result equals a fresh run, bit for bit."""
    script = tmp_path / "fault.py"
    script.write_text(FAULT_SCRIPT)

    def run(store, out, chunk, threads, fault="none"):
        return subprocess.run([sys.executable, str(script), str(store), str(out), str(chunk), str(threads), fault],
                              capture_output=True, text=True, timeout=120)

    assert run(tmp_path / "fresh.zarr", tmp_path / "fresh.npy", 3, 1).returncode == 0
    fresh = np.load(tmp_path / "fresh.npy")
    cases = [("array:0", None), ("array:3", None), ("rename:0", None), ("none", 0.0), ("none", 0.003),
             ("none", 0.03), ("none", 0.3)]
    for i, (fault, delay) in enumerate(cases):
        store = tmp_path / f"s{i}.zarr"
        if delay is None:
            assert run(store, tmp_path / "x.npy", 3, 1, fault).returncode == -signal.SIGKILL
        else:
            proc = subprocess.Popen([sys.executable, str(script), str(store), str(tmp_path / "x.npy"), "3", "1",
                                     "none"], stdout=subprocess.PIPE, text=True)
            assert proc.stdout.readline().strip() == "go"
            time.sleep(delay)
            proc.kill()
            proc.wait()
        again = run(store, tmp_path / f"r{i}.npy", 5 + i, 2)
        assert again.returncode == 0, (fault, delay, again.stderr[-1500:])
        assert np.array_equal(np.load(tmp_path / f"r{i}.npy"), fresh), (fault, delay)


def test_store_resumes_under_another_client_and_chunking(tmp_path):
    """A store made with 3 trajectories per chunk and one thread, with one chunk's flag cleared
    (as a kill leaves it), resumes on an executor with another chunk size: the missing chunk is
    recomputed in the store's own chunking and the result equals the first run."""
    from concurrent.futures import ThreadPoolExecutor

    import zarr

    prob = ti.problems.fpu(m=3, omega=50.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
    hs = 2 * np.pi / 3 / 50 * np.linspace(0.9, 1.1, 12)
    store = tmp_path / "s.zarr"
    first = ti.ensemble(prob, "B", q0, p0, h=hs, t_end=50.0, chunk_size=3, threads=1, store=store,
                        save_every=100, progress=False)
    group = zarr.open_group(str(store), mode="a")
    group["done"][1] = False
    group["max_deviation"][3:6] = np.nan
    with ThreadPoolExecutor(2) as pool:
        again = ti.ensemble(prob, "B", q0, p0, h=hs, t_end=50.0, chunk_size=7, client=pool, store=store,
                            save_every=100, progress=False)
    assert np.array_equal(first.max_deviation.values, again.max_deviation.values)
    assert np.array_equal(first.q.values, again.q.values, equal_nan=True)
    assert bool(np.all(zarr.open_group(str(store), mode="r")["done"][:]))


def _quartic_value(q):
    return float(q @ q) ** 2


def _quartic_gradient(q):
    return 4 * float(q @ q) * q


def test_clients_that_cannot_take_work_are_refused_with_what_to_pass(sweep_inputs):
    prob, Q0, P0, hs = sweep_inputs
    with pytest.raises(TypeError, match=r"client: expected a dask.distributed.Client or a concurrent.futures.Executor, "
                                        r"got str; for a scheduler at 'tcp://127.0.0.1:8786' pass "
                                        r"client=dask.distributed.Client\('tcp://127.0.0.1:8786'\)"):
        ti.ensemble(prob, "B", Q0, P0, h=hs, t_end=1.0, client="tcp://127.0.0.1:8786")
    pool = ThreadPoolExecutor(1)
    pool.shutdown()
    with pytest.raises(ValueError, match=r"client: cannot take work \(cannot schedule new futures after shutdown\)"):
        ti.ensemble(prob, "B", Q0, P0, h=hs, t_end=1.0, client=pool)
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        client = Client(cluster)
        client.close()
        with pytest.raises(ValueError, match="client: this dask.distributed.Client is closed"):
            ti.ensemble(prob, "B", Q0, P0, h=hs, t_end=1.0, client=client)


def test_a_process_pool_needs_picklable_python_functions():
    from concurrent.futures import ProcessPoolExecutor

    fpu = ti.problems.fpu()
    q0, p0 = ti.problems.fpu_initial()
    hs = 0.04 * np.array([1.0, 1.01])
    local = ti.OscillatoryProblem(fpu.omega, ti.PythonPotential(lambda q: _quartic_value(q),
                                                                lambda q: _quartic_gradient(q)))
    with ProcessPoolExecutor(1) as pool:
        with pytest.raises(TypeError, match=r"potential: the PythonPotential's functions \(.*<lambda>, .*<lambda>\) "
                                            r"cannot be pickled .*ProcessPoolExecutor.*def at module level"):
            ti.ensemble(local, "B", q0, p0, h=hs, n_steps=200, client=pool)
        # functions found by module and name travel, and give the local run's numbers
        named = ti.OscillatoryProblem(fpu.omega, ti.PythonPotential(_quartic_value, _quartic_gradient))
        there = ti.ensemble(named, "B", q0, p0, h=hs, n_steps=200, client=pool)
    here = ti.ensemble(local, "B", q0, p0, h=hs, n_steps=200)
    assert np.array_equal(there.max_deviation.values, here.max_deviation.values)
    # threads share the objects: a lambda is fine there
    with ThreadPoolExecutor(1) as pool:
        threaded = ti.ensemble(local, "B", q0, p0, h=hs, n_steps=200, client=pool)
    assert np.array_equal(threaded.max_deviation.values, here.max_deviation.values)
