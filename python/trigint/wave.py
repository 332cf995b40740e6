"""Semilinear wave equations on the torus, spectrally discretized: u_tt = Δu − ρu − V'(u) on
[0, 2π)^d, d = 1, 2, 3, collocated on the grid x_k = 2πk/n per axis.

In real Fourier coordinates q (N = n^d of them, see :class:`trigint._core.FourierGrid`) this is
q'' + Ω²q = −∇U(q) with Ω = diag(ω_j), ω_j = √(ρ + |j|²) and U(q) = mean_x V(u): the paper's
problem class, so every method of trigint steps it unchanged (Cohen, Hairer, Lubich,
Numer. Math. 110 (2008) 113–143, §2). The core evaluates the force with two FFTs and V by
machine code; states go in and come out as grid values.

Each Fourier mode (a conjugate pair {j, −j}, or a self-conjugate j) is one block of the
problem, so its energy is streamed like the paper's I_j, and the harmonic action of the mode is
that energy over ω_j: J_j = I_j + I_{−j} = (ω_j|û_j|² + |v̂_j|²/ω_j)/2 summed over the pair (a
self-conjugate mode has its own I_j), with û = FFT(u)/N.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from . import _check, _core, _tape
from .potentials import Potential, PythonPotential
from .problem import OscillatoryProblem

if TYPE_CHECKING:  # imported where a Dataset is made, so that `import trigint` loads no xarray (nor pandas)
    import xarray as xr

#: modes kept in ``sol.energies["action"]`` by default: all of them up to this many
ALL_MODES_UP_TO = 256


class WavePotential(Potential):
    """U(q) = mean_x V(u) of the wave problem, in its Fourier coordinates (compiled V)."""

    def __init__(self, shape: tuple[int, ...], tape: dict, order: np.ndarray, text: str):
        self.shape, self.order, self.text = shape, order, text
        self.dim = int(np.prod(shape))
        self._tape = tape

    def describe(self, n: int) -> dict:
        return {"kind": "wave", "shape": list(self.shape), "v": self._tape,
                "order": [int(i) for i in self.order]}

    def __repr__(self) -> str:
        return f"WavePotential(V(u) = {self.text}, grid {self.shape})"


def _python_potential(functions: tuple, fmap) -> PythonPotential:
    """U and ∇U = (1/N) Sᵀ V'(u) for callables V, V' (and V'', for the tangent map) on grid
    arrays, through the core's FFTs (`fmap` the problem's ``_core.CoordinateMap``)."""
    v, dv = functions[:2]
    d2v = functions[2] if len(functions) == 3 else None

    def grid_rows(q):
        return fmap.to_user(np.asarray(q, dtype=float))

    def value(q):
        u = grid_rows(q)
        return _per_point(v(u), u, "V", 0).mean(axis=1)

    def gradient(q):
        u = grid_rows(q)
        return fmap.to_core(_per_point(dv(u), u, "V'", 1))

    def hessian_vector(q, w):
        # ∇²U(q) w = (1/N) Sᵀ (V''(u) · S w): the gradient's map, linearized
        u = grid_rows(np.reshape(q, (1, -1)))
        return fmap.to_core(_per_point(d2v(u), u, "V''", 2) * grid_rows(np.reshape(w, (1, -1)))).reshape(-1)

    pot = WaveFunctions(value, gradient, vectorized=True, hessian_vector=None if d2v is None else hessian_vector)
    if d2v is None:
        pot.no_second_derivative = NO_SECOND_DERIVATIVE
    return pot


class WaveFunctions(PythonPotential):
    """A wave's potential given as Python functions (V, V') or (V, V', V''): a vectorized
    :class:`~trigint.PythonPotential` of the wave's coordinates that knows, without V'', why the
    tangent map has no second derivative (`no_second_derivative`, said before a run needs it)."""

    no_second_derivative: str | None = None


#: why a wave potential given as (V, V') has no tangent map, and what gives it one
NO_SECOND_DERIVATIVE = (
    "potential: the wave's potential is a pair (V, V') of Python functions, which gives no second derivative "
    "for the tangent map; give V'' too, potential=(V, V', V''), or V as a string or SymPy expression in u "
    "(compiled, exact second derivatives), or allow central differences of V' (finite_differences=True)")


def _per_point(values, u: np.ndarray, name: str, index: int) -> np.ndarray:
    """What V, V' or V'' returned for the grid rows u: one value per grid point (an array of the
    shape of u, or of as many values); anything else refused, naming the function."""
    which = f"{name} (function {index + 1} of the potential tuple)"
    expected = f"it must return one value per grid point, an array of the shape of u, here {u.shape}"
    if values is None:
        raise TypeError(f"potential: {which} returned None; {expected}")
    try:
        a = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"potential: {which} returned {type(values).__name__}, not real numbers; {expected}") from None
    if a.size != u.size:
        got = "a single number" if a.ndim == 0 else f"an array of shape {a.shape}"
        raise ValueError(f"potential: {which} returned {got}; {expected}")
    return a.reshape(u.shape)


class WaveProblem(OscillatoryProblem):
    """The spectral semi-discretization of u_tt = Δu − ρu − V'(u) on the torus (build it with
    :func:`trigint.problems.wave`, which checks and normalizes the arguments).

    The grid values u(x_k) are the coordinates a user sees (initial values, ``sol.u``); inside,
    the real Fourier coefficients are the oscillatory coordinates, with ω_j = √(ρ + |j|²) and one
    block per mode pair {j, −j}, blocks in order of frequency.

    Parameters
    ----------
    shape : tuple of int
        Grid points per axis (1 to 3 axes, each even).
    rho : float
        ρ ≥ 0, the mass term.
    potential : str, sympy.Expr or tuple of callables
        V(u), as for :func:`trigint.problems.wave`: an expression, (V, V') or (V, V', V'').
    params : dict of str → float or None
        Values of the other symbols of `potential`.
    variable : str
        The name of u in `potential`.
    modes : sequence of wavevectors or None
        The modes whose actions are kept as samples (None: the default of
        :func:`trigint.problems.wave`).

    Examples
    --------
    >>> import trigint as ti
    >>> prob = ti.problems.wave((8, 8), rho=1.0, potential="u**4 / 4")
    >>> isinstance(prob, ti.WaveProblem), prob.dim, prob.modes[:3].tolist()
    (True, 64, [[0, 0], [0, 1], [1, 0]])

    Attributes
    ----------
    shape : tuple of int
        Grid points per axis.
    grid : list of arrays
        The grid x_k = 2πk/n of each axis, one 1-D array per axis, in the order of `shape`
        (x, y, z). Grid values of shape `shape` are indexed like
        ``np.meshgrid(*prob.grid, indexing="ij")`` (the first index is x): :attr:`mesh`.
    mesh : list of arrays
        ``np.meshgrid(*grid, indexing="ij")``: the coordinates of every grid point, each of shape
        `shape`, to write initial values as ``u0 = np.cos(x) * np.sin(2 * y)``.
    rho : float
        ρ.
    modes : array of int, shape (ℓ, d)
        The wavevector j of each block (the representative of a pair {j, −j}).
    mode_frequencies : array, shape (ℓ,)
        ω_j of each block.
    action_modes : array of int
        The blocks (0-based) whose actions ``sol.energies["action"]`` holds.
    linear : bool
        Whether V is at most quadratic in u (V' linear): no mode drives another, and runs do not
        warn of resonant combinations.
    """

    def __init__(self, shape: tuple[int, ...], rho: float, potential, params: Mapping | None = None,
                 variable: str = "u", modes=None):
        self.shape = shape
        self.rho = rho
        _check.coordinates(math.prod(int(n) for n in shape), "shape", f"grid points ({' x '.join(map(str, shape))})")
        self.fourier_grid = _core.FourierGrid(list(shape))
        j = np.asarray(self.fourier_grid.wavevectors())
        parts = np.asarray(self.fourier_grid.parts())
        omega = np.sqrt(rho + np.sum(j.astype(float) ** 2, axis=1))
        # one block per mode, modes in order of frequency; a pair's two coordinates together
        first = parts != 2
        mode_of = np.cumsum(first) - 1
        mode_omega = omega[first]
        rank = np.empty(mode_omega.size, dtype=np.int64)
        rank[np.argsort(mode_omega, kind="stable")] = np.arange(mode_omega.size)
        slow = mode_omega == 0.0
        label = rank - np.count_nonzero(slow) + 1
        label[slow] = 0
        blocks_canonical = label[mode_of]
        order = np.lexsort((np.arange(j.shape[0]), blocks_canonical))
        # the grid values ⇄ Fourier coordinates in the core's order, one map for the states,
        # the samples and a Python V (the grid's plans shared)
        fourier = _core.CoordinateMap.fourier(self.fourier_grid, order.astype(np.int64))
        self._wavevectors, self._parts = j[order], parts[order]
        self.n_axes = len(shape)
        omega, blocks = omega[order], blocks_canonical[order]
        self.linear = False
        super().__init__(omega, self._potential(potential, params, variable, order, fourier), blocks=blocks)
        self.coordinate_map = fourier
        starts = np.flatnonzero(np.r_[True, self.blocks[1:] != self.blocks[:-1]])
        starts = starts[self.blocks[starts] > 0]
        self.modes = j[order][starts]
        self.mode_frequencies = self.omega[starts]
        self.pair_forms = self._momentum_form()
        self.action_modes = self._action_modes(modes)

    def _potential(self, potential, params, variable, order, fourier):
        if isinstance(potential, tuple) and len(potential) in (2, 3) and all(callable(f) for f in potential):
            return _python_potential(potential, fourier)
        if callable(potential) or isinstance(potential, tuple | list) and any(callable(f) for f in potential):
            raise TypeError("potential: a Python V needs its derivative too: give a tuple (V, V') or (V, V', V''), "
                            "callables on grid arrays, or V as a string or SymPy expression in u")
        (var,) = _tape.symbols([variable], "variable")
        params = _tape.parameters(params)
        expr = _tape.parse(potential, [str(var), *params], "potential")
        tape = _tape.tape(expr, [var], params, "potential", "variable")
        # V at most quadratic in u: V'(u) is linear, no mode drives another, no combination resonates
        self.linear = bool(expr.is_polynomial(var)) and _degree(expr, var) <= 2
        return WavePotential(self.shape, tape, order, str(expr))

    def _momentum_form(self) -> dict:
        """K_m = −mean_x(v ∂_m u) = Σ_pairs j_m (q_a p_b − q_b p_a), a and b the cosine and sine
        coordinates of a mode (the Nyquist component's derivative taken as 0), streamed by the
        core as the channels momentum_1 … momentum_d (0 on a grid of 2 points per axis, which
        has no complex mode)."""
        cos = np.flatnonzero(self._parts == 1)
        j = self._wavevectors[cos].astype(float)
        for axis, n in enumerate(self.shape):
            j[np.abs(j[:, axis]) == n // 2, axis] = 0.0
        return {"a": [int(i) for i in cos], "b": [int(i) + 1 for i in cos],
                "weights": np.ascontiguousarray(j.T.reshape(-1)), "axes": len(self.shape)}

    def _action_modes(self, modes) -> np.ndarray:
        n_modes = self.modes.shape[0]
        if modes is None:
            if n_modes <= ALL_MODES_UP_TO:
                return np.arange(n_modes)
            return np.flatnonzero(np.max(np.abs(self.modes), axis=1) <= 8)
        wanted = _wavevectors(modes, len(self.shape))
        found = []
        for w in wanted:
            hit = np.flatnonzero(np.all(self.modes == w, axis=1) | np.all(self.modes == -w, axis=1))
            if hit.size == 0:
                raise ValueError(f"modes: {w.tolist()} is not a wavevector of the grid {self.shape} "
                                 f"(or its frequency is 0, which has no action)")
            found.append(int(hit[0]))
        return np.array(sorted(set(found)), dtype=np.int64)

    @property
    def grid(self) -> list[np.ndarray]:
        """The grid points x_k = 2πk/n of each axis."""
        return [2 * np.pi * np.arange(n) / n for n in self.shape]

    @property
    def mesh(self) -> list[np.ndarray]:
        """``np.meshgrid(*self.grid, indexing="ij")``: the coordinates x, y, … of every grid point.

        >>> import trigint as ti
        >>> x, y = ti.problems.wave((8, 6), rho=1.0).mesh
        >>> x.shape, float(x[1, 0]), float(y[0, 1])
        ((8, 6), 0.7853981633974483, 1.0471975511965976)
        """
        return np.meshgrid(*self.grid, indexing="ij")

    @property
    def points(self) -> int:
        """N, the number of grid points (= coordinates)."""
        return self._n

    def as_state(self, x, name: str) -> np.ndarray:
        """Grid values of shape (…,) + `shape` as flat states (…, N); flat ones pass unchanged.

        Parameters
        ----------
        x : array
            Grid values, or flat values (…, N).
        name : str
            The argument's name, for errors.
        """
        if isinstance(x, str | bytes | dict) or x is None:
            raise TypeError(f"{name}: expected grid values, an array of shape {self.shape} (or {self._n} flat "
                            f"values), got {type(x).__name__} {_check.shown(x)}")
        a = np.asarray(x)
        d = len(self.shape)
        if a.ndim >= d and a.shape[a.ndim - d:] == self.shape:
            return a.reshape(*a.shape[: a.ndim - d], self._n)
        if a.ndim >= 1 and a.shape[-1] == self._n:
            return a
        raise ValueError(f"{name}: expected grid values of shape {self.shape} (or {self._n} flat values), "
                         f"got shape {a.shape}")

    def fourier(self, u) -> np.ndarray:
        """The real Fourier coordinates (the problem's order) of grid values u.

        Parameters
        ----------
        u : array, shape (…, N) or (…,) + `shape`
            Grid values.
        """
        return self.coordinate_map.to_core(np.asarray(self.as_state(u, "u"), dtype=float))

    def momentum(self, u, v) -> np.ndarray:
        """K = −mean_x(v ∇u) of grid values u, v of shape (…, N) or (…,) + `shape`: one component
        per axis (the last axis of the result), the derivative spectral (the Nyquist
        wavenumber's derivative 0). The form the core streams as ``momentum_1`` ….

        Parameters
        ----------
        u, v : array
            Grid values of the field and its time derivative.
        """
        q, p = self.fourier(u), self.fourier(v)
        f = self.pair_forms
        a, b = np.asarray(f["a"], dtype=np.intp), np.asarray(f["b"], dtype=np.intp)
        w = f["weights"].reshape(len(self.shape), -1)
        return (q[..., a] * p[..., b] - q[..., b] * p[..., a]) @ w.T

    def warn_resonances(self, sol, method, stacklevel: int = 3) -> None:
        """Warns after a run when a mode or a mode combination that carries energy is near a
        numerical resonance at the run's step size (:func:`trigint.resonance.energy_resonances`
        on the initial mode energies); names the modes by wavevector. A resonant mode that
        carries no energy moves none: no warning (a run with hK > π always has such modes).

        Parameters
        ----------
        sol : Solution
            The finished run (its step size, initial mode energies and energy deviation).
        method : Method
            The run's method.
        stacklevel : int
            Passed to :func:`warnings.warn`, to point at the user's call.
        """
        import warnings

        from .resonance.wave import energy_resonances

        if getattr(self, "linear", False):  # V'(u) linear: no mode drives another, nothing to warn of
            return
        channels = sol.initial_energies
        first = channels.position("oscillatory_1")  # the per-mode channels, in block order
        initial = channels.as_array()[first:first + len(self.modes)]  # (read-only; not copied)
        tolerance = min(float(np.sqrt(sol.h)), 0.1)
        found = energy_resonances(self, sol.h, initial, tolerance=tolerance)
        if not found:
            return
        r = found[0]
        what = (f"mode j = {r.modes[0]} with h*omega_j = {sol.h * r.combination:.6g}" if len(r.modes) == 1 else
                "modes j = {}, k = {}, l = {} with h/2*(omega_j {} omega_k {} omega_l) = {:.6g}".format(
                    *r.modes, "+" if r.signs[1] > 0 else "-", "+" if r.signs[2] > 0 else "-",
                    0.5 * sol.h * r.combination))
        total, e0 = sol.max_deviation.get("total", np.nan), abs(sol.initial_energies.get("total", np.nan))
        drift = total / e0 if e0 > 0 else np.nan
        kept = (f"; here the total energy was kept to {drift:.1e} (relative)" if np.isfinite(drift) and drift <= 1e-6
                else f"; here the total energy deviated by {drift:.1e} (relative) and may drift further"
                if np.isfinite(drift) else "")
        more = f" ({len(found) - 1} more)" if len(found) > 1 else ""
        warnings.warn(
            f"numerical resonance of the wave equation: {what} is {r.distance:.3g} (|sin|) from a multiple of pi"
            + ("; that mode carries energy, which the step size may move" if len(r.modes) == 1 else
               f", and it couples modes that carry energy: energy may move into mode {r.affected}")
            + " over long times "
            + f"(Cohen, Hairer, Lubich 2008){kept}. trigint.resonance.energy_resonances(problem, h, mode_energies) "
            f"ranks every such combination{more}; wave_resonances(problem, h) lists them all",
            RuntimeWarning, stacklevel=stacklevel)

    def energy_dataset(self, names: Sequence[str], energies: np.ndarray, coords: dict, attrs: dict) -> xr.Dataset:
        """The wave's energies at the samples: H (``total``), H_ω, ``slow``, H*_ω, the
        ``momentum`` (over ``axis``, streamed) and the ``action`` J_j over (t, mode) for
        `action_modes`.

        Parameters
        ----------
        names : sequence of str
            The channels, in the order of the columns of `energies`.
        energies : array, shape (samples, channels)
            The streamed channels at the samples.
        coords, attrs : dict
            The Dataset's coordinates (``t``, ``step``) and attributes.
        """
        first = names.index("oscillatory_1") if "oscillatory_1" in names else len(names)
        whole = {name: ("t", energies[:, k]) for k, name in enumerate(names[:first]) if not name[-1].isdigit()}
        streamed = [f"momentum_{m + 1}" for m in range(self.n_axes)]
        # the per-axis channels come last (the core's channel table): looked up there, not
        # through the tens of thousands of per-mode names before them
        tail = list(names[len(names) - len(streamed):])
        momentum = {"momentum": (("t", "axis"), np.stack(
            [energies[:, len(names) - len(streamed) + tail.index(k)] for k in streamed], axis=1))} if streamed else {}
        blocks = energies[:, first:][:, self.action_modes]
        actions = blocks / self.mode_frequencies[self.action_modes]
        data = {**whole, **momentum, "action": (("t", "mode"), actions)}
        # axis a (0-based, as NumPy's) is the channel momentum_{a+1} of max_deviation
        axes = {"axis": np.arange(len(self.shape)), **({"channel": ("axis", streamed)} if streamed else {})}
        import xarray as xr

        return xr.Dataset(data, coords={**coords, **self._mode_coords(), **axes}, attrs=attrs)

    def _mode_coords(self) -> dict:
        d = len(self.shape)
        j = self.modes[self.action_modes].reshape(-1, d)
        # the wavenumber j in 1-D (|j| in 2-D/3-D), and the components as j0, j1, j2
        return {"mode": np.arange(self.action_modes.size),
                "wavenumber": ("mode", j[:, 0] if d == 1 else np.sqrt(np.sum(j.astype(float) ** 2, axis=1))),
                **{f"j{a}": ("mode", j[:, a]) for a in range(d)},
                "omega": ("mode", self.mode_frequencies[self.action_modes])}

    def ensemble_dataset(self, ds: xr.Dataset) -> xr.Dataset:
        """An ensemble's Dataset with the actions of `action_modes`: ``action`` over
        (trajectory, sample, mode) when samples were kept, and ``action_max_deviation`` over
        (trajectory, mode).

        Parameters
        ----------
        ds : xarray.Dataset
            What :func:`trigint.ensemble` assembled.
        """
        names = list(ds.energy.values)
        blocks = [names.index(f"oscillatory_{b + 1}") for b in self.action_modes]
        omega = self.mode_frequencies[self.action_modes]
        extra = {"action_max_deviation": (("trajectory", "mode"), ds.max_deviation.values[:, blocks] / omega)}
        if "energies" in ds:
            extra["action"] = (("trajectory", "sample", "mode"), ds.energies.values[..., blocks] / omega)
        return ds.assign(extra).assign_coords(self._mode_coords())

    def __repr__(self) -> str:
        return (f"WaveProblem(grid {self.shape}, rho={self.rho:g}, {self.modes.shape[0]} modes, "
                f"omega from {self.mode_frequencies.min():.4g} to {self.mode_frequencies.max():.4g}, "
                f"potential={self.potential!r})")


def wave(n, rho: float = 1.0, potential="0", *, params: Mapping | None = None, variable: str = "u",
         modes=None) -> WaveProblem:
    """The semilinear wave equation u_tt = Δu − ρu − V'(u) on [0, 2π)^d, spectrally discretized.

    Parameters
    ----------
    n : int or tuple of int
        Grid points: an int for d = 1, a tuple of 2 or 3 for d = 2, 3; each even and ≥ 2.
    rho : float
        ρ ≥ 0 (ρ = 0: the mean of u is a slow coordinate).
    potential : str, sympy.Expr, (callable, callable) or (callable, callable, callable)
        V(u) as an expression in `variable` (and the names in `params`), compiled to machine
        code; or a tuple (V, V') of Python functions of grid arrays (slower: a call per step),
        each taking the grid values u as an array of shape (lanes, N) and returning one value
        per grid point, an array of that shape. A third function V'' gives the exact tangent
        map of :func:`trigint.lyapunov` (without it, ``finite_differences=True`` is needed there).
    params : dict of str → float, optional
        Values of the other symbols of `potential`.
    variable : str
        The name of u in `potential` (default ``"u"``).
    modes : sequence of wavevectors, optional
        The modes whose actions ``sol.energies["action"]`` holds: ints in 1-D, d-tuples
        otherwise. Default: all modes up to 256 of them, else those with every |j_i| ≤ 8. The
        energies of all modes are streamed either way (their maximal deviations in
        ``sol.max_deviation``).

    Examples
    --------
    A weakly nonlinear Klein–Gordon equation (Cohen, Hairer, Lubich 2008, §6):

    >>> import numpy as np, trigint as ti
    >>> prob = ti.problems.wave(32, rho=0.5, potential="u**3 / 3")  # V'(u) = u²: u_tt = u_xx − ρu − u²
    >>> x, = prob.grid
    >>> u0 = 0.01 * (x - np.pi)**2 * np.sin(x)**2; v0 = 0.01 * np.sin(x)
    >>> sol = ti.integrate(prob, "B", u0, v0, h=0.05, n_steps=2000, save_every=1000)
    >>> sol.q.shape  # grid values at t = 0, 50, 100
    (3, 32)
    >>> bool(abs(sol.max_deviation["total"]) < 1e-4 * sol.initial_energies["total"])
    True
    >>> sol.energies["action"].dims
    ('t', 'mode')
    """
    shape = _shape(n)
    rho = _check.real(rho, "rho", nonneg=True)
    return WaveProblem(shape, rho, potential, params, variable, modes)


def _wavevectors(modes, d: int) -> np.ndarray:
    """`modes` as rows of d integers: ints in 1-D (a sequence, or one int), d-tuples otherwise."""
    example = "[1, 2, 5]" if d == 1 else f"[{tuple(range(1, d + 1))}, ...]"
    expected = f"modes: expected wavevectors of integers, such as {example}, got {_check.shown(modes)}"
    try:
        a = np.asarray(modes, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(expected) from None
    if a.size == 0:  # no mode's action kept
        return np.zeros((0, d), dtype=np.int64)
    if not np.all(np.isfinite(a)) or np.any(a != np.round(a)) or np.any(np.abs(a) > 2**31):
        raise ValueError(expected)
    if (d == 1 and a.ndim > 1) or (d > 1 and (a.ndim > 2 or a.shape[-1] != d)):
        raise ValueError(f"modes: expected {'ints' if d == 1 else f'{d}-tuples'} on a {d}-D grid, "
                         f"such as {example}, got shape {a.shape}")
    return a.astype(np.int64).reshape(-1, d)


def _shape(n) -> tuple[int, ...]:
    values = (n,) if np.ndim(n) == 0 else tuple(n)
    if not 1 <= len(values) <= 3:
        raise ValueError(f"n: expected an int (1-D) or a tuple of 2 or 3 ints, got {n!r}")
    out = []
    for v in values:
        k = _check.integer(v, "n", low=2)
        if k % 2:
            raise ValueError(f"n: grid points per axis must be even (the Nyquist mode is then real), got {k}")
        out.append(k)
    return tuple(out)


def _degree(expr, var) -> int:
    """The degree of a polynomial V in u (0 for a constant)."""
    import sympy as sp

    return int(sp.Poly(expr, var).degree()) if expr.has(var) else 0
