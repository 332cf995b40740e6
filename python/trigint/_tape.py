"""SymPy expressions → tapes (the straight-line programs the core compiles).

A tape is ``{"n": inputs, "ops": [(name, a, b?) …], "output": index}``: each operation refers to
earlier ones by index. Nothing is expanded: the expression's structure is kept, shared
subexpressions are emitted once (SymPy's own structural sharing plus a memo), and the core
hash-conses, simplifies exactly and differentiates the tape in reverse mode.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

#: the functions an expression may use (SymPy class name → tape operation)
FUNCTIONS = {
    "exp": "exp", "log": "log", "sin": "sin", "cos": "cos", "tan": "tan",
    "sinh": "sinh", "cosh": "cosh", "tanh": "tanh", "Abs": "abs",
}
SUPPORTED = ("+ - * /, integer and rational powers, sqrt, exp, log, sin, cos, tan, sinh, cosh, "
             "tanh, abs, numbers")


def sympy():
    try:
        import sympy as sp
    except ImportError:  # pragma: no cover - sympy is a dependency
        raise ImportError("expressions need SymPy: pip install sympy") from None
    return sp


def parse(expr, names: Sequence[str], what: str = "expr"):
    """`expr` as a SymPy expression; strings are parsed as data (:func:`trigint._expr.parse_string`),
    with `names` as plain symbols."""
    sp = sympy()
    if isinstance(expr, str):  # data, never evaluated as Python (see trigint._expr)
        from ._expr import parse_string

        return parse_string(expr, names, what)
    if isinstance(expr, int | float) and not isinstance(expr, bool):
        return sp.Float(expr) if isinstance(expr, float) else sp.Integer(expr)
    if not isinstance(expr, sp.Basic):
        raise TypeError(f"{what}: expected a SymPy expression or a string, got {type(expr).__name__}")
    return expr


def symbols(coordinates, what: str = "coordinates") -> list:
    """Coordinate symbols from SymPy symbols or names (a sequence, or one name for one)."""
    sp = sympy()
    if isinstance(coordinates, str | sp.Symbol):
        coordinates = [coordinates]
    try:
        items = list(coordinates)
    except TypeError:
        raise TypeError(f"{what}: expected a sequence of SymPy symbols or names") from None
    if not items:
        raise ValueError(f"{what}: give at least one symbol")
    out = []
    for s in items:
        if isinstance(s, str):
            if not s.isidentifier():
                raise ValueError(f"{what}: {s!r} is not a valid symbol name")
            s = sp.Symbol(s)
        if not isinstance(s, sp.Symbol):
            raise TypeError(f"{what}: expected SymPy symbols or names, got {s!r} ({type(s).__name__})")
        out.append(s)
    names = [str(s) for s in out]
    if len(set(names)) != len(names):
        dup = sorted({x for x in names if names.count(x) > 1})
        raise ValueError(f"{what}: repeated symbols {dup}")
    return out


def parameters(params: Mapping | None) -> dict[str, float]:
    """Named numeric parameters: finite real numbers."""
    if params is None:
        return {}
    if not isinstance(params, Mapping):
        raise TypeError(f"params: expected a dict of name -> number, got {type(params).__name__}")
    out = {}
    for k, v in params.items():
        name = str(k)
        if not isinstance(k, str) or not k.isidentifier():
            raise ValueError(f"params: {k!r} is not a valid parameter name (a Python identifier)")
        if isinstance(v, complex) or (hasattr(v, "is_real") and v.is_real is False):
            raise ValueError(f"params: {name} = {v!r} is complex; parameters must be real numbers")
        try:
            x = float(v)
        except OverflowError:
            raise ValueError(f"params: {name} is too large for a double (at most about 1.8e308 in magnitude)") from None
        except (TypeError, ValueError):
            raise TypeError(f"params: {name} = {v!r} is not a number") from None
        if not math.isfinite(x):
            raise ValueError(f"params: {name} = {x} is not finite")
        out[name] = x
    return out


class Compiler:
    """Emits a tape for expressions in `coordinates` with numeric `params` (by name)."""

    def __init__(self, coordinates: Sequence, params: Mapping[str, float], what: str = "expr",
                 inputs: str = "coordinates"):
        #: the arguments named in error messages
        self.what, self.inputs_name = what, inputs
        self.inputs = {s: i for i, s in enumerate(coordinates)}
        self.params = dict(params)
        self.ops: list[tuple] = []
        self.op_index: dict[tuple, int] = {}
        #: tape index of each compiled SymPy subexpression
        self.memo: dict = {}
        self.allowed = ", ".join(str(s) for s in coordinates)

    def emit(self, op: tuple) -> int:
        if op not in self.op_index:
            self.ops.append(op)
            self.op_index[op] = len(self.ops) - 1
        return self.op_index[op]

    def const(self, x: float) -> int:
        return self.emit(("const", float(x)))

    def number(self, e) -> float:
        sp = sympy()
        if e.is_real is False or (e.has(sp.I)):
            raise ValueError(f"{self.what}: the constant {_show(e)} is complex; the potential must be real")
        if e in (sp.nan, sp.oo, -sp.oo, sp.zoo):
            raise ValueError(f"{self.what}: the constant {e} is not finite")
        try:
            x = float(e)
        except OverflowError:
            x = math.inf
        if not math.isfinite(x):
            raise ValueError(f"{self.what}: the constant {_show(e)} is not finite (too large for a double)")
        return x

    def check(self, expr) -> None:
        """Free symbols must be coordinates or parameters; no unsupported constructs."""
        sp = sympy()
        for s in expr.free_symbols:
            if s not in self.inputs and str(s) not in self.params:
                raise ValueError(
                    f"{self.what}: the symbol {s} is neither in {self.inputs_name} ({self.allowed}) nor in params"
                    f" ({', '.join(self.params) or 'none given'}); pass params={{'{s}': value}}"
                )
        if expr.has(sp.I):
            raise ValueError(f"{self.what}: contains the imaginary unit; the potential must be real")

    def compile(self, expr) -> int:
        """The tape index of expr (iterative post-order, so deep expressions do not recurse)."""
        self.check(expr)
        stack = [(expr, False)]
        while stack:
            e, ready = stack.pop()
            if e in self.memo:
                continue
            children = self._children(e)
            if ready or not children:
                self.memo[e] = self._node(e)
                continue
            stack.append((e, True))
            stack.extend((c, False) for c in children if c not in self.memo)
        return self.memo[expr]

    def _children(self, e) -> list:
        sp = sympy()
        if isinstance(e, sp.Symbol) or e.is_Number or e.is_NumberSymbol:
            return []
        supported = isinstance(e, sp.Add | sp.Mul | sp.Pow) or (
            type(e).__name__ in FUNCTIONS and len(e.args) == 1)
        if not supported:  # refused before its arguments are looked at
            raise ValueError(f"{self.what}: {_describe(e)} is not supported; supported are {SUPPORTED}")
        if isinstance(e, sp.Pow):
            return [e.base] if e.exp.is_Number or _is_param(e.exp, self.params) else [e.base, e.exp]
        return list(e.args)

    def _node(self, e) -> int:
        sp = sympy()
        m = self.memo
        if isinstance(e, sp.Symbol):
            if e in self.inputs:
                return self.emit(("input", self.inputs[e]))
            return self.const(self.params[str(e)])
        if e.is_Number or e.is_NumberSymbol:
            return self.const(self.number(e))
        if isinstance(e, sp.Add):
            return self._sum(e.args)
        if isinstance(e, sp.Mul):
            return self._product(e.args)
        if isinstance(e, sp.Pow):
            return self._power(e)
        name = type(e).__name__
        if name in FUNCTIONS and len(e.args) == 1:
            return self.emit((FUNCTIONS[name], m[e.args[0]]))
        raise ValueError(f"{self.what}: {_describe(e)} is not supported; supported are {SUPPORTED}")

    def _sum(self, args) -> int:
        sp = sympy()
        acc = None
        for a in args:
            neg = isinstance(a, sp.Mul) and a.args[0] == -1
            if neg:
                rest = sp.Mul(*a.args[1:], evaluate=False) if len(a.args) > 2 else a.args[1]
                t = self.memo.get(rest)
                if t is None:
                    t = self.compile(rest)
            else:
                t = self.memo[a]
            if acc is None:
                acc = self.emit(("neg", t)) if neg else t
            else:
                acc = self.emit(("sub" if neg else "add", acc, t))
        return acc

    def _product(self, args) -> int:
        sp = sympy()
        num, den = [], []
        sign = 1.0
        for a in args:
            if a == -1:
                sign = -sign
            elif isinstance(a, sp.Pow) and a.exp.is_Number and a.exp < 0:
                inv = sp.Pow(a.base, -a.exp)
                den.append(self.memo[inv] if inv in self.memo else self.compile(inv))
            else:
                num.append(self.memo[a])
        acc = None
        for t in num:
            acc = t if acc is None else self.emit(("mul", acc, t))
        if acc is None:
            acc = self.const(1.0)
        d = None
        for t in den:
            d = t if d is None else self.emit(("mul", d, t))
        if d is not None:
            acc = self.emit(("div", acc, d))
        return self.emit(("neg", acc)) if sign < 0 else acc

    def _power(self, e) -> int:
        sp = sympy()
        b, x = self.memo[e.base], e.exp
        if x.is_Integer:
            k = int(x)
            if abs(k) > 1 << 20:
                raise ValueError(f"{self.what}: the exponent {k} is too large (at most 2^20)")
            if k < 0:
                return self.emit(("div", self.const(1.0), self.emit(("powi", b, -k))))
            return self.emit(("powi", b, k))
        if x.is_Rational:
            if x == sp.Rational(1, 2):
                return self.emit(("sqrt", b))
            if x == sp.Rational(-1, 2):
                return self.emit(("div", self.const(1.0), self.emit(("sqrt", b))))
            if x.q == 2 and abs(x.p) < 64:
                # b^(p/2) = b^⌊p/2⌋·sqrt(b) exactly as written, without pow's rounding.
                s = self.emit(("sqrt", b))
                k = (abs(int(x.p)) - 1) // 2
                r = s if k == 0 else self.emit(("mul", self.emit(("powi", b, k)), s))
                return self.emit(("div", self.const(1.0), r)) if x < 0 else r
            return self.emit(("powf", b, float(x)))
        if x.is_Number:
            return self.emit(("powf", b, self.number(x)))
        if _is_param(x, self.params):
            return self.emit(("powf", b, self.params[str(x)]))
        raise ValueError(
            f"{self.what}: the power {e} has a non-constant exponent {x}; supported are integer and "
            "rational (or parameter) exponents; write exp(y*log(x)) for x**y"
        )


def _show(e) -> str:
    """A number for a message: its digits, shortened; a huge integer by its length."""
    try:
        text = str(e)
    except ValueError:  # more digits than Python converts to text
        return f"(an integer of about {int(abs(e.p).bit_length() * 0.30103)} digits)"
    return text if len(text) <= 60 else text[:40] + "..." + text[-10:]


def _is_param(x, params) -> bool:
    sp = sympy()
    return isinstance(x, sp.Symbol) and str(x) in params


def _describe(e) -> str:
    sp = sympy()
    if isinstance(e, sp.Piecewise):
        return "Piecewise"
    if isinstance(e, sp.Derivative):
        return f"the derivative {e}"
    if isinstance(e, sp.core.function.AppliedUndef):
        return f"the undefined function {type(e).__name__}"
    return f"{type(e).__name__} (in {e})"


def tape(expr, coordinates: Sequence, params: Mapping[str, float], what: str = "expr",
         inputs: str = "coordinates") -> dict:
    """The tape of expr in `coordinates` with numeric `params` (errors name the arguments `what`
    and `inputs`)."""
    c = Compiler(coordinates, params, what, inputs)
    out = c.compile(expr)
    return {"n": len(coordinates), "ops": c.ops, "output": out}


_BINARY = ("add", "sub", "mul", "div")


def chain_tape(n: int, terms: list[dict]) -> dict:
    """One tape of Σ_terms Σ_b V_term((L q)_b) from a chain's terms (each a V tape of one input
    and a map in compressed rows): the forms y_b = Σ_k L_bk q_k in stored order, V at each, the
    values summed in term and row order. A short chain runs as this one program (one pass of
    machine code, no per-term overhead)."""
    ops: list[tuple] = []
    index: dict[tuple, int] = {}

    def emit(op: tuple) -> int:
        if op not in index:
            ops.append(op)
            index[op] = len(ops) - 1
        return index[op]

    total = None
    for term in terms:
        v, m = term["v"], term["map"]
        ptr, idx, vals = m["ptr"], m["idx"], [float(x) for x in m["vals"]]
        for b in range(len(ptr) - 1):
            y = None
            for k in range(ptr[b], ptr[b + 1]):
                x = emit(("input", int(idx[k])))
                c = vals[k]
                t = x if c == 1.0 else emit(("neg", x)) if c == -1.0 else emit(("mul", emit(("const", c)), x))
                y = t if y is None else emit(("add", y, t))
            if y is None:
                y = emit(("const", 0.0))
            at: dict[int, int] = {}
            for j, op in enumerate(v["ops"]):
                name = op[0]
                if name == "input":
                    at[j] = y
                elif name == "const":
                    at[j] = emit(op)
                elif name in _BINARY:
                    at[j] = emit((name, at[op[1]], at[op[2]]))
                else:  # one operand, and powi's or powf's exponent
                    at[j] = emit((name, at[op[1]], *op[2:]))
            total = at[v["output"]] if total is None else emit(("add", total, at[v["output"]]))
    return {"n": n, "ops": ops, "output": total}
