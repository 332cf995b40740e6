"""Expression strings are data: parsed by a whitelist (numbers, declared names, the supported
functions, arithmetic), never evaluated as Python; accepted strings give the expression SymPy
would have given; sums of any length parse."""

import numpy as np
import pytest
import sympy as sp

import trigint as ti
from trigint import _tape


def parse_string(text, names):
    return _tape.parse(text, names)


NAMES = ["x", "y", "z", "w", "a", "b", "g", "k"]


def _payloads(marker):
    """Strings that create `marker` if anything evaluates them as Python."""
    path = str(marker)
    return [
        f"x**2 + __import__('pathlib').Path({path!r}).touch()*0",
        f"x**2 + (lambda: __import__('pathlib').Path({path!r}).touch())()*0",
        f"x.__class__.__init__.__globals__['__builtins__']['__import__']('pathlib').Path({path!r}).touch()",
        f"x + getattr(__import__('pathlib').Path({path!r}), 'touch')()*0",
        f"x + exec(\"open({path!r}, 'w')\")",
    ]


@pytest.mark.parametrize("index", range(5))
def test_payload_is_refused_and_nothing_runs(tmp_path, index):
    marker = tmp_path / "payload-ran"
    text = _payloads(marker)[index]
    with pytest.raises(ValueError, match=r"is not allowed: .*; allowed are numbers, the names x"):
        ti.ExpressionPotential(text, ["x"])
    with pytest.raises(ValueError, match=r"is not allowed"):
        ti.ChainPotential(2).add(text, "x", sites=[0])
    assert not marker.exists()


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("x**2 + __import__('os').getpid()*0", "'__import__' at character 8 is not allowed: names beginning with an"
                                               " underscore are refused"),
        ("x.real", "'.' at character 2 is not allowed: attribute access is refused"),
        ("(lambda: 0)()", "'lambda' at character 2 is not allowed: 'lambda' is a Python keyword"),
        ("x[0]", "'[' at character 2 is not allowed: subscripts are refused"),
        ("x + 'a'", "\"'\" at character 5 is not allowed: strings are refused"),
        ("eval('x')", "'eval' at character 1 is not allowed: eval is an undefined function here"),
        ("x(2)", "'x' at character 1 is not allowed: x is a declared symbol, not a function"),
        ("x == 1", "'=' at character 3 is not allowed: assignments and comparisons are refused"),
        ("exp + x", "'exp' at character 1 is not allowed: the function exp must be called"),
        ("__class__", "'__class__' at character 1 is not allowed"),
    ],
)
def test_refused_constructs_name_the_token(text, fragment):
    with pytest.raises(ValueError) as info:
        ti.ExpressionPotential(text, ["x"])
    message = str(info.value)
    assert message.startswith("expr: ") and fragment in message
    assert "allowed are numbers, the names x, pi, E, the functions exp, log, sqrt" in message


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("x +", "could not parse 'x +': it ends after '+'"),
        ("", "could not parse '': it is empty"),
        ("2x", "unexpected 'x' at character 2"),
        ("((x)", "it ends where ')' is expected (to close the '(' at character 1)"),
        ("exp(x, x)", "exp at character 1 takes 1 argument(s), got 2"),
        ("-" * 150 + "x", "nested more than 100 levels deep"),
        ("(" * 150 + "x" + ")" * 150, "nested more than 100 levels deep"),
        ("2**2**2**2**2**2 * x", "raises a number to an exponent larger than 2^20"),
        ("1" * 5000 + "*x", "an integer of more than 4300 digits"),
    ],
)
def test_syntax_errors_say_what_is_wrong(text, fragment):
    with pytest.raises(ValueError, match="^expr: ") as info:
        ti.ExpressionPotential(text, ["x"])
    assert fragment in str(info.value)


def test_huge_constant_is_a_value_error_not_a_printing_failure():
    # 2**65536 has 19 729 digits: more than Python converts to text
    with pytest.raises(ValueError, match=r"the constant \(an integer of about 1972\d digits\) is not finite"):
        ti.ExpressionPotential("2**2**2**2**2 * x", ["x"])


@pytest.mark.parametrize(
    "text",
    [
        "k*(x - y)**2/2 + exp(-x)", "x^2 + y", "-x**2", "2**-1*x", "1/3*x", "0.1*x + 1e-3", "log(x, 2) + log(y)",
        "abs(x) + Abs(y)", "sqrt(x - 2) + y**2", "g*(2 - cos(a) - cos(b))", "x - y - z + 2 - 3", "-(-x) + +y",
        "x**y**2", "(x**2 + y**2) / 2", "0.3*x**2 + 0.2*x*y - 0.1*z*w + 0.4*y*w", "pi*x + E", "I*x",
        "exp(y) - 1 - y", "1.5E3*x", "x**(1/2)", "x**0.5", "0.12345678901234567890123*x", "1_000*x", ".5*x + 5.*y",
        "2*x*y/3/z", "x - (y - z)", "-2**2*x", "(-2)**2*x", "sinh(x)*cosh(y)/tanh(z) + tan(w)*sin(a)",
    ],
)
def test_accepted_strings_give_what_sympify_gave(text):
    local = {n: sp.Symbol(n) for n in NAMES}
    assert sp.srepr(parse_string(text, NAMES)) == sp.srepr(sp.sympify(text, locals=local))


def test_sympy_expressions_pass_unchanged():
    x, y = sp.symbols("x y")
    expr = sp.Rational(1, 4) * (x - y) ** 4 + sp.cos(x)
    pot = ti.ExpressionPotential(expr, [x, y])
    assert pot.expr is expr
    assert pot.value([0.5, -0.5]) == pytest.approx(0.25 + np.cos(0.5), rel=1e-15)


@pytest.mark.parametrize("terms", [5000, 20000])
def test_long_sums_parse(terms):
    """SymPy's own parser gave 'could not parse' beyond a few thousand terms."""
    text = " + ".join(f"{i % 7 + 1}*x{i % 40}**2*x{(i + 1) % 40} - x{i % 40}/{i + 1}" for i in range(terms))
    coords = [f"x{i}" for i in range(40)]
    pot = ti.ExpressionPotential(text, coords)
    q = np.linspace(-0.5, 0.5, 40)
    expected = sum((i % 7 + 1) * q[i % 40] ** 2 * q[(i + 1) % 40] - q[i % 40] / (i + 1) for i in range(terms))
    assert pot.value(q) == pytest.approx(expected, rel=1e-12)


def test_undeclared_names_keep_the_compilers_message():
    with pytest.raises(ValueError, match=r"the symbol beta is neither in coordinates \(x\) nor in params"):
        ti.ExpressionPotential("beta*x", ["x"])


def test_chain_terms_use_the_same_parser():
    with pytest.raises(ValueError, match=r"^v: 'os' at character 1 is not allowed: os is an undefined function"):
        ti.ChainPotential(3).add("os(y)", "y", sites=[0])
    long = " + ".join(f"y**{k % 4 + 2}/{k + 1}" for k in range(5000))
    pot = ti.ChainPotential(3).add(long, "y", sites=[0, 2])
    one = sum(0.3 ** (k % 4 + 2) / (k + 1) for k in range(5000))
    assert pot.value([0.3, 7.0, 0.3]) == pytest.approx(2 * one, rel=1e-12)
