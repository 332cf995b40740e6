"""Types at the boundary: integer arguments refuse floats, strings and booleans (a TypeError
naming the argument); numbers that do not fit a double are a ValueError naming the argument,
never a raw OverflowError."""

import numpy as np
import pytest

import trigint as ti
from trigint import resonance

BIG = 10**400  # an exact integer no double can hold
PROB = ti.problems.fpu()
Q0, P0 = ti.problems.fpu_initial()
H = 2 * np.pi / 3 / 50
POLY = ti.PolynomialPotential([1.0], [[1, 1]])


def _with(values, i, x):
    out = list(values)
    out[i] = x
    return out


TOO_LARGE = {
    "h": lambda x: ti.integrate(PROB, "B", Q0, P0, h=x, n_steps=3),
    "t_end": lambda x: ti.integrate(PROB, "B", Q0, P0, h=H, t_end=x),
    "n_steps": lambda x: ti.integrate(PROB, "B", Q0, P0, h=H, n_steps=x),
    "save_every": lambda x: ti.integrate(PROB, "B", Q0, P0, h=H, n_steps=3, save_every=x),
    "q0": lambda x: ti.integrate(PROB, "B", _with(Q0, 0, x), P0, h=H, n_steps=3),
    "p0": lambda x: ti.integrate(PROB, "B", Q0, _with(P0, 2, x), h=H, n_steps=3),
    "ensemble q0": lambda x: ti.ensemble(PROB, "B", _with(Q0, 0, x), P0, h=H, n_steps=3),
    "ensemble h": lambda x: ti.ensemble(PROB, "B", Q0, P0, h=[H, x], n_steps=3),
    "ensemble t_end": lambda x: ti.ensemble(PROB, "B", Q0, P0, h=H, t_end=x),
    "ensemble n_steps": lambda x: ti.ensemble(PROB, "B", Q0, P0, h=H, n_steps=x),
    "scan h_omega": lambda x: ti.scan(PROB, "B", Q0, P0, h_omega=[2.0, x], t_end=1.0),
    "scan omega_ref": lambda x: ti.scan(PROB, "B", Q0, P0, h_omega=[2.0], t_end=1.0, omega_ref=x),
    "perturb deltas": lambda x: ti.perturb(Q0, P0, [0.0, x]),
    "omega": lambda x: ti.OscillatoryProblem([x, 1.0], POLY),
    "stiffness": lambda x: ti.OscillatoryProblem(stiffness=[[x, 0], [0, 1]], potential=POLY),
    "params": lambda x: ti.ExpressionPotential("a*x", ["x"], params={"a": x}),
    "chain params": lambda x: ti.ChainPotential(3).add("a*y", params={"a": x}, sites=[0]),
    "coefficients": lambda x: ti.PolynomialPotential([x], [[2]]),
    "q": lambda x: ti.FPUPotential(1).value([x, 0.0]),
    "fpu omega": lambda x: ti.problems.fpu(omega=x),
    "fpu_initial omega": lambda x: ti.problems.fpu_initial(omega=x),
    "experiment1 omega": lambda x: ti.problems.experiment1(omega=x),
    "alpha": lambda x: ti.AlphaMethod(x),
    "h ": lambda x: resonance.analyze(x, [1.0]),
    "delta": lambda x: resonance.analyze(0.1, [1.0], delta=x),
    "x": lambda x: ti.sinc(x),
    "energies q": lambda x: ti.energies(PROB, _with(Q0, 1, x), P0),
    "krylov_tolerance": lambda x: ti.OscillatoryProblem(stiffness=np.eye(2), potential=POLY, krylov_tolerance=x),
}


@pytest.mark.parametrize("label", list(TOO_LARGE))
def test_a_number_too_large_for_a_double_is_a_value_error_naming_the_argument(label):
    name = label.split()[-1]
    with pytest.raises(ValueError) as info:
        TOO_LARGE[label](BIG)
    message = str(info.value)
    assert message.startswith(f"{name}:") or f" {name}:" in message or f"{name} " in message, message
    assert len(message) < 600, message  # the 401 digits are not printed in full


@pytest.mark.parametrize(
    ("call", "name", "value"),
    [
        (lambda v: ti.ChainPotential(3).add("y**2", pairs=v), "pairs", [(0.7, 1.2)]),
        (lambda v: ti.ChainPotential(3).add("y**2", pairs=v), "pairs", [(0, 1.0)]),
        (lambda v: ti.ChainPotential(3).add("y**2", pairs=v), "pairs", [(True, 2)]),
        (lambda v: ti.ChainPotential(3).add("y**2", pairs=v), "pairs", ["01"]),
        (lambda v: ti.ChainPotential(3).add("y**2", pairs=v), "pairs", np.array([[0.0, 1.0]])),
        (lambda v: ti.ChainPotential(3).add("y**2", sites=v), "sites", "012"),
        (lambda v: ti.ChainPotential(3).add("y**2", sites=v), "sites", [1.0]),
        (lambda v: ti.ChainPotential(3).add("y**2", sites=v), "sites", [True, 2]),
        (lambda v: ti.ChainPotential(3).add("y**2", sites=v), "sites", np.array([0.0, 1.0])),
        (lambda v: ti.ChainPotential(3).add("y**2", sites=v), "sites", b"01"),
        (lambda v: ti.ChainPotential(3).add("y**2", sites=v), "sites", 1.5),
    ],
)
def test_chain_indices_refuse_floats_strings_and_booleans(call, name, value):
    with pytest.raises(TypeError, match=rf"^{name}: .*integer"):
        call(value)


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda v: ti.ChainPotential(v), "n"),
        (lambda v: ti.FPUPotential(v), "m"),
        (lambda v: ti.problems.fpu(m=v), "m"),
        (lambda v: ti.PythonPotential(lambda q: 0.0, lambda q: q, dim=v), "dim"),
        (lambda v: ti.perturb(Q0, P0, [0.0], index=v), "index"),
        (lambda v: ti.integrate(PROB, "B", Q0, P0, h=H, n_steps=v), "n_steps"),
        (lambda v: ti.integrate(PROB, "B", Q0, P0, h=H, n_steps=3, save_every=v), "save_every"),
        (lambda v: ti.ensemble(PROB, "B", Q0, P0, h=H, n_steps=v), "n_steps"),
        (lambda v: ti.ensemble(PROB, "B", Q0, P0, h=H, n_steps=3, save_every=v), "save_every"),
        (lambda v: ti.ensemble(PROB, "B", Q0, P0, h=H, n_steps=3, threads=v), "threads"),
        (lambda v: ti.ensemble(PROB, "B", Q0, P0, h=H, n_steps=3, chunk_size=v), "chunk_size"),
        (lambda v: resonance.analyze(0.1, [1.0], N_max=v), "N_max"),
    ],
)
@pytest.mark.parametrize("value", [3.0, "3", True])
def test_integer_arguments_refuse_floats_strings_and_booleans(call, name, value):
    with pytest.raises(TypeError, match=rf"^{name}: (expected|must be|the number of .* must be) an integer") as info:
        call(value)
    assert repr(value) in str(info.value)


def test_valid_indices_keep_working():
    a = ti.ChainPotential(3).add("y**2", sites=np.array([0, 2], dtype=np.int32))
    b = ti.ChainPotential(3).add("y**2", sites=range(0, 3, 2))
    c = ti.ChainPotential(3).add("y**2", pairs=np.array([[0, 1], [1, 2]]))
    d = ti.ChainPotential(3).add("y**2", pairs=[(np.int64(0), 1), (1, 2)])
    q = [0.3, -0.2, 0.5]
    assert a.value(q) == b.value(q) == pytest.approx(0.34, rel=1e-15)
    assert c.value(q) == d.value(q) == pytest.approx(0.25 + 0.49, rel=1e-15)
