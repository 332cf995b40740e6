"""Symplecticity: the Jacobian M of one step satisfies MᵀJM = J exactly when ψ = χφ."""

import numpy as np
import pytest

import trigint as ti
from trigint._method_names import resolve_method

# Two oscillatory degrees of freedom, hω ≈ 1.5 and 1.2, coupled by a quadratic potential, so
# that one step is a linear map and its columns are the images of the unit vectors.
OMEGA = np.array([15.0, 12.0])
H = 0.1
PROBLEM = ti.OscillatoryProblem(OMEGA, ti.PolynomialPotential([0.3, 0.2, -0.1], [[1, 1], [2, 0], [0, 2]]))
J = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.eye(2), np.zeros((2, 2))]])


def jacobian(method, form):
    columns = []
    for e in np.eye(4):
        sol = ti.integrate(PROBLEM, method, e[:2], e[2:], h=H, n_steps=1, form=form)
        columns.append(np.r_[sol.q[-1], sol.p[-1]])
    return np.array(columns).T


def symplecticity_defect(method, form) -> float:
    M = jacobian(method, form)
    return float(np.max(np.abs(M.T @ J @ M - J)))


@pytest.mark.parametrize("form", ["two-step", "one-step"])
@pytest.mark.parametrize("method", ["B", "C", "stormer-verlet", "imex"])
def test_symplectic_methods(method, form):
    m = resolve_method(method)
    assert m.is_symplectic(H, OMEGA)
    assert symplecticity_defect(m, form) < 1e-10


@pytest.mark.parametrize("form", ["two-step", "one-step"])
@pytest.mark.parametrize("method", ["A", "D", "E"])
def test_non_symplectic_methods(method, form):
    m = ti.Trigonometric(method)
    assert not m.is_symplectic(H, OMEGA)
    assert symplecticity_defect(m, form) > 1e-4


def test_alpha_family_is_symplectic():
    for alpha in (0.1, 0.4, 2.0):
        m = ti.AlphaMethod(alpha)
        assert m.is_symplectic(H, OMEGA)
        assert symplecticity_defect(m, "two-step") < 1e-10
