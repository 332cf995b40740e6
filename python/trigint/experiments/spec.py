"""Experiment specs: TOML files (one per figure) with the values of the paper's §4.

A spec is a plain dict; numbers may be written as expressions in ``pi``, ``sqrt`` and, where
a family of curves is described, ``l`` (``"2*pi/3"``, ``"100 * l**(-1/2)"``). ``[quick]`` holds
the overrides of a reduced run.
"""

from __future__ import annotations

import ast
import copy
import math
import operator
import tomllib
from importlib import resources
from pathlib import Path

FIGURES = ("fig1", "fig2", "fig3", "fig4", "fig5")
KINDS = ("families", "perturbed", "scan", "methods")

_OPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
        ast.Pow: operator.pow, ast.USub: operator.neg, ast.UAdd: operator.pos}
_NAMES = {"pi": math.pi, "e": math.e}
_FUNCS = {"sqrt": math.sqrt, "log": math.log, "exp": math.exp}


def number(value, **variables) -> float:
    """A spec number: a float, or an arithmetic expression in pi, sqrt and the given variables."""
    if isinstance(value, int | float) and not isinstance(value, bool):
        return float(value)
    if not isinstance(value, str):
        raise ValueError(f"spec: expected a number or an expression, got {value!r}")

    def ev(node):
        if isinstance(node, ast.Expression):
            return ev(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, int | float):
            return float(node.value)
        if isinstance(node, ast.Name) and (node.id in _NAMES or node.id in variables):
            return float(variables.get(node.id, _NAMES.get(node.id)))
        if isinstance(node, ast.BinOp) and type(node.op) in _OPS:
            return _OPS[type(node.op)](ev(node.left), ev(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _OPS:
            return _OPS[type(node.op)](ev(node.operand))
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _FUNCS \
                and len(node.args) == 1:
            return _FUNCS[node.func.id](ev(node.args[0]))
        raise ValueError(f"spec: cannot evaluate {value!r}: only numbers, + - * / **, pi, sqrt, log, exp "
                         f"and {sorted(variables) or 'no variables'} are allowed")

    try:
        return ev(ast.parse(value, mode="eval"))
    except SyntaxError:
        raise ValueError(f"spec: {value!r} is not an arithmetic expression") from None


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
    from .schema import SpecError, validate

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
