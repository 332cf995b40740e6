"""Expression strings as data: a parser that builds SymPy expressions without running Python.

Strings such as ``"g*(2 - cos(a) - cos(b))"`` come from files and notebooks; they are read by a
small tokenizer and a precedence parser that know only

- numbers (``2``, ``0.5``, ``1e-3``),
- the declared names (coordinates, parameters; any other plain name becomes a symbol that the
  compiler then reports as undeclared), the constants ``pi``, ``E`` and ``I``,
- the supported functions (:data:`FUNCTIONS`), each called with one argument (``log`` also
  with two: ``log(x, b)``),
- ``+ - * / **`` (``^`` is ``**``, as in SymPy) and parentheses.

Anything else (attribute access, subscripts, strings, keywords such as ``lambda``, names that
begin with an underscore, calls of other names) is refused with an error that names the token
and its position. Nothing is passed to ``eval``: each node is built with SymPy's own
constructors and operators, so an accepted string gives the expression ``sympy.sympify`` would
have given. Sums are read in a loop and built with one ``Add``: sums of any length parse
(``sympify`` fails beyond a few thousand terms); nesting (parentheses, signs, powers) is
limited to :data:`MAX_DEPTH` levels.

>>> parse_string("k*(x - y)**2/2 + exp(-x)", ["x", "y", "k"])
k*(x - y)**2/2 + exp(-x)
>>> try:
...     parse_string("__import__('os').getpid()", ["x"])
... except ValueError as exc:
...     print(str(exc).split(";")[0])
expr: '__import__' at character 1 is not allowed: names beginning with an underscore are refused
"""

from __future__ import annotations

import contextlib
import keyword
import re
from collections.abc import Sequence

#: function name in a string → (SymPy constructor name, numbers of arguments allowed)
FUNCTIONS = {
    "exp": ("exp", (1,)), "log": ("log", (1, 2)), "sqrt": ("sqrt", (1,)),
    "sin": ("sin", (1,)), "cos": ("cos", (1,)), "tan": ("tan", (1,)),
    "sinh": ("sinh", (1,)), "cosh": ("cosh", (1,)), "tanh": ("tanh", (1,)),
    "Abs": ("Abs", (1,)), "abs": ("Abs", (1,)),
}
#: constant name → SymPy attribute
CONSTANTS = {"pi": "pi", "E": "E", "I": "I"}
#: the deepest nesting of parentheses, signs, powers and calls accepted
MAX_DEPTH = 100
#: the longest integer literal accepted (Python's own limit for converting digits to int)
MAX_DIGITS = 4300

_TOKEN = re.compile(r"""
    (?P<space>\s+)
  | (?P<number>(?:\d[\d_]*(?:\.[\d_]*)?|\.\d[\d_]*)(?:[eE][+-]?\d[\d_]*)?)
  | (?P<name>[^\W\d]\w*)
  | (?P<op>\*\*|[-+*/^(),])
""", re.VERBOSE)

_WHAT_IS_ALLOWED = ("allowed are numbers, the names {names}, pi, E, the functions "
                    + ", ".join(f for f in FUNCTIONS if f != "abs") + ", + - * / ** ^ and parentheses")


class _Token:
    __slots__ = ("kind", "text", "pos")

    def __init__(self, kind: str, text: str, pos: int):
        self.kind, self.text, self.pos = kind, text, pos

    def where(self) -> str:
        text = self.text if len(self.text) <= 40 else self.text[:37] + "..."
        return f"{text!r} at character {self.pos + 1}"


def _sympy():
    import sympy

    return sympy


def parse_string(text: str, names: Sequence[str], what: str = "expr"):
    """The SymPy expression of `text`, with `names` (coordinates, parameters) as symbols.

    Raises ValueError naming the offending token for anything outside the whitelist.

    >>> parse_string("2*x^3 - log(x, 2)", ["x"])
    2*x**3 - log(x)/log(2)
    >>> try:
    ...     parse_string("x.real", ["x"])
    ... except ValueError as exc:
    ...     print(str(exc).split(";")[0])
    expr: '.' at character 2 is not allowed: attribute access is refused
    """
    return _Parser(text, names, what).parse()


class _Parser:
    """Precedence parsing as Python's (``-x**2`` is ``-(x**2)``, ``**`` binds to the right)."""

    def __init__(self, text: str, names: Sequence[str], what: str):
        self.sp = _sympy()
        self.text, self.what = text, what
        self.names = {str(n): self.sp.Symbol(str(n)) for n in names}
        self.allowed = _WHAT_IS_ALLOWED.format(names=", ".join(self.names) or "(none declared)")
        self.tokens = self._tokenize()
        self.i = 0
        self.depth = 0

    # -- errors ------------------------------------------------------------------------------
    def refuse(self, token: _Token, why: str) -> ValueError:
        return ValueError(f"{self.what}: {token.where()} is not allowed: {why}; {self.allowed}")

    def syntax(self, why: str) -> ValueError:
        return ValueError(f"{self.what}: could not parse {_short(self.text)}: {why}")

    # -- tokens ------------------------------------------------------------------------------
    def _tokenize(self) -> list[_Token]:
        """The tokens; a character outside the grammar is a "char" token, refused when reached
        (so that errors come in reading order)."""
        out, pos, text = [], 0, self.text
        while pos < len(text):
            m = _TOKEN.match(text, pos)
            if m is None:
                out.append(_Token("char", text[pos], pos))
                pos += 1
                continue
            if m.lastgroup != "space":
                out.append(_Token(m.lastgroup, m.group(), pos))
            pos = m.end()
        if not out:
            raise self.syntax("it is empty")
        return out

    def peek(self) -> _Token | None:
        token = self.tokens[self.i] if self.i < len(self.tokens) else None
        if token is not None and token.kind == "char":
            raise self.refuse(token, _why_char(token.text))
        return token

    def peek_op(self, op: str) -> bool:
        token = self.peek()
        return token is not None and token.kind == "op" and token.text == op

    def take(self) -> _Token:
        token = self.peek()
        if token is None:
            last = self.tokens[-1]
            raise self.syntax(f"it ends after {last.text!r}, where a number, a name or '(' is expected")
        self.i += 1
        return token

    def accept(self, *ops: str) -> _Token | None:
        token = self.peek()
        if token is not None and token.kind == "op" and token.text in ops:
            self.i += 1
            return token
        return None

    def expect(self, op: str, context: str) -> None:
        token = self.peek()
        if token is None:
            raise self.syntax(f"it ends where {op!r} is expected ({context})")
        if not (token.kind == "op" and token.text == op):
            raise self.syntax(f"{token.where()} where {op!r} is expected ({context})")
        self.i += 1

    # -- grammar -----------------------------------------------------------------------------
    def parse(self):
        out = self.sum()
        token = self.peek()
        if token is not None:
            raise self.syntax(f"unexpected {token.where()} (an operator is missing before it?)")
        return out

    def sum(self):
        """term (('+' | '-') term)*, built as one Add (no recursion, whatever its length)."""
        terms = [self.product()]
        while (op := self.accept("+", "-")) is not None:
            term = self.product()
            terms.append(-term if op.text == "-" else term)
        return terms[0] if len(terms) == 1 else self.sp.Add(*terms)

    def product(self):
        acc = self.unary()
        while (op := self.accept("*", "/")) is not None:
            right = self.unary()
            acc = acc * right if op.text == "*" else acc / right
        return acc

    def unary(self):
        op = self.accept("+", "-")
        if op is None:
            return self.power()
        with self.nested(op):
            operand = self.unary()
        return -operand if op.text == "-" else operand

    def power(self):
        base = self.atom()
        op = self.accept("**", "^")
        if op is None:
            return base
        with self.nested(op):
            exponent = self.unary()  # right-associative; 2**-1 allowed, as in Python
        return self._pow(base, exponent, op)

    def atom(self):
        token = self.take()
        if token.kind == "number":
            return self._number(token)
        if token.kind == "name":
            return self._name(token)
        if token.text == "(":
            with self.nested(token):
                inner = self.sum()
            self.expect(")", f"to close the '(' at character {token.pos + 1}")
            return inner
        raise self.syntax(f"{token.where()} where a number, a name or '(' is expected")

    # -- nodes -------------------------------------------------------------------------------
    @contextlib.contextmanager
    def nested(self, token: _Token):
        """One level deeper (the parser recurses only here, so its depth is bounded)."""
        if self.depth >= MAX_DEPTH:
            raise self.syntax(f"nested more than {MAX_DEPTH} levels deep at {token.where()} (parentheses, "
                              "signs, powers and calls); write it with fewer levels")
        self.depth += 1
        try:
            yield
        finally:
            self.depth -= 1

    def _number(self, token: _Token):
        digits = token.text.replace("_", "")
        if any(c in digits for c in ".eE"):
            return self.sp.Float(digits)  # as sympify reads it: the decimal digits, not a double
        if len(digits) > MAX_DIGITS:
            raise self.refuse(token, f"an integer of more than {MAX_DIGITS} digits")
        return self.sp.Integer(int(digits))

    def _name(self, token: _Token):
        name = token.text
        if name in self.names:
            if self.peek_op("("):
                raise self.refuse(token, f"{name} is a declared symbol, not a function")
            return self.names[name]
        if name.startswith("_"):
            raise self.refuse(token, "names beginning with an underscore are refused")
        if keyword.iskeyword(name) or keyword.issoftkeyword(name):
            raise self.refuse(token, f"{name!r} is a Python keyword")
        if self.peek_op("("):
            return self._call(token)
        if name in FUNCTIONS:
            raise self.refuse(token, f"the function {name} must be called, as in {name}(x)")
        if name in CONSTANTS:
            return getattr(self.sp, CONSTANTS[name])
        return self.sp.Symbol(name)  # undeclared: the compiler says which names are allowed

    def _call(self, token: _Token):
        name = token.text
        if name not in FUNCTIONS:
            raise self.refuse(token, f"{name} is an undefined function here (only the functions listed are "
                                     "supported)")
        constructor, counts = FUNCTIONS[name]
        self.expect("(", f"after {name}")
        args = []
        with self.nested(token):
            if self.peek_op(")"):
                raise self.syntax(f"{name}() at character {token.pos + 1} has no argument")
            args.append(self.sum())
            while self.accept(","):
                args.append(self.sum())
        self.expect(")", f"to close the call of {name} at character {token.pos + 1}")
        if len(args) not in counts:
            want = " or ".join(map(str, counts))
            raise self.syntax(f"{name} at character {token.pos + 1} takes {want} argument(s), got {len(args)}")
        return getattr(self.sp, constructor)(*args)

    def _pow(self, base, exponent, op: _Token):
        if base.is_Number and exponent.is_Number and abs(exponent) > 2**20 and abs(base) not in (0, 1):
            raise ValueError(f"{self.what}: the power at character {op.pos + 1} of {_short(self.text)} raises a "
                             "number to an exponent larger than 2^20 in magnitude, which is not allowed")
        return base**exponent


def _why_char(c: str) -> str:
    reasons = {
        ".": "attribute access is refused", "[": "subscripts are refused", "]": "subscripts are refused",
        "'": "strings are refused", '"': "strings are refused", "=": "assignments and comparisons are refused",
        ":": "this is not an expression", ";": "one expression only", "@": "this operator is not supported",
        "%": "this operator is not supported", "<": "comparisons are refused", ">": "comparisons are refused",
        "!": "this operator is not supported", "{": "this is not an expression", "}": "this is not an expression",
        "&": "this operator is not supported", "|": "this operator is not supported",
        "~": "this operator is not supported", "\\": "this is not an expression", "#": "comments are refused",
    }
    return reasons.get(c, "this character is not part of an arithmetic expression")


def _short(text: str) -> str:
    return repr(text) if len(text) <= 80 else repr(text[:77] + "...")
