"""Numbers in specs: a float, or an arithmetic expression evaluated without running Python
(the expression's syntax tree is walked with a whitelist of nodes)."""

from __future__ import annotations

import ast
import math
import operator

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
