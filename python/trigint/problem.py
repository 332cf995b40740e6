"""The problem class q'' + Ω²q = −∇U(q) (paper §2.1): Ω diagonal, or Ω² = A any symmetric
positive semi-definite stiffness matrix."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from . import _check, _native, _stiffness
from ._steppers import KRYLOV, RECURSION
from ._stiffness import Frequencies
from .potentials import Potential


class OscillatoryProblem:
    """q'' + Ω²q = g(q) = −∇U(q) with Ω = diag(ω₁ … ωₙ), or q'' + Aq = g(q) with A symmetric
    positive semi-definite.

    **Diagonal** (``omega=``): ωᵢ ≥ 0 is the frequency of coordinate i (0: slow). Coordinates
    are grouped in blocks: block 0 holds the slow coordinates and blocks 1 … ℓ the coordinates
    of each distinct non-zero frequency, in order of first appearance (paper §2.1,
    q = (q₀, q₁, …, q_ℓ)). `blocks=` overrides the grouping.

    **Stiffness matrix** (``stiffness=A``): A = QΛQᵀ is diagonalized once; the frequencies are
    ω_j = √λ_j, with eigenvalues within `slow_tolerance` (relative to the largest) of 0 slow and
    eigenvalues within `equal_tolerance` (relative) of each other one block of equal frequency,
    in increasing order. Every method steps the modal coordinates x = Qᵀq, which is the same
    recursion with its filters as matrix functions of h√A; everything the user gives and gets
    (q0, p0, samples, energies, the potential's argument) stays in the coordinates of A.
    `omega`, `blocks` and `dim` then describe the modal coordinates, `basis` is Q.

    Parameters
    ----------
    omega : array of float, shape (n,), optional
        The frequency of each coordinate. Give this or `stiffness`.
    potential : Potential
        U(q), acting on n coordinates.
    stiffness : array of shape (n, n) or scipy.sparse matrix, optional
        A, symmetric positive semi-definite, n up to 5000.
    blocks : array of int, shape (n,), optional
        (Diagonal only) block label of each coordinate: 0 for every slow coordinate (and only
        those), 1 … ℓ for the oscillatory ones, each label used, the coordinates of one label
        all of one frequency (a frequency may be split over several blocks, each with its own
        energy I_j; a block of two frequencies is refused).
    slow_tolerance, equal_tolerance : float
        (Stiffness only) the relative tolerances above, default 1e-10 each.
    path : {"auto", "dense", "krylov"}
        (Stiffness only) how A is applied. ``"dense"`` diagonalizes A once (n up to 5000) and
        runs every kernel, ensembles included; ``"krylov"`` never forms an n × n matrix and
        applies each matrix function of h√A by the Lanczos method in the core (one-step form;
        ``integrate()``, ``ensemble()``, and ``scan()`` with ``omega_ref``). ``"auto"``: Krylov
        for a ``scipy.sparse`` A with n > 5000, dense otherwise.
    krylov_tolerance : float
        (Krylov path) a Lanczos iteration for f(h√A)v stops when its a posteriori error
        estimate β_k |e_kᵀ f(h√T_k) e₁| is below this times |f(h√T_k) e₁|, for every function
        f taken from the basis; at least 1e-15.

    Attributes
    ----------
    omega, blocks : array
        The frequency and the block label of each coordinate (of each modal coordinate with a
        stiffness matrix; None on the Krylov path).
    potential : Potential
        U.
    stiffness : array, scipy.sparse matrix or None
        A, read-only (None for a diagonal Ω).
    basis : array or None
        Q with A = QΛQᵀ on the dense path (None otherwise).
    path : str
        ``"diagonal"``, ``"dense"`` or ``"krylov"``.

    Examples
    --------
    >>> import numpy as np, trigint as ti
    >>> prob = ti.OscillatoryProblem([0.0, 50.0, 50.0 * 2**0.5],
    ...                              ti.PolynomialPotential([0.01], [[0, 1, 1]]))
    >>> prob.block_frequencies
    array([50.        , 70.71067812])

    Two particles joined by a stiff spring (A = ω²/2 [[1, −1], [−1, 1]]), held by soft springs:

    >>> A = 1250.0 * np.array([[1.0, -1.0], [-1.0, 1.0]])
    >>> U = ti.ExpressionPotential("(q0**2 + q1**2) / 2", ["q0", "q1"])
    >>> ti.OscillatoryProblem(stiffness=A, potential=U).frequencies
    Frequencies(slow=1, [50 (x1)], max_relative_change=0.00e+00, largest_zeroed=0.00e+00)
    """

    def __init__(self, omega=None, potential: Potential | None = None, *, stiffness=None, blocks=None,
                 slow_tolerance: float = _stiffness.SLOW_TOLERANCE,
                 equal_tolerance: float = _stiffness.EQUAL_TOLERANCE, path: str = "auto",
                 krylov_tolerance: float = 1e-12):
        if (omega is None) == (stiffness is None):
            raise ValueError("omega, stiffness: give exactly one of them (the frequencies of a diagonal "
                             "problem, or a symmetric positive semi-definite stiffness matrix A)")
        if potential is None:
            raise TypeError("potential: a trigint potential U(q) is required")
        self.stiffness = None
        self.basis = None
        self.coordinate_map = None
        self.frequencies_found = None
        self.path = "diagonal"
        self.stepper = RECURSION  # how the steps are taken (trigint._steppers)
        if stiffness is not None:
            if blocks is not None:
                raise ValueError("blocks: not allowed with stiffness=; the blocks are A's eigenspaces")
            if not isinstance(path, str) or path not in ("auto", "dense", "krylov"):
                raise ValueError(f"path: expected 'auto', 'dense' or 'krylov', got {path!r}")
            slow_tolerance = _stiffness.check_tolerance(slow_tolerance, "slow_tolerance")
            equal_tolerance = _stiffness.check_tolerance(equal_tolerance, "equal_tolerance")
            krylov_tolerance = _stiffness.check_tolerance(krylov_tolerance, "krylov_tolerance")
            if krylov_tolerance < 1e-15:
                raise ValueError(f"krylov_tolerance: at least 1e-15 (rounding), got {krylov_tolerance!r}")
            krylov = path == "krylov" or (path == "auto" and _stiffness.is_sparse(stiffness)
                                          and stiffness.shape[0] > _stiffness.DENSE_MAX)
            if krylov:
                self.stiffness = _stiffness.sparse_stiffness(stiffness)
                _check_potential(potential, self.stiffness.shape[0])
                self.krylov_tolerance = krylov_tolerance
                self.path, self.potential, self._n = "krylov", potential, self.stiffness.shape[0]
                self.stepper = KRYLOV
                self.omega = self.blocks = None
                return
            self.path = "dense"
            a = _stiffness.dense_stiffness(stiffness)
            _check_potential(potential, a.shape[0])
            own = potential.own_coordinates()
            modal = _stiffness.diagonalize(a, slow_tolerance, equal_tolerance, None if own is None else own[0])
            a.setflags(write=False)
            self.stiffness, self.basis = a, modal.basis
            self.omega, self.blocks, self.potential = modal.omega, modal.blocks, potential
            self.frequencies_found = modal.frequencies
            self._n = self.omega.size
            return
        omega = _check.real_array(omega, "omega", ndim=None, finite=False, nonempty=False)
        if omega.ndim != 1 or omega.size == 0:
            raise ValueError(f"omega: expected a 1-d array of n >= 1 frequencies, got shape {omega.shape}")
        if not np.all(np.isfinite(omega)):
            bad = int(np.flatnonzero(~np.isfinite(omega))[0])
            raise ValueError(f"omega: frequencies must be finite; omega[{bad}] = {omega[bad]}")
        if np.any(omega > 1e150):
            bad = int(np.flatnonzero(omega > 1e150)[0])
            raise ValueError(f"omega: omega[{bad}] = {omega[bad]:g} is too large: the energies need omega**2, "
                             "which must stay finite; frequencies up to 1e150 are allowed")
        if np.any(omega < 0):
            bad = int(np.flatnonzero(omega < 0)[0])
            raise ValueError(f"omega: frequencies must be >= 0; omega[{bad}] = {omega[bad]}")
        _check_potential(potential, omega.size)
        self.omega = omega
        self._n = omega.size
        self.omega.setflags(write=False)
        self.potential = potential
        self.blocks = _check_blocks(blocks, omega) if blocks is not None else _group(omega)
        self.blocks.setflags(write=False)

    @property
    def dim(self) -> int:
        """Number of coordinates n."""
        return self._n

    #: per-axis channels streamed besides the energies (a wave problem's momentum): their
    #: number, and the pair form in the core's coordinates ({"a", "b", "weights"}) or None
    n_axes: int = 0
    pair_forms: dict | None = None

    def as_state(self, x, name: str):
        """A state as the kernels take it: here unchanged (a wave problem flattens grid values).
        None, and a single number where a state has several coordinates, are refused as what
        they are (not as an array of shape (1,) that they would become).

        Parameters
        ----------
        x : array
            One state (n,) or a batch of them.
        name : str
            The argument's name, for error messages.
        """
        if x is None:
            raise TypeError(f"{name}: expected an array of {self.dim} floats (one value per coordinate), got None")
        if self.dim != 1 and np.ndim(x) == 0 and not isinstance(x, str | bytes | dict):
            try:
                shown = repr(bool(x) if isinstance(x, bool | np.bool_) else float(x))
            except (TypeError, ValueError, OverflowError):
                shown = _check.shown(x)
            raise ValueError(f"{name}: expected an array of {self.dim} floats (one value per coordinate), got a "
                             f"single number {shown}")
        return x

    def energy_dataset(self, names: Sequence[str], energies: np.ndarray, coords: dict, attrs: dict):
        """The energies at the samples as an xarray Dataset, one variable per channel over ``t``.

        Parameters
        ----------
        names : sequence of str
            The channels, in the order of the columns of `energies`.
        energies : array, shape (samples, channels)
            The streamed energies at the samples.
        coords, attrs : dict
            The Dataset's coordinates (``t``, ``step``) and attributes.
        """
        import xarray as xr

        return xr.Dataset({name: ("t", energies[:, k]) for k, name in enumerate(names)}, coords=coords,
                          attrs=attrs)

    def ensemble_dataset(self, ds):
        """An ensemble's Dataset as the problem presents it: here unchanged (a wave problem adds
        its actions over modes).

        Parameters
        ----------
        ds : xarray.Dataset
            What :func:`trigint.ensemble` assembled.
        """
        return ds

    def require_spectrum(self, what: str) -> None:
        """Raises ValueError for a problem on the Krylov path, whose eigenvectors are never formed.

        Parameters
        ----------
        what : str
            The name of what needs the spectrum, for the message.
        """
        if not self.stepper.has_spectrum:
            raise ValueError(f"{what}: not available for a stiffness matrix on the Krylov path (n = {self.dim}), "
                             "whose eigenvalues and eigenvectors are never computed; use trigint.integrate, "
                             "or path='dense' for n up to 5000")

    @property
    def frequencies(self) -> Frequencies:
        """The distinct non-zero frequencies with their multiplicities (and, for a stiffness
        matrix, the largest relative change that grouping eigenvalues made)."""
        self.require_spectrum("frequencies")
        if self.frequencies_found is not None:
            return self.frequencies_found
        counts = np.bincount(self.blocks, minlength=self.n_blocks + 1)[1:].astype(np.int64)
        return Frequencies(self.block_frequencies, counts, int(np.count_nonzero(self.blocks == 0)))

    @property
    def n_blocks(self) -> int:
        """ℓ, the number of oscillatory blocks (1 on the Krylov path, where H_ω is one sum)."""
        if self.blocks is None:
            return 1
        # Kept with the (read-only) array it was read from: a 2¹⁶-point wave problem's blocks
        # took 0.1 ms to scan, twice a call.
        return _native.kept_on(self, "_n_blocks_kept", id(self.blocks), self.blocks,
                               lambda: int(self.blocks.max(initial=0)))

    @property
    def block_frequencies(self) -> np.ndarray:
        """The frequency ω_j of each block j = 1 … ℓ."""
        self.require_spectrum("block_frequencies")
        labels, first = np.unique(self.blocks, return_index=True)
        return np.asarray(self.omega[first[labels > 0]], dtype=float)

    @property
    def epsilon(self) -> float:
        """ε = 1 / min_j ω_j over the non-zero frequencies (inf if there are none)."""
        self.require_spectrum("epsilon")
        fast = self.omega[self.omega > 0]
        return float(1.0 / fast.min()) if fast.size else float("inf")

    #: what calls keep on a problem for the next call (the core's layout and methods, the
    #: coefficients, the resonance check's mode index): keyed by objects' ids, so worthless in
    #: another process, and on a 2¹⁶-point wave tens of MB that a pickle (an ensemble's task)
    #: would carry
    KEPT_FOR_CALLS = ("_core_layout", "_core_methods", "_coefficients_kept", "_modified_finite",
                      "_n_blocks_kept", "_mode_index", "_mode_list")

    def __getstate__(self) -> dict:
        """The problem without what its calls kept (:data:`KEPT_FOR_CALLS`): a used problem
        pickles as a fresh one does, and its next call makes them again."""
        return {k: v for k, v in self.__dict__.items() if k not in self.KEPT_FOR_CALLS}

    def __repr__(self) -> str:
        if not self.stepper.has_spectrum:
            return (f"OscillatoryProblem(n={self.dim}, sparse stiffness matrix with {self.stiffness.nnz} entries, "
                    f"Krylov path (tolerance {self.krylov_tolerance:g}), potential={self.potential!r})")
        if self.stiffness is not None:
            f = self.frequencies
            return (f"OscillatoryProblem(n={self.dim}, stiffness matrix: {f.slow} slow, "
                    f"{f.values.size} distinct frequenc{'y' if f.values.size == 1 else 'ies'} [{f.listing()}], "
                    f"grouping changed them by at most {f.max_relative_change:.1e} (relative), "
                    f"potential={self.potential!r})")
        slow = int(np.count_nonzero(self.omega == 0))
        return (
            f"OscillatoryProblem(n={self.dim}: {slow} slow, {self.dim - slow} oscillatory in {self.n_blocks} "
            f"block{'' if self.n_blocks == 1 else 's'} of frequencies "
            f"{np.round(self.block_frequencies, 6).tolist()}, potential={self.potential!r})"
        )


def _check_potential(potential, n: int) -> None:
    if not isinstance(potential, Potential):
        raise TypeError(
            "potential: expected a trigint potential (FPUPotential, ExpressionPotential, PolynomialPotential, "
            f"ChainPotential, PythonPotential), got {type(potential).__name__}"
        )
    potential.check_dim(n)


def _group(omega: np.ndarray) -> np.ndarray:
    """Block labels: 0 for ω = 0, then 1, 2, … for the distinct non-zero frequencies in order of
    first appearance (sorted once: a problem with 10⁵ distinct frequencies is grouped at once)."""
    blocks = np.zeros(omega.size, dtype=np.int64)
    fast = np.flatnonzero(omega != 0.0)
    if fast.size:
        _, first, inverse = np.unique(omega[fast], return_index=True, return_inverse=True)
        rank = np.empty(first.size, dtype=np.int64)
        rank[np.argsort(first, kind="stable")] = np.arange(first.size)
        blocks[fast] = rank[inverse.reshape(-1)] + 1
    return blocks


def _check_blocks(blocks, omega: np.ndarray) -> np.ndarray:
    b = np.asarray(blocks)
    if b.shape != omega.shape or b.dtype.kind not in "iu":
        raise ValueError(f"blocks: expected {omega.size} integer labels, got {b.dtype} array of shape {b.shape}")
    b = b.astype(np.int64)
    if np.any(b < 0):
        bad = int(np.flatnonzero(b < 0)[0])
        raise ValueError(f"blocks: labels are 0 (slow) or 1, 2, ..., l (oscillatory); blocks[{bad}] = {b[bad]}")
    if np.any((b == 0) != (omega == 0)):
        raise ValueError("blocks: label 0 is for the slow coordinates (omega == 0), and only for them")
    fast = np.flatnonzero(b > 0)
    # the oscillatory coordinates by label; labels already in order (a wave problem's 16.8
    # million on a 256³ grid) need no sort
    labels = b[fast]
    order = fast if np.all(labels[1:] >= labels[:-1]) else fast[np.argsort(labels, kind="stable")]
    sorted_labels = b[order]
    if sorted_labels.size and (sorted_labels[0] != 1 or np.any(np.diff(sorted_labels) > 1)):
        used = np.unique(sorted_labels)
        raise ValueError(f"blocks: oscillatory labels must be 1, 2, ..., l with none skipped, got {used.tolist()}")
    # one frequency per block: sorted by label, neighbours with one label must have one frequency
    mixed = (sorted_labels[1:] == sorted_labels[:-1]) & (omega[order][1:] != omega[order][:-1])
    if mixed.any():
        j = int(sorted_labels[1:][mixed][0])  # the lowest such label
        values = np.unique(omega[b == j])
        raise ValueError(
            f"blocks: block {j} holds the frequencies {values.tolist()}; a block is a group of coordinates "
            "of one frequency (paper §2.1: its energy I_j and its frequency omega_j enter the theory). Give "
            "each frequency its own label (one frequency may be split over several blocks)"
        )
    return b
