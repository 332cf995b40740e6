"""The schema of experiment specs: which keys each kind of figure takes, of what type and range.

Every key of a spec is checked here before anything runs: an unknown key is an error that
suggests the closest valid one (``sampels`` → ``samples``), a value of the wrong type or out of
range names its key and says what is allowed. Expressions (``"2*pi/3"``) are allowed exactly for
the keys marked ``Expr`` below, and ``l`` only in a family's ``omega``.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field

from .._figure_kinds import KINDS as FIGURE_KINDS
from .numbers import number


class SpecError(ValueError):
    """A spec that does not follow the schema; the message names the file and the key."""


@dataclass(frozen=True)
class Int:
    low: int | None = None
    high: int | None = None

    def check(self, key: str, value):
        if isinstance(value, bool) or not isinstance(value, int):
            if isinstance(value, float) and value.is_integer():
                value = int(value)
            else:
                raise SpecError(f"{key}: expected an integer{self._range()}, got {value!r}")
        if (self.low is not None and value < self.low) or (self.high is not None and value > self.high):
            raise SpecError(f"{key}: must be an integer{self._range()}, got {value}")
        return value

    def _range(self) -> str:
        if self.low is not None and self.high is not None:
            return f" from {self.low} to {self.high}"
        return f" >= {self.low}" if self.low is not None else ""


@dataclass(frozen=True)
class Float:
    low: float | None = None
    positive: bool = False

    def check(self, key: str, value):
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise SpecError(f"{key}: expected a number{self._range()}, got {value!r}")
        value = float(value)
        if not math.isfinite(value) or (self.positive and value <= 0) or (self.low is not None and value < self.low):
            raise SpecError(f"{key}: must be a finite number{self._range()}, got {value}")
        return value

    def _range(self) -> str:
        return " > 0" if self.positive else (f" >= {self.low:g}" if self.low is not None else "")


@dataclass(frozen=True)
class Expr:
    """A number or an expression in pi, e, sqrt, log, exp (and the given variables)."""

    variables: tuple = ()
    positive: bool = True

    def check(self, key: str, value):
        if isinstance(value, bool) or not isinstance(value, int | float | str):
            raise SpecError(f"{key}: expected a number or an expression such as \"2*pi/3\", got {value!r}")
        try:
            x = number(value, **{v: 1.0 for v in self.variables})
        except (ValueError, ZeroDivisionError, OverflowError) as exc:
            raise SpecError(f"{key}: {str(exc).removeprefix('spec: ')}") from None
        if not math.isfinite(x) or (self.positive and x <= 0):
            raise SpecError(f"{key}: {value!r} = {x} must be finite{' and > 0' if self.positive else ''}")
        return value


@dataclass(frozen=True)
class Str:
    choices: tuple = ()

    def check(self, key: str, value):
        if not isinstance(value, str):
            raise SpecError(f"{key}: expected a string, got {value!r}")
        if self.choices and value not in self.choices:
            raise SpecError(f"{key}: {value!r} is not one of {', '.join(self.choices)}{_suggest(value, self.choices)}")
        return value


@dataclass(frozen=True)
class FileName:
    """A name that becomes the output files' name: one plain name, no folders."""

    def check(self, key: str, value):
        if not isinstance(value, str):
            raise SpecError(f"{key}: expected a name such as \"fig5\", got {value!r}")
        bad = [c for c in ("/", "\\", "\0") if c in value]
        if not value.strip() or value in (".", "..") or bad:
            raise SpecError(f"{key}: {value!r} cannot name output files: it must be one plain name (such as "
                            "\"fig5\" or \"my-figure\"), without '/', '\\' or '..', so that every file stays "
                            "in the output folder")
        return value


@dataclass(frozen=True)
class Method:
    def check(self, key: str, value):
        from .._method_names import resolve_method

        if not isinstance(value, str):
            raise SpecError(f"{key}: expected a method name such as \"B\" or \"imex\", got {value!r}")
        try:
            resolve_method(value)
        except ValueError as exc:
            raise SpecError(f"{key}: {str(exc).removeprefix('method: ')}") from None
        return value


@dataclass(frozen=True)
class List:
    item: object
    min_len: int = 1

    def check(self, key: str, value):
        if not isinstance(value, list):
            raise SpecError(f"{key}: expected a list (e.g. [1, 2]), got {value!r}")
        if len(value) < self.min_len:
            raise SpecError(f"{key}: expected at least {self.min_len} entries, got {len(value)}")
        return [self.item.check(f"{key}[{i}]", v) for i, v in enumerate(value)]


@dataclass(frozen=True)
class Tables:
    """An array of tables ([[panel]]) with its own keys."""

    keys: dict = field(default_factory=dict)
    required: tuple = ()

    def check(self, key: str, value):
        if not isinstance(value, list) or not value or not all(isinstance(v, dict) for v in value):
            raise SpecError(f"{key}: expected one or more [[{key}]] tables")
        return [check_table(f"{key}[{i}]", v, self.keys, self.required) for i, v in enumerate(value)]


ENERGIES = ("oscillatory", "total", "slow", "modified_oscillatory")
POSITIVE = Float(positive=True)
NONNEG = Float(low=0.0)
#: the largest realization set s (seed 0: the paper's initial values)
SEED_MAX = 10**6

COMMON = {
    "id": FileName(), "kind": Str(tuple(FIGURE_KINDS)), "title": Str(),
    "caption": Str(),
    "seed": Int(0, SEED_MAX), "energy": Str(ENERGIES), "samples": Int(2, 10**7),
}
FPU = {"problem": Str(("fpu",)), "m": Int(1, 10**4), "omega": POSITIVE, "method": Method()}

KEYS = {
    "families": {
        **COMMON, "problem": Str(("experiment1", "experiment3", "fpu")), "method": Method(),
        "m": Int(1, 10**4),
        "panel": Tables({"label": Str(), "h_omega": Expr(), "t_end": POSITIVE, "omega": Expr(("l",)),
                         "l": List(Int(1)), "expected_exponent": Float(), "tolerance": POSITIVE},
                        required=("h_omega", "t_end", "omega", "l")),
    },
    "perturbed": {
        **COMMON, **FPU, "h_omega": Expr(), "perturbed": Int(0, 64), "delta_max": NONNEG,
        "panels": List(POSITIVE), "early_ratio_max": POSITIVE, "spread_exponent": Float(),
        "spread_tolerance": POSITIVE, "spread_from": NONNEG, "expected_power": Float(),
        "panel_t_end": List(POSITIVE), "panel_spread_from": List(NONNEG),
        "panel": Tables({"label": Str(), "h_omega": Expr(), "t_end": POSITIVE, "perturbed": Int(0, 64),
                         "expected_power": Float(), "spread_from": NONNEG},
                        required=("h_omega", "t_end")),
    },
    "scan": {
        **COMMON, **FPU, "t_end": POSITIVE, "centres": List(Expr()), "width": POSITIVE, "points": Int(2, 10**6),
        "resonance_order": Int(1, 100), "realizations": Int(0, 64), "realizations_max_N": Int(-1, 100),
        "delta_max": NONNEG,
    },
    "methods": {
        **COMMON, "problem": Str(("experiment3", "fpu")), "m": Int(1, 10**4), "h_omega": Expr(),
        "methods": List(Method()), "omegas": List(POSITIVE), "t_end": POSITIVE, "growth_exponent": Float(),
        "tolerance": POSITIVE, "ratio_max": POSITIVE,
    },
    "wave": {
        **COMMON, "problem": Str(("wave",)), "n": Int(2, 2**16), "rho": NONNEG, "potential": Str(),
        "amplitude": POSITIVE, "method": Method(), "h_min": POSITIVE, "h_max": POSITIVE, "points": Int(2, 10**5),
        "t_end": POSITIVE, "tolerance": POSITIVE, "order": Float(), "order_tolerance": POSITIVE,
        "peak_factor": POSITIVE, "action_bound": POSITIVE, "action_factor": POSITIVE,
    },
    "strata": {
        **COMMON, "problem": Str(("wave",)), "n": Int(2, 2**12), "rho": POSITIVE, "potential": Str(),
        "method": Method(), "epsilons": List(POSITIVE), "h": POSITIVE, "t_end": POSITIVE, "modes": Int(1, 64),
        "scan_epsilon": POSITIVE, "h_min": POSITIVE, "h_max": POSITIVE, "points": Int(2, 10**5),
        "scan_t_end": POSITIVE, "order": Int(2, 5), "holdout_rho": NONNEG, "exponent_tolerance": POSITIVE,
        "floor_factor": POSITIVE, "band_bound": POSITIVE, "break_factor": POSITIVE, "recall_min": POSITIVE,
        "first_factor": POSITIVE, "precision_min": POSITIVE, "ladder_min": POSITIVE,
    },
}
REQUIRED = {
    "families": ("kind", "problem", "panel"),
    "perturbed": ("kind", "problem", "omega"),
    "scan": ("kind", "problem", "omega", "t_end", "centres"),
    "methods": ("kind", "problem", "methods", "omegas", "t_end"),
    "wave": ("kind", "problem", "n", "h_min", "h_max", "t_end"),
    "strata": ("kind", "problem", "n", "rho", "epsilons", "h", "t_end", "scan_epsilon", "h_min", "h_max", "points",
               "scan_t_end"),
}
TOP_LEVEL = ("figure", "panel", "claims", "quick")


def _suggest(word: str, valid) -> str:
    close = difflib.get_close_matches(word, list(valid), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def check_table(where: str, table: dict, keys: dict, required=()) -> dict:
    """Checks every key of `table` against `keys`; returns the table with values normalized."""
    out = {}
    for key, value in table.items():
        if key not in keys:
            raise SpecError(f"{where}: unknown key {key!r}{_suggest(key, keys)}; valid keys: {', '.join(sorted(keys))}")
        out[key] = keys[key].check(key if where == "figure" else f"{where}.{key}", value)
    missing = [k for k in required if k not in out]
    if missing:
        raise SpecError(f"{where}: missing {', '.join(repr(k) for k in missing)}")
    return out


def validate(raw: dict) -> None:
    """Checks a parsed spec file (its [figure], [[panel]], [claims] and [quick] tables)."""
    for key in raw:
        if key not in TOP_LEVEL:
            raise SpecError(f"unknown table [{key}]{_suggest(key, TOP_LEVEL)}; valid: {', '.join(TOP_LEVEL)}")
    fig = raw.get("figure")
    if not isinstance(fig, dict):
        raise SpecError("needs a [figure] table")
    kind = fig.get("kind")
    if not isinstance(kind, str) or kind not in KEYS:
        raise SpecError(f"figure.kind: {kind!r} is not one of {', '.join(KEYS)}"
                        f"{_suggest(str(kind), KEYS) if isinstance(kind, str) else ''}")
    keys = KEYS[kind]
    merged = dict(fig)
    for table in ("panel", "claims"):
        if table in raw:
            if table == "claims" and not isinstance(raw[table], dict):
                raise SpecError("claims: expected a [claims] table")
            merged.update(raw[table] if table == "claims" else {"panel": raw[table]})
    check_table("figure", merged, keys, REQUIRED[kind])
    quick = raw.get("quick", {})
    if not isinstance(quick, dict):
        raise SpecError("quick: expected a [quick] table")
    check_table("quick", quick, keys)
    if kind == "perturbed" and "panel" not in merged and ("panels" not in merged or "h_omega" not in merged):
        raise SpecError("figure: a 'perturbed' figure needs [[panel]] tables, or 'panels' and 'h_omega'")
    if kind == "methods" and merged["problem"] != "experiment3" and "h_omega" not in merged:
        raise SpecError("figure: 'h_omega' is needed unless problem = \"experiment3\" (whose step it knows)")
    panels = len(merged.get("panel") or merged.get("panels") or [])
    for key in ("panel_t_end", "panel_spread_from"):
        if key in quick and len(quick[key]) != panels:
            raise SpecError(f"quick.{key}: has {len(quick[key])} entries for {panels} panels")
