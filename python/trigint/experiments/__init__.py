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

__all__ = ["FIGURES", "Claim", "load", "measure", "outputs", "report", "reproduce", "run", "run_spec"]


def run_spec(spec: dict, out: Path, *, log=print) -> tuple[list[Claim], float]:
    """Runs one spec; writes DIR/<id>.nc, .png and .pdf; returns the measured claims and the seconds.

    Parameters
    ----------
    spec : dict
        A spec from :func:`load`.
    out : path
        The output folder DIR.
    log : callable
        Receives the progress and the claims as lines (default ``print``).

    Returns
    -------
    claims : list of Claim
    seconds : float

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from trigint import experiments
    >>> claims, seconds = experiments.run_spec(experiments.load("fig5", quick=True), Path(tempfile.mkdtemp()),
    ...                                        log=lambda *a: None)
    >>> all(c.passed for c in claims)
    True
    """
    _announce(spec, log)
    outputs(spec, out)  # before the run: no file may land outside `out`
    ds, seconds = _compute(spec)
    return _finish(spec, ds, seconds, out, log), seconds


#: the files a spec writes into the output folder
SUFFIXES = (".nc", ".png", ".pdf")


def outputs(spec: dict, out) -> list[Path]:
    """The files a spec writes (DIR/<id>.nc, .png, .pdf), each checked to resolve inside the
    output folder `out` (an id such as "../x", or a link in `out` pointing elsewhere, is refused).

    Parameters
    ----------
    spec : dict
        A loaded spec (:func:`load`); its ``figure.id`` names the files.
    out : str or path
        The output folder.

    Returns
    -------
    list of Path
        The three files, resolved.

    Examples
    --------
    >>> from pathlib import Path
    >>> [p.name for p in outputs({"figure": {"id": "fig5"}}, Path("results"))]
    ['fig5.nc', 'fig5.png', 'fig5.pdf']
    >>> try:
    ...     outputs({"figure": {"id": "../fig5"}}, Path("results"))
    ... except ValueError as exc:
    ...     print(exc)
    figure.id: '../fig5' would write ../fig5.nc outside the output folder results; give the figure a plain name
    """
    fid = spec["figure"]["id"]
    folder = Path(out).resolve()
    paths = []
    for suffix in SUFFIXES:
        relative = Path(f"{fid}{suffix}")
        target = (folder / relative).resolve()
        if target.parent != folder or relative.is_absolute():
            raise ValueError(f"figure.id: {fid!r} would write {relative} outside the output folder {out}; give the "
                             "figure a plain name")
        paths.append(target)
    return paths


def _announce(spec: dict, log) -> None:
    log(f"{spec['figure']['id']}: {spec['figure'].get('title', '')}{' (quick)' if spec.get('quick') else ''} ...")


def _compute(spec: dict):
    start = time.perf_counter()
    ds = run(spec)
    return ds, time.perf_counter() - start


def _finish(spec: dict, ds, seconds: float, out: Path, log) -> list[Claim]:
    """Saves the data and the figure (in the calling thread: matplotlib is not thread-safe) and
    measures the claims."""
    from ..plotting import figure, save

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    fid = spec["figure"]["id"]
    outputs(spec, out)  # checked again: the folder exists now, links in it are resolved
    ds.to_netcdf(out / f"{fid}.nc", engine="scipy")
    written = save(figure(ds), out / fid)
    claims = measure(ds)
    log(f"{fid}:")
    for c in claims:
        log(f"  {c.verdict}  {c.claim}: {c.measured:.4g} (expected {c.expected}, {c.tolerance})")
    log(f"  {seconds:.1f} s; wrote {out / (fid + '.nc')}, " + ", ".join(str(p) for p in written))
    return claims


def report(claims: list[Claim], timings: dict, path: Path, quick: bool, wall: float | None = None) -> str:
    """The report of measured claims as Markdown (written to `path`).

    Parameters
    ----------
    claims : list of Claim
        The measured claims.
    timings : dict of str → float
        Seconds per figure.
    path : path
        Where the report is written.
    quick : bool
        Whether the runs were the reduced ones.
    wall : float, optional
        The wall time of the whole run, when figures ran side by side.

    Returns
    -------
    str
        The Markdown text.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from trigint import experiments
    >>> claims = experiments.measure(experiments.run(experiments.load("fig5", quick=True)))
    >>> text = experiments.report(claims, {"fig5": 0.1}, Path(tempfile.mkdtemp()) / "report.md", quick=True)
    >>> text.splitlines()[0]
    '# Reproduction of Cohen, Gauckler, Hairer, Lubich (BIT 2015), §4'
    """
    lines = [
        "# Reproduction of Cohen, Gauckler, Hairer, Lubich (BIT 2015), §4",
        "",
        f"Run: {'quick (reduced)' if quick else 'full resolution'}; "
        + ", ".join(f"{k} {v:.1f} s" for k, v in timings.items())
        + (f" (two at a time); wall time {wall:.1f} s." if wall is not None
           else f"; total {sum(timings.values()):.1f} s."),
        "",
        f"Machine: {_machine()}.",
        "",
        "| figure | claim | measured | expected | tolerance | verdict |",
        "|---|---|---:|---|---|---|",
    ]
    cell = lambda text: str(text).replace("|", "\\|")  # noqa: E731
    for c in claims:
        lines.append(f"| {c.figure} | {cell(c.claim)} | {c.measured:.4g} | {cell(c.expected)} | {cell(c.tolerance)} "
                     f"| {c.verdict} |")
    claimed = [c for c in claims if not c.measurement]
    lines += ["", f"{sum(c.passed for c in claimed)} of {len(claimed)} claims pass."]
    if len(claimed) < len(claims):
        lines += ["", f"{len(claims) - len(claimed)} rows are measurements (MEASURED): numbers stated, not "
                  "claimed; each row says why."]
    text = "\n".join(lines) + "\n"
    Path(path).write_text(text, encoding="utf-8")
    return text


def _machine() -> str:
    """The CPU the timings were taken on, its cores and the widest kernel copy it runs."""
    import os

    from .._config import config

    cfg = config()
    copy = cfg["isa_cap"] or cfg["copies"][0]
    return f"{cfg['cpu']}, {os.cpu_count()} logical cores, kernel copies up to {copy}, {cfg['platform']}"


def reproduce(figures=FIGURES, out="reproduction", *, quick: bool = False, seed: int = 0,
              log=print) -> list[Claim]:
    """Runs the given figures into `out`, with a report of every claim (DIR/report.md).

    Two figures are computed at a time: Figure 4's bottom panel is one sequential run on one
    core, and the other figures fill the second core meanwhile. `seed` ≥ 1 runs every figure on
    another realization set of its initial values (see ``runners.seeded``).

    Parameters
    ----------
    figures : sequence of str
        Figure names, ``"fig1"`` … ``"fig5"``.
    out : path
        The output folder.
    quick : bool
        The reduced runs.
    seed : int
        0: the paper's initial values; s ≥ 1: another realization set.
    log : callable
        Receives the progress, the claims and the report as lines (default ``print``).

    Returns
    -------
    list of Claim

    Examples
    --------
    >>> import tempfile
    >>> from trigint import experiments
    >>> claims = experiments.reproduce(["fig5"], tempfile.mkdtemp(), quick=True, log=lambda *a: None)
    >>> all(c.passed for c in claims)
    True
    """
    from concurrent.futures import ThreadPoolExecutor

    from trigint._check import integer

    from .schema import SEED_MAX

    if not 0 <= integer(seed, "seed") <= SEED_MAX:
        raise ValueError(f"seed: 0 (the paper's initial values) or a realization set s from 1 to {SEED_MAX:,}, "
                         f"got {int(seed)}")
    out = Path(out)
    claims, timings = [], {}
    specs = [load(name, quick=quick) for name in figures]
    for spec in specs:
        if seed:
            spec["figure"]["seed"] = int(seed)
        outputs(spec, out)  # before any run
    start = time.perf_counter()
    with ThreadPoolExecutor(max_workers=2) as pool:
        futures = []
        for spec in specs:
            _announce(spec, log)
            futures.append(pool.submit(_compute, spec))
        for spec, future in zip(specs, futures, strict=True):
            ds, seconds = future.result()
            claims += _finish(spec, ds, seconds, out, log)
            timings[spec["figure"]["id"]] = seconds
    wall = time.perf_counter() - start
    text = report(claims, timings, out / "report.md", quick, wall)
    log("")
    log(text)
    return claims
