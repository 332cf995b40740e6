"""A standing guard: every public entry point, fed property-based garbage in one argument at a
time (wrong types, NaN/inf, huge and negative numbers, wrong shapes, complex, empty), either
returns a result or raises ValueError/TypeError whose message names the argument. Never another
exception, an abort (each case would take the test process down) or a hang (an alarm per case).
"""

from __future__ import annotations

import contextlib
import io
import signal
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import trigint as ti
from trigint import cli, experiments
from trigint import resonance as res

PROB = ti.problems.fpu()
Q0, P0 = ti.problems.fpu_initial()
H = 2 * np.pi / 3 / 50
SECONDS_PER_CASE = 60  # a guard against hangs, with room for a loaded machine

numbers = st.one_of(
    st.integers(-10**6, 10**6),
    st.sampled_from([10**16, 2**63, 10**30, -(10**30), 0, -1]),
    st.floats(-1e6, 1e6),
    st.sampled_from([np.nan, np.inf, -np.inf, 1e300, -1e300, 5e-324, 1e20, -0.0]),
    st.complex_numbers(max_magnitude=1e3, allow_nan=False),
)
arrays = st.one_of(
    st.just([]), st.just(np.zeros((0,))), st.just(np.zeros((2, 3, 4))),
    st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=0, max_size=8),
    st.lists(st.integers(-10**6, 10**6), min_size=1, max_size=8),
    st.lists(numbers, min_size=1, max_size=7),
    st.just(np.full(6, 1 + 2j)),
)
garbage = st.one_of(
    st.none(), st.booleans(), numbers, arrays, st.text(max_size=8), st.just("B"), st.just(object()),
    st.dictionaries(st.text(max_size=3), st.integers(), max_size=2), st.just(lambda *a: None),
)


class Timeout(Exception):
    pass


@contextlib.contextmanager
def alarm(seconds: int):
    def fire(*_):
        raise Timeout(f"no result after {seconds} s")

    old = signal.signal(signal.SIGALRM, fire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def outcome(call, names: tuple[str, ...]):
    """Runs call(); only a result or a ValueError/TypeError that names one of `names` may come out."""
    with warnings.catch_warnings(), alarm(SECONDS_PER_CASE):
        warnings.simplefilter("ignore")
        try:
            call()
        except (ValueError, TypeError) as exc:
            message = str(exc)
            assert any(name in message for name in names), f"message does not name {names}: {message!r}"


def one_bad_argument(base: dict, data, keys=None):
    """`base` with one argument replaced by garbage; returns (kwargs, the argument's name)."""
    key = data.draw(st.sampled_from(sorted(keys or base)), label="argument")
    kwargs = dict(base)
    kwargs[key] = data.draw(garbage, label=key)
    return kwargs, key


SETTINGS = settings(max_examples=100, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)


@SETTINGS
@given(st.data())
def test_integrate(data):
    base = dict(problem=PROB, method="B", q0=Q0, p0=P0, h=H, n_steps=5, save_every=1, form="two-step",
                track_energies=True, progress=False)
    kwargs, key = one_bad_argument(base, data)
    if key == "n_steps" and data.draw(st.booleans()):  # the other way to give the length
        kwargs["t_end"] = kwargs.pop("n_steps")
        key = "t_end"
    outcome(lambda: ti.integrate(**kwargs), (key, "n_steps") if key == "t_end" else (key,))


@SETTINGS
@given(st.data())
def test_ensemble(data):
    base = dict(problem=PROB, method="B", q0=np.array([Q0, Q0]), p0=np.array([P0, P0]), h=H, n_steps=5,
                save_every=None, track_energies=True, threads=None, chunk_size=None, progress=False)
    kwargs, key = one_bad_argument(base, data)
    outcome(lambda: ti.ensemble(**kwargs), (key, "trajectory"))


@SETTINGS
@given(st.data())
def test_scan(data):
    base = dict(problem=PROB, method="B", q0=Q0, p0=P0, h_omega=[2.0, 2.1], t_end=0.5, energy="oscillatory",
                omega_ref=None, progress=False)
    kwargs, key = one_bad_argument(base, data, keys=["method", "q0", "p0", "h_omega", "t_end", "energy", "omega_ref"])
    outcome(lambda: ti.scan(**kwargs), (key, "h:", "trajectory"))


@SETTINGS
@given(st.data())
def test_perturb_and_energies(data):
    kwargs, key = one_bad_argument(dict(q0=Q0, p0=P0, deltas=[0.0, 1e-9], index=0, component="q"), data)
    outcome(lambda: ti.perturb(**kwargs), (key,))
    kwargs, key = one_bad_argument(dict(problem=PROB, q=Q0, p=P0, method="B", h=H), data)
    outcome(lambda: ti.energies(**kwargs), (key,))


@SETTINGS
@given(st.data())
def test_problem_and_potentials(data):
    kwargs, key = one_bad_argument(dict(omega=[0.0, 50.0], potential=ti.PolynomialPotential([1.0], [[4, 0]]),
                                        blocks=None), data)
    outcome(lambda: ti.OscillatoryProblem(**kwargs), (key,))
    kwargs, key = one_bad_argument(dict(stiffness=[[200.0, -100.0], [-100.0, 200.0]],
                                        potential=ti.PolynomialPotential([1.0], [[4, 0]]), slow_tolerance=1e-10,
                                        equal_tolerance=1e-10, path="auto", krylov_tolerance=1e-12), data)
    outcome(lambda: ti.OscillatoryProblem(**kwargs), (key,))
    outcome(lambda: ti.FPUPotential(data.draw(garbage)), ("m",))
    kwargs, key = one_bad_argument(dict(coefficients=[1.0, 2.0], exponents=[[4, 0], [1, 1]]), data)
    outcome(lambda: ti.PolynomialPotential(**kwargs), (key,))
    kwargs, key = one_bad_argument(dict(expr="a*x**4 + cos(y)", coordinates=["x", "y"], params={"a": 1.0}), data)
    outcome(lambda: ti.ExpressionPotential(**kwargs), (key,))
    chain = ti.ChainPotential(4)
    kwargs, key = one_bad_argument(dict(v="y**4/4", variable="y", pairs=[(0, 1), (1, 2)], params=None), data)
    outcome(lambda: chain.add(**kwargs), (key,))
    outcome(lambda: ti.ChainPotential(data.draw(garbage)), ("n",))
    kwargs, key = one_bad_argument(dict(value=lambda q: 0.0, gradient=lambda q: 0 * q, dim=None,
                                        vectorized=False), data)
    outcome(lambda: ti.PythonPotential(**kwargs), (key,))


@SETTINGS
@given(st.data())
def test_methods(data):
    outcome(lambda: ti.Trigonometric(data.draw(garbage)), ("filter",))
    outcome(lambda: ti.Trigonometric(psi=data.draw(garbage)), ("psi",))
    outcome(lambda: ti.AlphaMethod(data.draw(garbage)), ("alpha",))
    kwargs, key = one_bad_argument(dict(omega_tilde=lambda x: x, chi=None, psi=None), data)
    outcome(lambda: ti.ModifiedTrigonometric(**kwargs), (key,))
    # a filter that returns garbage fails when it is first evaluated, naming the filter
    value = data.draw(garbage)

    def garbage_filter():
        method = ti.Trigonometric(psi=lambda x: value if np.any(x != 0) else 1.0, phi=np.cos)
        ti.integrate(PROB, method, Q0, P0, h=H, n_steps=3)

    outcome(garbage_filter, ("psi",))


@SETTINGS
@given(st.data())
def test_resonance(data):
    kwargs, key = one_bad_argument(dict(h=0.04, omega=[50.0, 70.0], method="B", N_max=4, delta=0.25), data)
    outcome(lambda: res.analyze(**kwargs), (key,))
    kwargs, key = one_bad_argument(dict(omega=[50.0, 70.0], h_omega_range=(1.0, 2.0), order=4), data)
    outcome(lambda: res.resonant_step_sizes(**kwargs), (key,))
    kwargs, key = one_bad_argument(dict(h=0.04, omega=np.array([50.0, 70.0]), radius=4), data)
    outcome(lambda: res.nonresonance_violations(**kwargs), (key,))
    kwargs, key = one_bad_argument(dict(omega=np.array([50.0, 100.0]), radius=4), data)
    outcome(lambda: res.resonance_module(**kwargs), (key,))
    kwargs, key = one_bad_argument(dict(h=0.04, omega=[50.0, 70.0], N=2, delta=0.25), data)
    outcome(lambda: res.modified_frequencies(**kwargs), (key,))


@settings(max_examples=40, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)
@given(data=st.data())
def test_cli(tmp_path_factory, data):
    """The command line: exit status 0, 1 (a claim failed) or 2 (a user error, one line), never a traceback."""
    out = tmp_path_factory.mktemp("cli")
    text = st.one_of(st.text(max_size=6), st.sampled_from(["nan", "inf", "-1", "0", "1e400", "3.5", "", "-"]))
    argv = data.draw(st.sampled_from([
        ["resonance", "--h", data.draw(text), "--omega", "50"],
        ["resonance", "--h", "0.04", "--omega", data.draw(text), "--N-max", data.draw(text)],
        ["resonance", "--h", "0.04", "--omega", "50", "--method", data.draw(text), "--delta", data.draw(text)],
        ["fpu", "--m", data.draw(text), "--t-end", "0.5", "--out", str(out)],
        ["fpu", "--omega", data.draw(text), "--h-omega", data.draw(text), "--t-end", "0.5", "--out", str(out)],
        ["fpu", "--method", data.draw(text), "--t-end", "0.5", "--out", str(out)],
        ["reproduce", data.draw(text), "--out", str(out), "--quick"],
        ["run", data.draw(text), "--out", str(out)],
    ]))
    stderr = io.StringIO()
    with contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(io.StringIO()), alarm(SECONDS_PER_CASE):
        try:
            code = cli.main(argv)
        except SystemExit as exc:  # argparse's own usage errors
            code = exc.code
    assert code in (0, 1, 2), argv
    assert "Traceback" not in stderr.getvalue(), argv
    if code == 2:
        assert stderr.getvalue().strip(), argv


SPEC_KEYS = ["kind", "problem", "methods", "omegas", "t_end", "samples", "energy", "tolerance", "ratio_max",
             "growth_exponent", "seed", "sampels", "h_omega", "m"]


@settings(max_examples=80, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)
@given(data=st.data())
def test_toml_specs(tmp_path_factory, data):
    """A spec with one key set to garbage either loads or is refused naming that key."""
    import tomllib

    raw = tomllib.loads((experiments.spec.resources.files("trigint.experiments") / "specs" / "fig5.toml")
                        .read_text(encoding="utf-8"))
    key = data.draw(st.sampled_from(SPEC_KEYS))
    toml_values = st.one_of(st.integers(-10**9, 10**9), st.floats(allow_nan=True), st.text(max_size=6),
                            st.booleans(), st.lists(st.integers(-5, 5), max_size=3),
                            st.lists(st.floats(-1e3, 1e3), max_size=3), st.lists(st.text(max_size=3), max_size=3))
    raw["figure"][key] = data.draw(toml_values)
    path = tmp_path_factory.mktemp("spec") / "s.toml"
    path.write_text(_toml(raw), encoding="utf-8")
    outcome(lambda: experiments.load(str(path), quick=data.draw(st.booleans())), (key, "not valid TOML"))


def _toml(raw: dict) -> str:
    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, float):
            return "nan" if v != v else ("inf" if v == float("inf") else "-inf" if v == -float("inf") else repr(v))
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)

    lines = []
    for table, body in raw.items():
        lines.append(f"[{table}]")
        lines += [f"{k} = {value(v)}" for k, v in body.items()]
    return "\n".join(lines) + "\n"


def test_the_guard_itself_fails_on_bad_outcomes():
    with pytest.raises(AssertionError, match="does not name"):
        outcome(lambda: ti.integrate(PROB, "B", Q0, P0, h=H, n_steps=0), ("h",))
    with pytest.raises(KeyError):
        outcome(lambda: {}["x"], ("x",))
    with pytest.raises(Timeout):
        with alarm(1):
            while True:
                pass
