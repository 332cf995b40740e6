import numpy as np
import pytest

import trigint as ti

#: every method family, built fresh for each test
ALL_METHODS = {
    "A": lambda: ti.Trigonometric("A"),
    "B": lambda: ti.Trigonometric("B"),
    "C": lambda: ti.Trigonometric("C"),
    "D": lambda: ti.Trigonometric("D"),
    "E": lambda: ti.Trigonometric("E"),
    "custom": lambda: ti.Trigonometric(psi=lambda x: ti.sinc(x) ** 3, phi=lambda x: np.cos(x / 3)),
    "stormer-verlet": ti.StormerVerlet,
    "imex": ti.IMEX,
    "alpha=0.1": lambda: ti.AlphaMethod(0.1),
    "alpha=0.4": lambda: ti.AlphaMethod(0.4),
    "mclachlan-stern": lambda: ti.ModifiedTrigonometric(
        lambda x: 2 * np.arctan(x / 2), chi="mclachlan-stern", psi=lambda x: ti.sinc(x) ** 2
    ),
}


@pytest.fixture(params=sorted(ALL_METHODS))
def method(request):
    return ALL_METHODS[request.param]()


@pytest.fixture
def fpu():
    prob = ti.problems.fpu(m=3, omega=50.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
    return prob, q0, p0
