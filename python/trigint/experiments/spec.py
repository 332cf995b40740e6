"""Experiment specs: TOML files (one per figure) with the values of the paper's §4.

A spec is a plain dict; numbers may be written as expressions in ``pi``, ``sqrt`` and, where
a family of curves is described, ``l`` (``"2*pi/3"``, ``"100 * l**(-1/2)"``). ``[quick]`` holds
the overrides of a reduced run.
"""

from __future__ import annotations

import copy
import tomllib
from importlib import resources
from pathlib import Path

from .schema import SpecError, validate

FIGURES = ("fig1", "fig2", "fig3", "fig4", "fig5", "wave1", "strata")

def load(name_or_path, quick: bool = False) -> dict:
    """The spec of a paper figure ("fig1" … "fig5") or of a TOML file, with `[quick]` applied.

    ``trigint spec fig3 > my.toml`` writes a figure's spec to start one's own from.

    Parameters
    ----------
    name_or_path : str or path
        A figure's name, or the path of a TOML spec.
    quick : bool
        Apply the spec's ``[quick]`` table (a reduced run).

    Returns
    -------
    dict
        The validated spec.

    Examples
    --------
    >>> from trigint import experiments
    >>> spec = experiments.load("fig5", quick=True)
    >>> spec["figure"]["kind"], spec["figure"]["t_end"]
    ('methods', 200.0)
    """
    text, origin = _read(name_or_path)
    try:
        spec = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{origin}: not valid TOML: {exc}") from None
    try:
        validate(spec)
    except SpecError as exc:
        raise ValueError(f"{origin}: {exc}") from None
    fig = spec["figure"]
    fig.setdefault("id", Path(str(origin)).stem)
    # Other top-level tables ([[panel]], [claims]) belong to the figure.
    for key in [k for k in spec if k not in ("figure", "quick")]:
        value = spec.pop(key)
        fig.update(value) if key == "claims" else fig.__setitem__(key, value)
    if quick:
        spec = apply_quick(spec)
    spec["origin"] = str(origin)
    spec["quick"] = bool(quick)
    return spec


def apply_quick(spec: dict) -> dict:
    out = copy.deepcopy(spec)
    out["figure"].update(out.pop("quick", {}))
    return out


def _read(name_or_path) -> tuple[str, str]:
    if isinstance(name_or_path, str) and name_or_path in FIGURES:
        path = resources.files("trigint.experiments") / "specs" / f"{name_or_path}.toml"
        return path.read_text(encoding="utf-8"), f"{name_or_path}.toml"
    path = Path(name_or_path)
    if not path.exists():
        raise ValueError(f"spec: {name_or_path!r} is neither a figure ({', '.join(FIGURES)}) nor a file")
    return path.read_text(encoding="utf-8"), str(path)
