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


#: The first lines of every child script that is sent Ctrl-C. A process started with SIGINT
#: ignored (``make test &`` from a script: a background job of a non-interactive shell) passes
#: SIG_IGN on to its children, and Python then installs no KeyboardInterrupt handler, so the
#: child would never see the signal. The child restores Python's default handler itself.
SIGINT_DEFAULT = "import signal\nsignal.signal(signal.SIGINT, signal.default_int_handler)\n"


def with_default_sigint(script: str) -> str:
    """`script` (Python source) preceded by :data:`SIGINT_DEFAULT`."""
    return SIGINT_DEFAULT + script
