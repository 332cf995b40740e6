"""The paper's experiments in their --quick form: every claim measured and passing, files written."""

import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

from trigint import experiments
from trigint.experiments.numbers import number
from trigint.experiments.runners import perturbations


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduction")
    claims = experiments.reproduce(experiments.FIGURES, out, quick=True, log=lambda *_: None)
    return out, claims


def test_every_quick_claim_passes(quick):
    out, claims = quick
    failed = [f"{c.figure}: {c.claim} = {c.measured}" for c in claims if not c.passed]
    assert not failed, failed
    assert {c.figure for c in claims} == set(experiments.FIGURES)
    for fig in experiments.FIGURES:
        for ext in ("nc", "png", "pdf"):
            assert (out / f"{fig}.{ext}").stat().st_size > 1000
    report = (out / "report.md").read_text()
    claimed = [c for c in claims if not c.measurement]
    measured = [c for c in claims if c.measurement]
    assert f"{len(claimed)} of {len(claimed)} claims pass." in report
    # the strata's withdrawn hypothesis stays in view as measurements, one per scan
    assert [c.figure for c in measured] == ["strata", "strata"] and all(np.isfinite(c.measured) for c in measured)
    assert f"{len(measured)} rows are measurements (MEASURED)" in report and report.count("| MEASURED |") == 2
    # run times are stated with the machine they were taken on
    from trigint._config import config

    assert f"Machine: {config()['cpu']}, " in report


def test_figure1_exponents(quick):
    out, claims = quick
    exps = [c.measured for c in claims if c.figure == "fig1" and "exponent" in c.claim]
    assert exps[0] == pytest.approx(2.0, abs=0.15)
    assert exps[1] == pytest.approx(3.0, abs=0.15)
    ds = xr.open_dataset(out / "fig1.nc", engine="scipy")
    assert ds.sizes["curve"] == 7 and ds.omega.values[0, 0] == pytest.approx(100.0)
    assert ds.omega.values[1, 6] == pytest.approx(100 * 7 ** (-1 / 3))


def test_figure5_growth_and_ratio(quick):
    _, claims = quick
    fig5 = {c.claim.split(":")[0]: c.measured for c in claims if c.figure == "fig5"}
    assert fig5["(B)"] == pytest.approx(1.0, abs=0.15)
    assert fig5["max |deviation| of (A) / that of (B), worst ω"] < 0.01


def test_figure2_spread_is_a_random_walk(quick):
    _, claims = quick
    spread = [c.measured for c in claims if c.figure == "fig2" and "spread of the perturbed" in c.claim]
    assert spread and spread[0] == pytest.approx(0.5, abs=0.2)


def test_user_spec_runs_from_a_copied_toml(tmp_path):
    text = (experiments.spec.resources.files("trigint.experiments") / "specs" / "fig5.toml").read_text()
    text = text.replace('omegas = [200.0, 100.0, 50.0]', 'omegas = [160.0, 80.0]')
    path = tmp_path / "mine.toml"
    path.write_text(text)
    out = subprocess.run([sys.executable, "-m", "trigint.cli", "run", str(path), "--quick", "--out", str(tmp_path)],
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    ds = xr.open_dataset(tmp_path / "fig5.nc", engine="scipy")
    assert ds.omega.values.tolist() == [160.0, 80.0]


def test_spec_expressions_and_errors():
    assert number("2*pi/3") == pytest.approx(2 * np.pi / 3)
    assert number("100 * l**(-1/2)", l=4) == pytest.approx(50.0)
    assert number("sqrt(12)") == pytest.approx(np.sqrt(12))
    with pytest.raises(ValueError, match="cannot evaluate"):
        number("__import__('os')")
    with pytest.raises(ValueError, match="neither a figure"):
        experiments.load("fig9")


def test_perturbations_are_distinct_doubles():
    d = perturbations(9, 7e-16)
    assert len(set((1.0 + d).tolist())) == 9 and np.all(np.abs(d) <= 7e-16) and np.all(d != 0)
    with pytest.raises(ValueError, match="only 9 doubles"):
        perturbations(10, 7e-16)


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_quick_claims_pass_for_other_realization_sets(seed, tmp_path, quick):
    """The random-walk figures on four more sets of initial values (seed 0, the paper's, is the
    run above): no claim may pass by the luck of one realization. The first set goes through
    `reproduce` (its `seed`); the others are only computed and measured, without their files
    and plots (a third of the time)."""
    if seed == 1:
        claims = experiments.reproduce(["fig2", "fig3", "fig4"], tmp_path, quick=True, seed=seed, log=lambda *_: None)
        assert (tmp_path / "fig3.png").exists()
    else:
        claims = []
        for name in ("fig2", "fig3", "fig4"):
            spec = experiments.load(name, quick=True)
            spec["figure"]["seed"] = seed
            claims += experiments.measure(experiments.run(spec))
    failed = [f"{c.figure}: {c.claim} = {c.measured}" for c in claims if not c.passed]
    assert not failed, failed
    # the realization sets really differ: Figure 2's spread exponent is not that of seed 0
    spread = [c.measured for c in claims if c.figure == "fig2" and "spread of" in c.claim]
    spread0 = [c.measured for c in quick[1] if c.figure == "fig2" and "spread of" in c.claim]
    assert spread and spread != spread0
