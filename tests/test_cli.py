"""The command line as a user meets it: help with defaults, a spec to start from, warnings at a
numerical resonance, pipes that close early, and logs that are not a terminal."""

from __future__ import annotations

import io
import subprocess
import sys
import tomllib

import numpy as np
import pytest

import trigint as ti
from trigint import _progress, experiments
from trigint.cli import build_parser


def run_cli(*args, **kwargs):
    return subprocess.run([sys.executable, "-m", "trigint.cli", *args], capture_output=True, text=True,
                          timeout=300, **kwargs)


def test_every_command_has_a_description_and_shows_its_defaults():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name, p in sub.choices.items():
        assert p.description, f"trigint {name} has no description"
        text = " ".join(p.format_help().split())
        for action in p._actions:
            if action.default not in (None, "==SUPPRESS==") and action.option_strings:
                assert f"(default: {action.default})" in text, (name, action.dest)
    assert "(default: 3)" in run_cli("fpu", "--help").stdout


def test_debug_goes_before_or_after_the_command():
    parser = build_parser()
    assert parser.parse_args(["fpu", "--debug"]).debug and parser.parse_args(["--debug", "fpu"]).debug
    assert not parser.parse_args(["resonance", "--h", "0.04", "--omega", "50"]).debug
    assert "strata" in next(a for a in parser._actions if a.dest == "command").choices["run"].format_help()


def test_a_closed_pipe_ends_the_output_quietly():
    """`trigint resonance ... --json | head`: the reader leaves before the JSON is written."""
    proc = subprocess.Popen([sys.executable, "-m", "trigint.cli", "resonance", "--h", "0.0418879", "--omega", "50",
                             "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # long before the child has imported trigint
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=300) == 141  # 128 + SIGPIPE, as the shell reports a writer cut off
    assert err == ""


def test_fpu_at_a_numerical_resonance_warns(tmp_path):
    near = run_cli("fpu", "--h-omega", "3.14159265", "--t-end", "30", "--out", str(tmp_path))
    assert near.returncode == 0, near.stderr
    assert "trigint: warning: numerical resonance: h*omega[3] = 3.14159265 is 3.59e-09 from 1*pi" in near.stderr
    assert "(3.2)" in near.stderr and "Traceback" not in near.stderr
    usual = run_cli("fpu", "--t-end", "30", "--out", str(tmp_path))  # hω = 2π/3
    assert usual.returncode == 0 and "warning" not in usual.stderr


def test_spec_prints_a_figure_spec_that_run_accepts(tmp_path):
    printed = run_cli("spec", "fig5")
    assert printed.returncode == 0
    spec = tomllib.loads(printed.stdout)
    assert spec["figure"]["id"] == "fig5"
    mine = tmp_path / "my.toml"
    mine.write_text(printed.stdout.replace('id = "fig5"', 'id = "mine"'))
    out = run_cli("run", str(mine), "--quick", "--out", str(tmp_path / "out"))
    assert out.returncode == 0, out.stderr
    assert (tmp_path / "out" / "mine.png").exists() and (tmp_path / "out" / "mine.nc").exists()
    assert experiments.load(str(mine))["figure"]["id"] == "mine"
    bad = run_cli("spec", "fig9")
    assert bad.returncode == 2 and "valid: fig1, fig2, fig3, fig4, fig5" in bad.stderr


def test_progress_in_a_log_is_lines_without_carriage_returns():
    log = io.StringIO()
    bar = _progress.LineProgress(1000, "step", "integrate", stream=log)
    for _ in range(100):
        bar.update(10)
    bar.close()
    lines = log.getvalue().splitlines()
    assert "\r" not in log.getvalue()
    assert lines[0] == "integrate: 10% (100 of 1,000 steps)" and lines[-1] == "integrate: 100% (1,000 of 1,000 steps)"
    assert len(lines) == 10
    assert not _progress.interactive(io.StringIO())


LOG_SCRIPT = """
import numpy as np, trigint as ti
prob = ti.OscillatoryProblem([50.0], ti.PythonPotential(lambda q: 0.0, lambda q: np.zeros(1)))
ti.integrate(prob, "B", [0.1], [0.0], h=0.01, n_steps=200_000)                  # default: no bar in a log
ti.integrate(prob, "B", [0.1], [0.0], h=0.01, n_steps=200_000, progress=True)   # asked for: lines
"""


def test_integrate_writes_no_bar_into_a_log_by_default():
    out = subprocess.run([sys.executable, "-c", LOG_SCRIPT], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "\r" not in out.stderr
    lines = out.stderr.splitlines()
    assert lines and all(line.startswith("integrate: ") for line in lines), out.stderr
    assert lines[-1] == "integrate: 100% (200,000 of 200,000 steps)"
    assert sum("100%" in line for line in lines) == 1  # only the run that asked for it reports


def test_ensemble_in_a_log_has_no_bar():
    prob = ti.problems.fpu()
    q0, p0 = ti.problems.fpu_initial()
    err = io.StringIO()
    import contextlib

    with contextlib.redirect_stderr(err):
        ds = ti.ensemble(prob, "B", q0, p0, h=0.04 * np.array([1.0, 1.01]), n_steps=1000, chunk_size=1,
                         progress=True)
    assert ds.status.values.tolist() == ["completed", "completed"]
    assert err.getvalue().splitlines()[-1] == "ensemble: 100% (2 of 2 chunks)" and "\r" not in err.getvalue()


def test_resonance_takes_the_step_size_as_h_omega_as_fpu_does():
    by_h = run_cli("resonance", "--h", str(2 * np.pi / 3 / 50), "--omega", "0", "50", "--json")
    by_h_omega = run_cli("resonance", "--h-omega", str(2 * np.pi / 3), "--omega", "0", "50", "--json")
    assert by_h.returncode == by_h_omega.returncode == 0, by_h_omega.stderr
    assert by_h.stdout == by_h_omega.stdout and '"kappa"' in by_h.stdout
    both = run_cli("resonance", "--h", "0.04", "--h-omega", "2", "--omega", "50")
    assert both.returncode == 2 and "not allowed with argument" in both.stderr
    slow = run_cli("resonance", "--h-omega", "2", "--omega", "0")
    assert slow.returncode != 0 and "--h-omega needs a frequency > 0" in slow.stderr


def test_the_theory_page_shows_what_trigint_resonance_prints():
    import shlex
    from pathlib import Path

    page = (Path(__file__).resolve().parents[1] / "docs" / "theory.md").read_text(encoding="utf-8")
    block = page.split("```text\n", 1)[1].split("```", 1)[0]
    command, *shown = block.splitlines()
    out = run_cli(*shlex.split(command.removeprefix("$ "))[1:])
    assert out.returncode == 0 and out.stdout.splitlines() == shown


def test_bad_numbers_are_reported_under_the_flag_that_was_typed(tmp_path, capsys):
    """Each refused value names its flag and what it allows, before any work: no Python
    exception names and no value the user did not type (h = (h*omega)/omega)."""
    from trigint.cli import main

    out = ["--out", str(tmp_path)]
    cases = {
        ("fpu", "--h-omega", "0"): "--h-omega: must be finite and > 0, got 0",
        ("fpu", "--h-omega", "nan"): "--h-omega: must be finite and > 0, got nan",
        ("fpu", "--h-omega", "-1"): "--h-omega: must be finite and > 0, got -1",
        ("fpu", "--omega", "0"): "--omega: must be finite and > 0, got 0",
        ("fpu", "--t-end", "nan"): "--t-end: must be finite and > 0, got nan",
        ("fpu", "--m", "0"): "--m: the number of stiff springs must be a whole number >= 1, got 0",
        ("fpu", "--h-omega", "1e300", "--omega", "1e-300"): "--h-omega, --omega: the step size h = 1e+300/1e-300 "
                                                            "overflows in double precision",
        ("lyapunov", "--exponents", "0"): "--exponents: how many exponents, a whole number from 1 to 4m = 12, got 0",
        ("lyapunov", "--m", "2", "--exponents", "9"): "--exponents: how many exponents, a whole number from 1 to "
                                                      "4m = 8, got 9",
        ("reproduce", "fig5", "--seed", "-1"): "--seed: 0 (the paper's initial values) or a realization set s "
                                               "from 1 to 1,000,000, got -1",
    }
    for argv, message in cases.items():
        assert main([*argv, *out]) == 2, argv
        err = capsys.readouterr().err
        assert err == f"trigint: error: {message}\n", (argv, err)
    # too many steps for a double: the library's count of allowed steps, not an OverflowError
    assert main(["fpu", "--t-end", "1e308", *out]) == 2
    err = capsys.readouterr().err
    assert "at most 2**53" in err and "OverflowError" not in err
    assert not list(tmp_path.iterdir())  # nothing was run or written


def test_reproduce_refuses_a_negative_seed():
    with pytest.raises(ValueError, match=r"^seed: 0 \(the paper's initial values\) or a realization set s from 1 "
                                         r"to 1,000,000, got -1$"):
        experiments.reproduce(["fig5"], "unused", quick=True, seed=-1)
    with pytest.raises(TypeError, match="seed: expected an integer, got 1.5"):
        experiments.reproduce(["fig5"], "unused", quick=True, seed=1.5)
