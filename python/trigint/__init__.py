"""trigint: long-time integration of highly oscillatory Hamiltonian systems.

q'' + Ω²q = −∇U(q) by trigonometric and modified trigonometric integrators, after
D. Cohen, L. Gauckler, E. Hairer, Ch. Lubich, *Long-term analysis of numerical integrators
for oscillatory Hamiltonian systems under minimal non-resonance conditions*, BIT 55 (2015).

>>> import numpy as np, trigint as ti
>>> prob = ti.problems.fpu(m=3, omega=50.0)
>>> q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
>>> sol = ti.integrate(prob, ti.Trigonometric("B"), q0, p0, h=2*np.pi/3/50, t_end=30.0)
>>> sol.status
'completed'
"""

from . import problems, resonance
from ._config import show_config
from ._filters import sinc
from ._stiffness import Frequencies
from ._store import StoreError
from .energies import energies
from .ensemble import ensemble, perturb, scan
from .integrate import integrate
from .lyapunov import LyapunovResult, lyapunov, tangent_map
from .methods import (
    IMEX,
    AlphaMethod,
    Coefficients,
    Method,
    ModifiedTrigonometric,
    StormerVerlet,
    Trigonometric,
)
from .potentials import (
    ChainPotential,
    ExpressionPotential,
    FPUPotential,
    PolynomialPotential,
    Potential,
    PythonPotential,
)
from .problem import OscillatoryProblem
from .saveat import SaveAt
from .solution import Solution
from .wave import WaveProblem

__version__ = "0.1.0"

__all__ = [
    "IMEX",
    "AlphaMethod",
    "LyapunovResult",
    "ChainPotential",
    "Coefficients",
    "ExpressionPotential",
    "FPUPotential",
    "Frequencies",
    "Method",
    "ModifiedTrigonometric",
    "OscillatoryProblem",
    "PolynomialPotential",
    "Potential",
    "PythonPotential",
    "SaveAt",
    "WaveProblem",
    "Solution",
    "StoreError",
    "StormerVerlet",
    "Trigonometric",
    "energies",
    "ensemble",
    "integrate",
    "lyapunov",
    "perturb",
    "problems",
    "resonance",
    "scan",
    "show_config",
    "sinc",
    "tangent_map",
]
