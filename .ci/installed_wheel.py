"""Checks an installed trigint (from the wheel), run from outside the checkout: the package is
the installed one, its specs are shipped, the CLI works, and a quick figure reproduces."""

import pathlib
import subprocess
import sys
import tempfile

import trigint as ti
from trigint import experiments

here = pathlib.Path(ti.__file__).resolve().parent
assert "site-packages" in str(here), f"not the installed package: {here}"
for fig in experiments.FIGURES:
    assert (here / "experiments" / "specs" / f"{fig}.toml").is_file(), f"spec {fig} not shipped"
bindir = pathlib.Path(sys.executable).parent
version = subprocess.run([str(bindir / "trigint"), "--version"], capture_output=True, text=True, check=True)
assert version.stdout.strip() == f"trigint {ti.__version__}", version.stdout
with tempfile.TemporaryDirectory() as out:
    run = subprocess.run([str(bindir / "trigint"), "reproduce", "fig1", "--quick", "--out", out],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-2000:]
    assert (pathlib.Path(out) / "fig1.png").stat().st_size > 1000
    assert "claims pass" in (pathlib.Path(out) / "report.md").read_text()
# The license travels with the package, and the metadata names it, its authors and its links.
from importlib import metadata  # noqa: E402

dist = metadata.distribution("trigint")
licenses = [f for f in dist.files or [] if f.name == "LICENSE"]
assert licenses and "MIT License" in licenses[0].read_text(), "LICENSE is not in the wheel"
assert dist.metadata["License-Expression"] == "MIT", dist.metadata["License-Expression"]
assert dist.metadata["Author"] == "The trigint developers" or "The trigint developers" in str(
    dist.metadata.get_all("Author-email")), dist.metadata["Author"]
assert any("10.1007/s10543-014-0527-1" in u for u in dist.metadata.get_all("Project-URL") or [])
prob = ti.problems.fpu()
q0, p0 = ti.problems.fpu_initial()
sol = ti.integrate(prob, "B", q0, p0, h=0.0418879, n_steps=1000)
assert sol.status == "completed" and sol.max_deviation["oscillatory"] < 0.05
print(f"installed wheel OK: {here}")
