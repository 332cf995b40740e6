"""The paper's numerical experiments (§4) as data: one TOML spec per figure, a runner that
turns a spec into an ``xarray.Dataset``, and the paper's claims measured on it.

>>> from trigint import experiments
>>> spec = experiments.load("fig5", quick=True)
>>> ds = experiments.run(spec)
>>> sorted(ds.method.values.tolist())
['A', 'B']
"""

from __future__ import annotations

import time
from pathlib import Path

from .claims import Claim, measure
from .runners import run
from .spec import FIGURES, load

__all__ = ["FIGURES", "Claim", "load", "measure", "report", "reproduce", "run", "run_spec"]


def run_spec(spec: dict, out: Path, *, log=print) -> tuple[list[Claim], float]:
    """Runs one spec; writes DIR/<id>.nc, .png and .pdf; returns the measured claims and the seconds."""
    from ..plotting import figure, save

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    fid = spec["figure"]["id"]
    log(f"{fid}: {spec['figure'].get('title', '')}{' (quick)' if spec.get('quick') else ''} ...")
    start = time.perf_counter()
    ds = run(spec)
    seconds = time.perf_counter() - start
    ds.to_netcdf(out / f"{fid}.nc", engine="scipy")
    written = save(figure(ds), out / fid)
    claims = measure(ds)
    for c in claims:
        log(f"  {c.verdict}  {c.claim}: {c.measured:.4g} (expected {c.expected}, {c.tolerance})")
    log(f"  {seconds:.1f} s; wrote {out / (fid + '.nc')}, " + ", ".join(str(p) for p in written))
    return claims, seconds


def report(claims: list[Claim], timings: dict, path: Path, quick: bool) -> str:
    """The report of measured claims as Markdown (written to `path`)."""
    lines = [
        "# Reproduction of Cohen, Gauckler, Hairer, Lubich (BIT 2015), §4",
        "",
        f"Run: {'quick (reduced)' if quick else 'full resolution'}; "
        + ", ".join(f"{k} {v:.1f} s" for k, v in timings.items()) + f"; total {sum(timings.values()):.1f} s.",
        "",
        "| figure | claim | measured | expected | tolerance | verdict |",
        "|---|---|---:|---|---|---|",
    ]
    cell = lambda text: str(text).replace("|", "\\|")  # noqa: E731
    for c in claims:
        lines.append(f"| {c.figure} | {cell(c.claim)} | {c.measured:.4g} | {cell(c.expected)} | {cell(c.tolerance)} "
                     f"| {c.verdict} |")
    passed = sum(c.passed for c in claims)
    lines += ["", f"{passed} of {len(claims)} claims pass."]
    text = "\n".join(lines) + "\n"
    Path(path).write_text(text, encoding="utf-8")
    return text


def reproduce(figures=FIGURES, out="reproduction", *, quick: bool = False, log=print) -> list[Claim]:
    """Runs the given figures into `out`, with a report of every claim (DIR/report.md)."""
    out = Path(out)
    claims, timings = [], {}
    for name in figures:
        spec = load(name, quick=quick)
        c, seconds = run_spec(spec, out, log=log)
        claims += c
        timings[spec["figure"]["id"]] = seconds
    text = report(claims, timings, out / "report.md", quick)
    log("")
    log(text)
    return claims
