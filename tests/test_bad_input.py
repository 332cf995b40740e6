"""Bad input gets a ValueError or TypeError naming the argument; faults never lose work.

Each case here reproduced a reported failure first (a silent truncation, a wrong default, an
exception of another type, a run that went on for minutes)."""

from __future__ import annotations

import subprocess
import sys
import warnings
from importlib import resources

import numpy as np
import pytest

import trigint as ti
from conftest import with_default_sigint
from trigint import experiments
from trigint.resonance import resonant_step_sizes

PROB = ti.problems.fpu()
Q0, P0 = ti.problems.fpu_initial()
H = 2 * np.pi / 3 / 50


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"n_steps": 0}, ValueError, "n_steps: must be >= 1"),
        ({"n_steps": 100.0}, TypeError, "n_steps: expected an integer"),
        ({"t_end": "10"}, TypeError, "t_end: expected a number"),
        ({"t_end": True}, TypeError, "t_end: expected a number"),
        ({"n_steps": 10, "track_energies": "no"}, TypeError, "track_energies: expected True or False"),
        ({"n_steps": 10, "form": 3}, ValueError, "form: must be one of"),
        ({"n_steps": 10, "save_every": 2.5}, TypeError, "save_every: expected an integer"),
    ],
)
def test_integrate_arguments(kwargs, error, match):
    with pytest.raises(error, match=match):
        ti.integrate(PROB, "B", Q0, P0, h=H, **kwargs)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"n_steps": 10, "threads": True}, ValueError, "threads: must be an integer"),
        ({"t_end": "10"}, TypeError, "t_end: expected a number"),
        ({"n_steps": 10, "track_energies": "no"}, TypeError, "track_energies: expected True or False"),
    ],
)
def test_ensemble_arguments(kwargs, error, match):
    with pytest.raises(error, match=match):
        ti.ensemble(PROB, "B", Q0, P0, h=H, progress=False, **kwargs)


def test_complex_input_is_refused_not_truncated():
    with pytest.raises(TypeError, match="q0: complex values are not allowed"):
        ti.integrate(PROB, "B", Q0 + 1e-3j, P0, h=H, n_steps=10)
    with pytest.raises(TypeError, match="p0: complex values are not allowed"):
        ti.ensemble(PROB, "B", Q0, P0 * (1 + 0j), h=H, n_steps=10, progress=False)
    with pytest.raises(TypeError, match="h: expected a positive number"):
        ti.ensemble(PROB, "B", Q0, P0, h=H + 0j, n_steps=10, progress=False)


def test_energies_accepts_method_names():
    named = ti.energies(PROB, Q0, P0, method="B", h=H)
    obj = ti.energies(PROB, Q0, P0, method=ti.Trigonometric("B"), h=H)
    assert float(named["modified_oscillatory"]) == float(obj["modified_oscillatory"])


@pytest.mark.parametrize(
    ("omega_tilde", "match"),
    [
        (lambda x: -x, "must be increasing"),
        (lambda x: x + 0.5, "must map 0 to 0"),
        (lambda x: np.sin(6 * x), "must be increasing"),
    ],
)
def test_modified_frequency_map_must_increase_from_zero(omega_tilde, match):
    with pytest.raises(ValueError, match=match):
        ti.ModifiedTrigonometric(omega_tilde=omega_tilde)


def test_resonant_step_sizes_refuses_huge_orders_before_enumerating(monkeypatch):
    """Refused from the count alone: the enumeration is never started (it would take hours)."""
    from trigint.resonance import steps

    def never(*args):
        raise AssertionError("enumerated before refusing")

    monkeypatch.setattr(steps, "half_ball", never)
    with pytest.raises(ValueError, match="order: 100000 .* at most"):
        resonant_step_sizes([50.0, 70.0], (1.0, 2.0), order=10**5)
    # one frequency: 10⁶ vectors k pass, but with about 3·10⁵ values of r each
    with pytest.raises(ValueError, match=r"order: 1000000 over h\*omega_ref in \[0, 3\] means up to 4.77e\+11 pairs "
                                         r"\(k, r\) to visit; at most 1e\+06 .*Choose order <= 1446"):
        resonant_step_sizes([50.0], (0.0, 3.0), order=10**6)
    monkeypatch.undo()
    # the largest order offered is accepted, and lists every 2πr/k in the range
    found = resonant_step_sizes([50.0], (2.0, 2.2), order=1446)
    assert found and all(2.0 <= s.h_omega <= 2.2 for s in found)
    assert any(s.k == (3,) and s.r == 1 for s in found)


def test_resonant_step_sizes_and_scan_measure_h_alike():
    """Both take the largest frequency as ω_ref, so markers land on the scanned step sizes."""
    omega = [50.0, 50.0 * np.sqrt(2)]
    steps = resonant_step_sizes(omega, (1.0, 3.0), order=3)
    prob = ti.OscillatoryProblem(omega, ti.PolynomialPotential([0.0], [[0, 0]]))
    s = ti.scan(prob, "B", [0.1, 0.1], [0.0, 0.0], h_omega=[steps[0].h_omega], t_end=1.0, progress=False)
    h = float(s.h.values[0])
    assert h * np.dot(steps[0].k, omega) == pytest.approx(2 * np.pi * steps[0].r, rel=1e-12)


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "trigint.cli", *args], capture_output=True, text=True, timeout=120)


def test_cli_version_and_user_errors():
    out = run_cli("--version")
    assert out.returncode == 0 and out.stdout.startswith("trigint ")
    bad = run_cli("fpu", "--out", "/dev/null/x", "--t-end", "1")
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert bad.stderr.strip().startswith("trigint: error: --out: cannot create the folder")
    assert "Solution(" not in bad.stdout  # refused before integrating
    missing = run_cli("run", "/nonexistent/spec.toml", "--out", "/tmp")
    assert missing.returncode == 2 and "Traceback" not in missing.stderr


def test_cli_help_describes_every_option():
    from trigint.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name, p in sub.choices.items():
        for action in p._actions:
            if action.dest != "help":
                assert action.help, f"trigint {name}: option {action.dest} has no help"


CTRL_C_SCRIPT = """
import os, signal, threading, warnings
import numpy as np, trigint as ti
warnings.simplefilter("ignore")
fpu = ti.problems.fpu(); q0, p0 = ti.problems.fpu_initial()
names = [f"x{i}" for i in range(6)]
potentials = {
    "native": fpu.potential,
    "expression": ti.ExpressionPotential("x0**4/4 + x3**2 * x1**2", names),
    "chain": ti.ChainPotential(6).add("y**4/4", "y", pairs=[(0, 1), (1, 2)]),
    "python": ti.PythonPotential(lambda q: float(q @ q) ** 2, lambda q: 4 * float(q @ q) * q),
}
for kind, U in potentials.items():
    prob = ti.OscillatoryProblem(fpu.omega, U)
    for form in ("two-step", "one-step"):
        timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
        timer.start()
        sol = ti.integrate(prob, "B", q0, p0, h=0.04, n_steps=10**9, save_every=10**4, form=form,
                           progress=False)
        timer.join()
        finite = bool(np.all(np.isfinite(sol.q)))
        print(kind, form, sol.status, sol.n_steps, sol.t.size, int(sol.steps[-1]), finite, flush=True)
"""


def test_ctrl_c_keeps_the_samples_for_every_potential_kind_and_form():
    """KeyboardInterrupt never escapes integrate(): a Python potential's callback sees it first,
    and the run must still return its samples with status 'interrupted'."""
    out = subprocess.run([sys.executable, "-c", with_default_sigint(CTRL_C_SCRIPT)], capture_output=True,
                         text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    rows = [line.split() for line in out.stdout.splitlines()]
    assert len(rows) == 8
    for kind, form, status, steps, samples, last, finite in rows:
        assert status == "interrupted", (kind, form)
        assert int(steps) > 10 and int(last) == int(steps) and finite == "True", (kind, form)
        assert int(samples) == int(steps) // 10**4 + 1 + (int(steps) % 10**4 != 0), (kind, form)


def test_ctrl_c_reaches_the_children_even_when_the_test_run_ignores_it():
    """`make test &` in a script runs pytest with SIGINT ignored, and every child inherits that:
    Python then installs no KeyboardInterrupt handler. The Ctrl-C tests' children restore it."""
    import signal

    code = ("import os, signal, time\n"
            "try:\n"
            "    os.kill(os.getpid(), signal.SIGINT)\n"
            "    time.sleep(0.5)\n"
            "    print('ignored')\n"
            "except KeyboardInterrupt:\n"
            "    print('interrupted')\n")
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        plain = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
        restored = subprocess.run([sys.executable, "-c", with_default_sigint(code)], capture_output=True, text=True,
                                  timeout=120)
    finally:
        signal.signal(signal.SIGINT, old)
    assert plain.stdout.strip() == "ignored"  # the situation the helper is for
    assert restored.stdout.strip() == "interrupted"


def test_false_causes_are_not_reported():
    """A huge ω is refused for what it is, not as 'a multiple of π'."""
    with pytest.raises(ValueError, match=r"h\*omega\[3\] = 1e\+13 is too large: above 1e\+12"):
        ti.integrate(ti.problems.fpu(omega=1e13), "B", Q0, P0, h=1.0, n_steps=10)
    with pytest.raises(ValueError, match=r"h\*omega\[3\] = 1e\+10 is so large that .* below 1e-10") as err:
        ti.integrate(ti.problems.fpu(omega=1e12), "B", Q0, P0, h=0.01, n_steps=10)
    assert "multiple" not in str(err.value)
    with pytest.raises(ValueError, match=r"is 1\*pi; .* vanishes there"):
        ti.integrate(PROB, "B", Q0, P0, h=np.pi / 50, n_steps=10)
    with pytest.raises(ValueError, match="omega: omega.* too large: the energies need omega"):
        ti.problems.fpu(omega=1e300)
    # NaN potential value at a finite initial state: the potential is named, not the state
    U = ti.ExpressionPotential("sqrt(x - 2) + y**2", ["x", "y"])
    with pytest.warns(RuntimeWarning, match="potential is not finite"):
        sol = ti.integrate(ti.OscillatoryProblem([0.0, 10.0], U), "B", [1.0, 0.0], [0.0, 0.0], h=0.1, n_steps=10)
    assert sol.status == "blow-up" and "potential is not finite at the initial state" in sol.message


def test_ensemble_refuses_samples_that_cannot_fit_before_allocating(monkeypatch):
    import importlib

    module = importlib.import_module("trigint.ensemble")  # the module, not the function of its name

    def never(*args, **kwargs):
        raise AssertionError("work started before the refusal")

    for name in ("run_chunk", "_assemble", "_open_store"):  # nothing is run, allocated or written
        monkeypatch.setattr(module, name, never)
    with pytest.raises(ValueError, match="save_every: 100 trajectories .* GiB"):
        ti.ensemble(PROB, "B", [Q0] * 100, [P0] * 100, h=H, n_steps=10**7, save_every=1, progress=False)


def shipped_spec(name: str) -> str:
    return (resources.files("trigint.experiments") / "specs" / f"{name}.toml").read_text(encoding="utf-8")


FIG5 = shipped_spec("fig5")


@pytest.mark.parametrize(
    ("old", "new", "match"),
    [
        ("samples = 2000", "sampels = 2000", "unknown key 'sampels' .did you mean 'samples'"),
        ("t_end = 2000.0", "t_ned = 2000.0", "unknown key 't_ned' .did you mean 't_end'"),
        ("omegas = [200.0, 100.0, 50.0]", "omegas = 200.0", "omegas: expected a list"),
        ("samples = 2000", "samples = 2.7", "samples: expected an integer"),
        ("samples = 2000", 'samples = "many"', "samples: expected an integer"),
        ("t_end = 2000.0", "t_end = -1.0", "t_end: must be a finite number > 0"),
        ("t_end = 2000.0", 't_end = "2*pi"', "t_end: expected a number"),  # no expressions here
        ('methods = ["A", "B"]', 'methods = ["A", "Q"]', r"methods\[1\]: unknown name 'Q'"),
        ('energy = "oscillatory"', 'energy = "oscilatory"', "did you mean 'oscillatory'"),
        ("[quick]", "[quik]", r"unknown table \[quik\] .did you mean 'quick'"),
        ("t_end = 200.0\n", "t_edn = 200.0\n", "quick: unknown key 't_edn'"),
        ('problem = "experiment3"', 'problem = "fpu"', "'h_omega' is needed"),
    ],
)
def test_spec_schema(tmp_path, old, new, match):
    assert old in FIG5
    path = tmp_path / "mine.toml"
    path.write_text(FIG5.replace(old, new, 1) if old != "t_end = 200.0\n" else FIG5.replace(old, new))
    with pytest.raises(ValueError, match=match):
        experiments.load(str(path), quick=True)
    out = run_cli("run", str(path), "--quick", "--out", str(tmp_path))
    assert out.returncode == 2 and "Traceback" not in out.stderr and len(out.stderr.strip().splitlines()) == 1


def test_spec_schema_checks_panels_and_expressions(tmp_path):
    fig1 = shipped_spec("fig1")
    for old, new, match in [
        ('h_omega = "2*pi/3"', 'h_omega = "2*pi/"', r"panel\[0\].h_omega: .* not an arithmetic expression"),
        ('h_omega = "2*pi/3"', 'h_omega = "2*l"', r"panel\[0\].h_omega: cannot evaluate"),
        ("l = [1, 2, 3, 4, 5, 6, 7]", "l = [1, 2.5]", r"panel\[0\].l\[1\]: expected an integer"),
        ("tolerance = 0.15", "tolerence = 0.15", "did you mean 'tolerance'"),
    ]:
        path = tmp_path / "f.toml"
        path.write_text(fig1.replace(old, new, 1))
        with pytest.raises(ValueError, match=match):
            experiments.load(str(path))


def test_a_step_size_in_a_0d_array_is_its_number_and_an_array_says_its_shape():
    """``h=np.array(0.03)`` (a step size read from a file or sliced from an array) is that step
    size, with the bits of ``h=0.03``; an array of several says its shape."""
    a = ti.integrate(PROB, "B", Q0, P0, h=np.array(H), n_steps=20)
    b = ti.integrate(PROB, "B", Q0, P0, h=H, n_steps=20)
    assert a.h == H and np.array_equal(a.q, b.q)
    with pytest.raises(TypeError, match=r"^h: expected a positive float, got an array of shape \(2,\)$"):
        ti.integrate(PROB, "B", Q0, P0, h=np.array([H, H]), n_steps=20)
    with pytest.raises(TypeError, match=r"got an array of shape \(\)$"):
        ti.integrate(PROB, "B", Q0, P0, h=np.array(True), n_steps=20)


def test_a_channel_that_is_not_there_names_those_that_are():
    sol = ti.integrate(PROB, "B", Q0, P0, h=H, n_steps=5)
    with pytest.raises(KeyError, match=r"no channel 'Oscillatory' \(did you mean 'oscillatory'\?\); the channels "
                                       r"are 'total', 'oscillatory', 'slow', "):
        sol.max_deviation["Oscillatory"]
    assert sol.max_deviation.get("H", -1.0) == -1.0 and "H" not in sol.max_deviation
    wave = ti.problems.wave(16, rho=0.5)
    x, = wave.grid
    sol = ti.integrate(wave, "B", 0.01 * np.cos(x), 0 * x, h=0.02, n_steps=5)
    with pytest.raises(KeyError, match=r"'momentum_1', 'oscillatory_1' … 'oscillatory_9'\"$"):
        sol.initial_energies["mode_3"]


@pytest.mark.parametrize(("value", "gradient", "match"), [
    (lambda q: 0.5 * float(q @ q), lambda q: list(q),
     r"^the gradient must return a 1-d float array of 2 values, got list$"),
    (lambda q: 0.5 * float(q @ q), lambda q: np.arange(len(q)),
     r"^the gradient must return a 1-d float array of 2 values, got ndarray of dtype int64 and shape \(2,\)$"),
    (lambda q: [0.5 * float(q @ q)], lambda q: q, r"^the value function must return one float, got list$"),
])
def test_a_python_potential_returning_the_wrong_type_hears_what_it_returned(value, gradient, match):
    prob = ti.OscillatoryProblem([0.0, 10.0], ti.PythonPotential(value, gradient, dim=2))
    with pytest.raises(TypeError, match=match):
        ti.integrate(prob, "B", [0.1, 0.0], [0.0, 0.1], h=0.01, n_steps=3)


def test_an_ensemble_at_one_resonant_step_size_warns_as_integrate_does():
    """Perturbed runs at one step size hear integrate()'s warning at it; a scan across the
    resonance does not (it crosses it on purpose) and reports its blow-ups instead."""
    Q, P = ti.perturb(Q0, P0, np.linspace(-1e-9, 1e-9, 3))
    resonant = 3.14159 / 50
    message = r"numerical resonance: h\*omega\[3\] = 3.14159 is 2.65e-06 from 1\*pi"
    with pytest.warns(RuntimeWarning, match=message) as w:
        ti.ensemble(PROB, "B", Q, P, h=resonant, n_steps=50)
    assert w[0].filename == __file__
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ti.ensemble(PROB, "B", Q, P, h=H, n_steps=50)
        ti.ensemble(PROB, "B", Q0, P0, h=[H, resonant], n_steps=50)


@pytest.mark.parametrize(("q0", "p0", "error", "message"), [
    (1.0, P0, ValueError,
     r"^q0: expected an array of 6 floats \(one value per coordinate\), got a single number 1\.0$"),
    (np.float64(2.5), P0, ValueError, r"got a single number 2\.5$"),
    (None, P0, TypeError, r"^q0: expected an array of 6 floats \(one value per coordinate\), got None$"),
    (Q0, None, TypeError, r"^p0: expected an array of 6 floats \(one value per coordinate\), got None$"),
])
def test_a_number_or_none_for_a_state_is_named_as_such(q0, p0, error, message):
    """Not "expected shape (6,), got (1,)": what was given, as given."""
    with pytest.raises(error, match=message):
        ti.integrate(PROB, "B", q0, p0, h=H, n_steps=2)
    with pytest.raises(error, match=message):
        ti.ensemble(PROB, "B", q0, p0, h=H, n_steps=2, progress=False)
    one = ti.OscillatoryProblem([50.0], ti.PolynomialPotential([0.0], [[0]]))
    assert ti.integrate(one, "B", 0.1, 0.0, h=0.01, n_steps=2).q[0].tolist() == [0.1]  # one coordinate: a number


def test_the_inverse_frequency_map_states_its_range_without_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=r"^xi_tilde: h\*omega_tilde must be in \[0, pi\) for the IMEX method "
                                             r"\(alpha = 1/4\), which reaches pi only as h\*omega -> inf; got "
                                             r"3\.141592653589793$"):
            ti.IMEX().h_omega_from_modified(np.pi)
        with pytest.raises(ValueError, match=r"must be in \[0, pi\] for the alpha-method with alpha = 0\.1, which "
                                             r"reaches pi at the step-size limit h\*omega = 2\.58198889747; got 3\.2$"):
            ti.AlphaMethod(0.1).h_omega_from_modified(3.2)
        with pytest.raises(ValueError, match=r"must be in \[0, 2 arcsin\(1/\(2 sqrt\(alpha\)\)\) = 1\.0471975512\) "
                                             r"for the alpha-method with alpha = 1, .*; got 1\.2$"):
            ti.AlphaMethod(1.0).h_omega_from_modified(1.2)
        with pytest.raises(ValueError, match=r"got -0\.5$"):
            ti.IMEX().h_omega_from_modified(-0.5)
        xi = np.array([0.0, 0.5, 2.0, 100.0])
        np.testing.assert_allclose(ti.IMEX().h_omega_from_modified(ti.IMEX().modified_h_omega(xi)), xi, rtol=1e-12)


def test_a_filter_that_is_not_finite_is_reported_in_plain_numbers():
    method = ti.Trigonometric(psi=lambda x: np.where(x > 1.0, np.nan, 1.0))
    with pytest.raises(ValueError, match=r"^psi: not finite at xi = 2\.5 \(value nan\)$"):
        method.coefficients(0.05, np.array([10.0, 50.0]))
    inverse = ti.ModifiedTrigonometric(lambda x: x, omega_tilde_inverse=lambda y: 1.0 / (y - 1.0))
    with pytest.raises(ValueError, match=r"^omega_tilde_inverse: not finite at xi_tilde = 1\.0 \(value inf\)$"):
        with np.errstate(divide="ignore"):
            inverse.h_omega_from_modified([0.5, 1.0])


def test_the_solution_documents_every_energy_it_holds():
    sol = ti.integrate(PROB, "B", Q0, P0, h=H, n_steps=4)
    doc = " ".join(ti.Solution.__doc__.split())
    for name in sol.energies.data_vars:
        assert f"``{name}``" in doc or (name.startswith("oscillatory_") and "``oscillatory_1``" in doc), name
    assert "kinetic" in ti.Solution.deviation.__doc__
    np.testing.assert_allclose(sol.deviation("kinetic"), sol.energies["kinetic"] - sol.initial_energies["kinetic"])


@pytest.fixture(scope="module")
def plot_runs():
    """A run, an ensemble with samples and one without, and a scan, for the plotting helpers."""
    sol = ti.integrate(PROB, "B", Q0, P0, h=H, t_end=5.0, save_every=10)
    ds = ti.ensemble(PROB, "B", Q0, P0, h=[H, 0.8 * H], t_end=5.0, save_every=10, progress=False)
    bare = ti.ensemble(PROB, "B", Q0, P0, h=[H, 0.8 * H], t_end=5.0, progress=False)
    scan = ti.scan(PROB, "B", Q0, P0, h_omega=[1.0, 2.0], t_end=5.0, progress=False)
    return sol, ds, bare, scan


def test_plot_deviation_needs_one_label_per_solution(plot_runs):
    from trigint.plotting import _pyplot, plot_deviation

    sol = plot_runs[0]
    with pytest.raises(ValueError, match=r"^labels: 1 label\(s\) for 2 solutions; give one per solution$"):
        plot_deviation([sol, sol], labels=["a"])
    with pytest.raises(TypeError, match=r"^labels: expected a list of strings, one per solution$"):
        plot_deviation(sol, labels=[1])
    ax = plot_deviation(sol, labels="one run")
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["one run"]
    _pyplot().close(ax.figure)


def test_plot_deviation_draws_an_ensembles_samples_one_curve_per_trajectory(plot_runs):
    from trigint.plotting import _pyplot, plot_deviation

    sol, ds = plot_runs[0], plot_runs[1]
    ax = plot_deviation(ds, labels=["h", "0.8 h"])
    first, second = ax.lines[:2]
    np.testing.assert_array_equal(first.get_xdata(), sol.t)  # trajectory 0 is sol
    np.testing.assert_allclose(first.get_ydata(), sol.deviation("oscillatory"), rtol=0, atol=1e-15)
    assert np.all(np.isfinite(second.get_ydata())) and second.get_xdata()[-1] == pytest.approx(5.0, abs=H)
    _pyplot().close(ax.figure)
    with pytest.raises(KeyError, match=r"energy: unknown name 'oscilatory'; valid: total, oscillatory, "):
        plot_deviation(ds, "oscilatory")


def test_what_the_plotting_helpers_cannot_draw_they_say_what_they_can(plot_runs):
    from trigint.plotting import figure, plot_deviation

    sol, ds, bare, scan = plot_runs
    accepted = (r"expected a Solution \(from ti\.integrate\), a list of them, or the Dataset of ti\.ensemble run "
                r"with save_every")
    with pytest.raises(TypeError, match=f"^solutions: {accepted}; this Dataset has no energies over time"):
        plot_deviation(bare)
    with pytest.raises(TypeError, match=f"^solutions: {accepted}, got an xarray DataArray"):
        plot_deviation(scan)
    with pytest.raises(TypeError, match=f"^solutions: {accepted}; item 1 is int$"):
        plot_deviation([sol, 3])
    with pytest.raises(TypeError, match=r"^ds: expected an experiment's Dataset, from trigint\.experiments\.run, "
                                        r"got Solution; a run's energies are drawn by plot_deviation$"):
        figure(sol)
    with pytest.raises(TypeError, match=r"got a Dataset without a figure kind"):
        figure(ds)


def test_a_scan_through_an_exact_multiple_of_pi_names_the_step_size_and_the_form_that_runs_it():
    """At hω = kπ the two-step form is undefined: the scan says which step size and that the
    one-step form, which scan() takes, is defined there; in that form the scan runs."""
    prob = ti.problems.fpu()
    q0, p0 = ti.problems.fpu_initial()
    h_omega = np.pi * np.linspace(0.5, 1.5, 11)
    with pytest.raises(ValueError, match=r"trajectory 5 \(h = .*is 1\*pi.*form='one-step' in integrate\(\), "
                                         r"ensemble\(\) or scan\(\)"):
        ti.scan(prob, "B", q0, p0, h_omega=h_omega, t_end=1.0)
    scan = ti.scan(prob, "B", q0, p0, h_omega=h_omega, t_end=1.0, form="one-step")
    assert np.all(np.isfinite(scan.values))
    # the trajectory at kπ is the one integrate() runs in the one-step form, bit for bit
    with pytest.warns(RuntimeWarning, match="numerical resonance"):
        alone = ti.integrate(prob, "B", q0, p0, h=float(scan.h[5]), t_end=1.0, form="one-step")
    assert scan.values[5] == alone.max_deviation["oscillatory"]


def test_a_scans_blow_up_warning_points_at_the_users_line():
    """scan() calls ensemble(): the warning names the caller's file, not the package's."""
    prob = ti.problems.fpu()
    q0, p0 = ti.problems.fpu_initial()
    with pytest.warns(RuntimeWarning, match="blew up") as caught:
        ti.scan(prob, "B", q0, p0, h_omega=[1.0, 3.138190955], t_end=300.0)
    assert [w.filename for w in caught if "blew up" in str(w.message)] == [__file__]
