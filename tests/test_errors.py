"""Bad input gets ValueError/TypeError naming the argument and what is allowed."""

import warnings

import numpy as np
import pytest

import trigint as ti


@pytest.fixture
def setup(fpu):
    prob, q0, p0 = fpu
    return prob, ti.Trigonometric("B"), q0, p0


@pytest.mark.parametrize("h", [0.0, -0.1, np.nan, np.inf])
def test_bad_step_size(setup, h):
    prob, m, q0, p0 = setup
    with pytest.raises(ValueError, match="h: the step size must be finite and > 0"):
        ti.integrate(prob, m, q0, p0, h=h, n_steps=10)


def test_step_size_type(setup):
    prob, m, q0, p0 = setup
    with pytest.raises(TypeError, match="h:"):
        ti.integrate(prob, m, q0, p0, h="0.1", n_steps=10)


def test_both_or_neither_of_t_end_and_n_steps(setup):
    prob, m, q0, p0 = setup
    with pytest.raises(ValueError, match="exactly one"):
        ti.integrate(prob, m, q0, p0, h=0.01)
    with pytest.raises(ValueError, match="exactly one"):
        ti.integrate(prob, m, q0, p0, h=0.01, t_end=1.0, n_steps=100)
    with pytest.raises(ValueError, match="t_end"):
        ti.integrate(prob, m, q0, p0, h=0.01, t_end=-1.0)
    with pytest.raises(ValueError, match="n_steps"):
        ti.integrate(prob, m, q0, p0, h=0.01, n_steps=-3)
    with pytest.raises(ValueError, match="save_every"):
        ti.integrate(prob, m, q0, p0, h=0.01, n_steps=3, save_every=0)


@pytest.mark.parametrize(("q0", "match"), [
    (np.zeros(5), r"q0: expected shape \(6,\)"),
    (np.zeros((2, 6)), r"q0: expected shape \(6,\)"),
    (np.r_[np.nan, np.zeros(5)], r"q0: entries must be finite; q0\[0\]"),
])
def test_bad_initial_values(setup, q0, match):
    prob, m, _, p0 = setup
    with pytest.raises(ValueError, match=match):
        ti.integrate(prob, m, q0, p0, h=0.01, n_steps=3)
    with pytest.raises(ValueError, match=match.replace("q0", "p0")):
        ti.integrate(prob, m, p0, q0, h=0.01, n_steps=3)


@pytest.mark.parametrize(("omega", "match"), [
    ([0.0, -1.0], r"omega\[1\] = -1"),
    ([0.0, np.inf], r"omega\[1\] = inf"),
    ([[1.0, 2.0]], "1-d array"),
    ([], "1-d array"),
])
def test_bad_frequencies(omega, match):
    with pytest.raises(ValueError, match=match):
        ti.OscillatoryProblem(omega, ti.FPUPotential(1))


def test_potential_dimension_must_match():
    with pytest.raises(ValueError, match=r"acts on 4 coordinates, but the problem \(omega or stiffness, q\) has 3"):
        ti.OscillatoryProblem([0.0, 1.0, 1.0], ti.FPUPotential(2))
    with pytest.raises(TypeError, match="potential"):
        ti.OscillatoryProblem([0.0, 1.0], lambda q: q)


def test_multiple_of_pi_is_refused_and_names_the_coordinate():
    prob = ti.OscillatoryProblem([0.0, 10.0, 20.0], ti.PolynomialPotential([1.0], [[4, 0, 0]]))
    h = np.pi / 20.0  # h*omega[2] = pi
    with pytest.raises(ValueError, match=r"h\*omega\[2\] = 3.14159265358979 is 1\*pi"):
        ti.integrate(prob, "B", np.zeros(3), np.zeros(3), h=h, n_steps=3)
    with pytest.raises(ValueError, match=r"h\*omega\[1\]"):
        ti.integrate(prob, "A", np.zeros(3), np.zeros(3), h=2 * np.pi / 10.0, n_steps=3)


@pytest.mark.parametrize(("alpha", "limit"), [(0.0, 2.0), (0.1, 2 / np.sqrt(0.6))])
def test_alpha_step_restriction(alpha, limit):
    prob = ti.OscillatoryProblem([0.0, 50.0], ti.FPUPotential(1))
    method = ti.AlphaMethod(alpha)
    with pytest.raises(ValueError, match=f"2/sqrt\\(1 - 4 alpha\\) = {limit:.12g}"[:-2]):
        ti.integrate(prob, method, np.zeros(2), np.zeros(2), h=limit / 50.0, n_steps=3)
    with pytest.raises(ValueError, match="h\\*omega < 2/sqrt"):
        ti.StormerVerlet().coefficients(2.5 / 50.0, [50.0])
    ti.integrate(prob, method, np.zeros(2), np.zeros(2), h=0.99 * limit / 50.0, n_steps=3)


def test_unknown_filter_lists_valid_names():
    with pytest.raises(ValueError, match="valid names are A, B, C, D, E, gautschi, deuflhard"):
        ti.Trigonometric("Z")
    with pytest.raises(ValueError, match="imex"):
        ti.integrate(ti.problems.fpu(1, 10.0), "nonsense", np.zeros(2), np.zeros(2), h=0.1, n_steps=1)
    with pytest.raises(TypeError, match="method"):
        ti.integrate(ti.problems.fpu(1, 10.0), 3, np.zeros(2), np.zeros(2), h=0.1, n_steps=1)


def test_bad_filters():
    with pytest.raises(ValueError, match=r"psi\(0\) = 1"):
        ti.Trigonometric(psi=lambda x: 2 + 0 * x, phi=None)
    with pytest.raises(ValueError, match="not both"):
        ti.Trigonometric("B", psi=ti.sinc)
    with pytest.raises(TypeError, match="phi"):
        ti.Trigonometric(psi=ti.sinc, phi=3)
    with pytest.raises(ValueError, match="chi"):
        ti.ModifiedTrigonometric(lambda x: x, chi="unknown")


def test_bad_polynomials():
    with pytest.raises(ValueError, match="exponents"):
        ti.PolynomialPotential([1.0, 2.0], [[1, 0]])
    with pytest.raises(ValueError, match="non-negative"):
        ti.PolynomialPotential([1.0], [[-1]])
    import sympy as sp

    x, y = sp.symbols("x y")
    with pytest.raises(ValueError, match="not a polynomial"):
        ti.PolynomialPotential.from_sympy(sp.sin(x), [x])
    with pytest.raises(ValueError, match="not coordinates"):
        ti.PolynomialPotential.from_sympy(x * y, [x])


def test_bad_blocks():
    pot = ti.PolynomialPotential([1.0], [[2, 0, 0]])
    with pytest.raises(ValueError, match="label 0"):
        ti.OscillatoryProblem([0.0, 1.0, 1.0], pot, blocks=[0, 0, 1])
    with pytest.raises(ValueError, match="none skipped"):
        ti.OscillatoryProblem([0.0, 1.0, 1.0], pot, blocks=[0, 1, 3])


def test_bad_form(setup):
    prob, m, q0, p0 = setup
    with pytest.raises(ValueError, match="form"):
        ti.integrate(prob, m, q0, p0, h=0.01, n_steps=3, form="three-step")


def test_near_resonant_step_size_warns_and_names_the_coordinate(setup):
    """hω ≈ π: κ = |sin(hω)| ≈ 4e-9, far below √h; the paper's (3.2) fails and the run says so."""
    prob, m, q0, p0 = setup
    with pytest.warns(RuntimeWarning, match=r"numerical resonance: h\*omega\[3\] = 3\.14159265 is 3\.59e-09 from 1\*pi"
                                            r".*\(3\.2\)"):
        sol = ti.integrate(prob, m, q0, p0, h=3.14159265 / 50, n_steps=2000)
    assert sol.max_deviation["oscillatory"] > 1.0  # what the warning is about: H_ω is not kept
    # the modified frequency counts for modified methods: IMEX at hω = √12 has hω̃ = 2π/3, no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ti.integrate(prob, "imex", q0, p0, h=np.sqrt(12) / 50, n_steps=100)
        ti.integrate(prob, m, q0, p0, h=2 * np.pi / 3 / 50, n_steps=100)  # the paper's hω = 2π/3
        ti.integrate(prob, m, q0, p0, h=np.pi / 2 / 50, n_steps=100)  # κ = 1


@pytest.mark.parametrize(("h_omega", "omega", "warns"), [
    (np.pi - 0.05, 50.0, True),     # h = 0.062, √h = 0.25: |sin| = 0.05 < 0.1
    (np.pi - 0.2, 50.0, False),     # |sin| = 0.199: above the cap 0.1
    (2 * np.pi + 0.02, 300.0, True),  # near 2π, h = 0.021: |sin| = 0.02 < min(√h, 0.1)
    (np.pi - 0.05, 5000.0, False),  # h = 6.2e-4: |sin| = 0.05 is above √h = 0.025, (3.2) holds
    (0.05, 50.0, False),            # near 0: not a numerical resonance
])
def test_resonance_warning_threshold(h_omega, omega, warns):
    h = h_omega / omega
    prob = ti.OscillatoryProblem([omega], ti.PolynomialPotential([0.0], [[2]]))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ti.integrate(prob, "B", [0.01], [0.0], h=h, n_steps=10)
    assert any("numerical resonance" in str(w.message) for w in caught) == warns
