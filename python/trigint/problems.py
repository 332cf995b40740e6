"""The problems of the paper's experiments (§4), ready to integrate.

- :func:`fpu`: alternating stiff and soft springs [GNI §I.5] (Experiment 2, Figures 2–4);
- :func:`experiment1`: one degree of freedom, U(q) = q³ + q⁴ (Figure 1);
- :func:`experiment3`: two frequencies ω and √2ω, U = 0.01 q₁q₂ (Figure 5);
- :func:`wave`: a semilinear wave equation on the torus, spectrally discretized.

Each has an ``*_initial`` companion returning the paper's initial values ``(q0, p0)``.
"""

from __future__ import annotations

import numpy as np

from . import _check
from .potentials import FPUPotential, PolynomialPotential, fpu_original_basis
from .problem import OscillatoryProblem
from .wave import wave as wave  # re-exported: ti.problems.wave


def _positive(x, name: str) -> float:
    x = _check.real(x, name, finite=False)
    if not np.isfinite(x) or x <= 0:
        raise ValueError(f"{name}: must be finite and > 0, got {x}")
    return x


def fpu(m: int = 3, omega: float = 50.0, coordinates: str = "diagonal") -> OscillatoryProblem:
    """FPU chain with m stiff springs of frequency ω [GNI §I.5].

    ``coordinates="diagonal"`` (default): x = (x₀,₁ … x₀,ₘ, x₁,₁ … x₁,ₘ), where
    x₀,ᵢ = (q₂ᵢ + q₂ᵢ₋₁)/√2 are slow and the elongations x₁,ᵢ = (q₂ᵢ − q₂ᵢ₋₁)/√2 oscillate
    with frequency ω: Ω = diag(0, …, 0, ω, …, ω).

    ``coordinates="original"``: the positions q₁ … q₂ₘ of the 2m particles, with the
    Hamiltonian ½|p|² + (ω²/4) Σᵢ (q₂ᵢ − q₂ᵢ₋₁)² + Σᵢ₌₀^m (q₂ᵢ₊₁ − q₂ᵢ)⁴ (q₀ = q₂ₘ₊₁ = 0):
    the stiff springs give the stiffness matrix A with 2×2 blocks (ω²/2)[[1, −1], [−1, 1]].

    The potential is native in both.

    Parameters
    ----------
    m : int
        The number of stiff springs (2m particles, 2m coordinates).
    omega : float
        The stiff frequency ω > 0.
    coordinates : {"diagonal", "original"}
        The modal coordinates x, or the particles' positions q.

    Examples
    --------
    >>> import trigint as ti
    >>> ti.problems.fpu(m=3, omega=50.0).omega.tolist()
    [0.0, 0.0, 0.0, 50.0, 50.0, 50.0]
    >>> ti.problems.fpu(m=3, omega=50.0, coordinates="original").frequencies.multiplicities.tolist()
    [3]
    """
    coordinates = _coordinates(coordinates)
    pot = FPUPotential(m, coordinates=coordinates)
    omega = _positive(omega, "omega")
    if coordinates == "original":
        return OscillatoryProblem(stiffness=fpu_stiffness(pot.m, omega), potential=pot)
    return OscillatoryProblem(np.r_[np.zeros(pot.m), np.full(pot.m, omega)], pot)


def fpu_stiffness(m: int, omega: float) -> np.ndarray:
    """A of the FPU chain in the original coordinates q₁ … q₂ₘ: ½qᵀAq = (ω²/4) Σᵢ (q₂ᵢ − q₂ᵢ₋₁)².

    Parameters
    ----------
    m : int
        The number of stiff springs (2m particles, 2m coordinates).
    omega : float
        The stiff frequency ω > 0.

    Returns
    -------
    array of shape (2m, 2m)
    """
    m = _check.integer(m, "m", low=1)
    _check.dense_matrix(2 * m, "m")
    a = np.zeros((2 * m, 2 * m))
    for i in range(m):
        a[2 * i:2 * i + 2, 2 * i:2 * i + 2] = 0.5 * omega**2 * np.array([[1.0, -1.0], [-1.0, 1.0]])
    return a


def fpu_initial(m: int = 3, omega: float = 50.0, coordinates: str = "diagonal") -> tuple[np.ndarray, np.ndarray]:
    """The standard initial data [GNI §I.5]: x₀,₁ = 1, y₀,₁ = 1, x₁,₁ = 1/ω, y₁,₁ = 1, others 0,
    in the coordinates of :func:`fpu` (``"original"``: q = Tx, p = Ty with q₂ᵢ₋₁ = (x₀,ᵢ − x₁,ᵢ)/√2,
    q₂ᵢ = (x₀,ᵢ + x₁,ᵢ)/√2).

    With ω = 50: H = 2.00120008 and H_ω = 1.

    Parameters
    ----------
    m : int
        The number of stiff springs (2m particles, 2m coordinates).
    omega : float
        The stiff frequency ω > 0.
    coordinates : {"diagonal", "original"}
        The modal coordinates x, or the particles' positions q.

    Returns
    -------
    q0, p0 : arrays of shape (2m,)

    Examples
    --------
    >>> import trigint as ti
    >>> q0, p0 = ti.problems.fpu_initial(m=1, omega=50.0)
    >>> q0.tolist(), p0.tolist()
    ([1.0, 0.02], [1.0, 1.0])
    """
    coordinates = _coordinates(coordinates)
    m = FPUPotential(m).m
    omega = _positive(omega, "omega")
    q0, p0 = np.zeros(2 * m), np.zeros(2 * m)
    q0[0], p0[0] = 1.0, 1.0
    q0[m], p0[m] = 1.0 / omega, 1.0
    if coordinates == "original":
        t = fpu_original_basis(m)
        return t @ q0, t @ p0
    return q0, p0


def _coordinates(value) -> str:
    if not isinstance(value, str) or value not in ("diagonal", "original"):
        raise ValueError(f"coordinates: expected 'diagonal' or 'original', got {value!r}")
    return value


def experiment1(omega: float = 100.0) -> OscillatoryProblem:
    """Experiment 1: q'' + ω²q = −U'(q) with U(q) = q³ + q⁴, one coordinate of frequency ω.

    Parameters
    ----------
    omega : float
        The frequency ω > 0 (default 100, the paper's).

    Examples
    --------
    >>> import trigint as ti
    >>> ti.problems.experiment1(100.0).omega.tolist()
    [100.0]
    """
    return OscillatoryProblem([_positive(omega, "omega")], PolynomialPotential([1.0, 1.0], [[3], [4]]))


def experiment1_initial(omega: float = 100.0) -> tuple[np.ndarray, np.ndarray]:
    """The initial values of Experiment 1: q(0) = 0.1/ω, q'(0) = 1.

    Parameters
    ----------
    omega : float
        The frequency ω > 0 (default 100, the paper's).

    Returns
    -------
    q0, p0 : arrays of shape (1,)

    Examples
    --------
    >>> import trigint as ti
    >>> [x.tolist() for x in ti.problems.experiment1_initial(100.0)]
    [[0.001], [1.0]]
    """
    return np.array([0.1 / _positive(omega, "omega")]), np.array([1.0])


def experiment3(omega: float = 200.0) -> OscillatoryProblem:
    """Experiment 3: coordinates (q₀, q₁, q₂) with frequencies (0, ω, √2ω), U = 0.01 q₁q₂.

    Parameters
    ----------
    omega : float
        ω, the smaller frequency, > 0 (default 200, the paper's).

    Examples
    --------
    >>> import trigint as ti
    >>> ti.problems.experiment3(100.0).block_frequencies.round(6).tolist()
    [100.0, 141.421356]
    """
    omega = _positive(omega, "omega")
    return OscillatoryProblem([0.0, omega, np.sqrt(2.0) * omega], PolynomialPotential([0.01], [[0, 1, 1]]))


def experiment3_initial(omega: float = 200.0) -> tuple[np.ndarray, np.ndarray]:
    """The initial values of Experiment 3: q(0) = (0, 0.3ε, 0.8ε), q'(0) = (0, 0.6, 0.7), ε = 1/ω.

    Parameters
    ----------
    omega : float
        ω, the smaller frequency, > 0 (default 200, the paper's).

    Returns
    -------
    q0, p0 : arrays of shape (3,)

    Examples
    --------
    >>> import trigint as ti
    >>> [x.tolist() for x in ti.problems.experiment3_initial(100.0)]
    [[0.0, 0.003, 0.008], [0.0, 0.6, 0.7]]
    """
    eps = 1.0 / _positive(omega, "omega")
    return np.array([0.0, 0.3 * eps, 0.8 * eps]), np.array([0.0, 0.6, 0.7])


def experiment3_step(omega: float = 200.0) -> float:
    """The paper's step size h = 2π/(ω₁ + ω₂), resonant at k = (1, 1), r = 1.

    Parameters
    ----------
    omega : float
        ω = ω₁, the smaller frequency, > 0 (default 200, the paper's).

    Examples
    --------
    >>> import numpy as np, trigint as ti
    >>> h = ti.problems.experiment3_step(100.0)
    >>> round(float(h * (100.0 + 100.0 * np.sqrt(2)) / (2 * np.pi)), 12)  # h(ω₁ + ω₂) = 2π
    1.0
    """
    omega = _positive(omega, "omega")
    return 2.0 * np.pi / (omega + np.sqrt(2.0) * omega)
