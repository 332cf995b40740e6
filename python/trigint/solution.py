"""The result of a run: samples, energies and the streamed diagnostics."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # imported where a Dataset is made, so that `import trigint` loads no xarray (nor pandas)
    import xarray as xr

#: channels a summary lists by name; the rest (one per block or mode) by their largest values
SUMMARY_ENTRIES = 6


class Channels(Mapping):
    """A read-only mapping over energy channels that prints as a summary: the main channels,
    then how many per-block (per-mode) entries there are and the largest of them. Every entry
    is still there. It holds the values as one array over the channels (a wave problem has a
    channel per mode: tens of thousands), indexed by name.

    >>> d = Channels({"total": 1e-3, **{f"oscillatory_{j}": j * 1e-6 for j in range(1, 501)}})
    >>> d
    {total=1.000e-03; 500 per-block entries, largest: oscillatory_500=5.000e-04, ...}
    >>> d["oscillatory_7"]
    7e-06
    >>> float(d.to_numpy()[0])
    0.001
    """

    __slots__ = ("_names", "_index", "_values")

    def __init__(self, entries=(), *, table: tuple[tuple[str, ...], dict[str, int]] | None = None,
                 values: np.ndarray | None = None, handed_over: bool = False):
        if table is None:
            entries = dict(entries)
            table = tuple(entries), {k: i for i, k in enumerate(entries)}
            values = [float(v) for v in entries.values()]
        self._names, self._index = table
        if handed_over:  # an array nobody else writes: kept without a copy, read-only
            self._values = np.asarray(values, dtype=float)
            self._values.flags.writeable = False
        else:
            self._values = np.array(values, dtype=float)

    @classmethod
    def of(cls, names: tuple[str, ...], index: dict[str, int], values: np.ndarray) -> Channels:
        """The channels `names` (with ``index[name]`` its position) holding `values`, an array
        of floats the caller hands over: kept without a copy (a wave run has a channel per
        mode) and made read-only."""
        return cls(table=(names, index), values=values, handed_over=True)

    def __getitem__(self, name: str) -> float:
        try:
            return float(self._values[self._index[name]])
        except (KeyError, TypeError):
            raise KeyError(self._unknown(name)) from None

    def get(self, name, default=None):
        """The value of channel `name`, or `default` where there is none (without building
        :meth:`__getitem__`'s message, which walks every name: a wave run has tens of
        thousands)."""
        try:
            i = self._index[name]
        except (KeyError, TypeError):
            return default
        return float(self._values[i])

    def _unknown(self, name) -> str:
        """Why `name` is not a channel: the channels there are (the per-block ones as a range),
        and the nearest name where one is near."""
        import difflib

        main = [k for k in self._names if not k.startswith("oscillatory_")]
        blocks = [k for k in self._names if k.startswith("oscillatory_")]
        listed = main + (blocks if len(blocks) <= 2 else [f"{blocks[0]!r} … {blocks[-1]!r}"])
        there = ", ".join(k if "…" in k else repr(k) for k in listed)
        lower = {k.lower(): k for k in main}
        near = difflib.get_close_matches(name.lower(), list(lower), n=1) if isinstance(name, str) else []
        hint = f" (did you mean {lower[near[0]]!r}?)" if near else ""
        return f"no channel {name!r}{hint}; the channels are {there}"

    def __contains__(self, name) -> bool:
        return name in self._index

    def __iter__(self):
        return iter(self._names)

    def __len__(self) -> int:
        return len(self._names)

    def to_numpy(self) -> np.ndarray:
        """The values in channel order (a copy)."""
        return self._values.copy()

    def as_array(self) -> np.ndarray:
        """The values in channel order, read-only (not copied: :meth:`to_numpy` copies; the
        Mapping's ``values()`` stays a view of floats).

        >>> Channels({"total": 1.0, "oscillatory_1": 2.0}).as_array().tolist()
        [1.0, 2.0]
        """
        view = self._values.view()
        view.flags.writeable = False
        return view

    def position(self, name: str) -> int:
        """Where channel `name` is in channel order (``to_numpy()[position(name)]`` is its value),
        without walking the names.

        >>> Channels({"total": 1.0, "oscillatory_1": 2.0}).position("oscillatory_1")
        1
        """
        return self._index[name]

    def __reduce__(self):
        return (Channels, (dict(self),))

    def __repr__(self) -> str:
        items = list(zip(self._names, self._values.tolist(), strict=True))
        blocks = [(k, v) for k, v in items if k.startswith("oscillatory_")]
        main = [(k, v) for k, v in items if not k.startswith("oscillatory_")]
        text = ", ".join(f"{k}={_number(v)}" for k, v in main)
        if len(blocks) <= SUMMARY_ENTRIES:
            text = ", ".join(x for x in (text, ", ".join(f"{k}={_number(v)}" for k, v in blocks)) if x)
        else:
            top = sorted(blocks, key=lambda kv: -abs(kv[1]) if np.isfinite(kv[1]) else -np.inf)[:3]
            shown = ", ".join(f"{k}={_number(v)}" for k, v in top)
            text += f"; {len(blocks)} per-block entries, largest: {shown}, ..."
        return "{" + text + "}"


def _number(v) -> str:
    try:
        return f"{float(v):.3e}"
    except (TypeError, ValueError):
        return repr(v)


class Deferred:
    """A value made when first asked for: ``Deferred(f, *args)()`` is ``f(*args)``. Picklable
    when `f` and `args` are (a problem's bound method and arrays)."""

    __slots__ = ("make", "args")

    def __init__(self, make, *args):
        self.make, self.args = make, args

    def __call__(self):
        return self.make(*self.args)

    def __reduce__(self):
        return (Deferred, (self.make, *self.args))


@dataclass(frozen=True)
class Solution:
    """A numerical solution, sampled at steps 0, s, 2s, … and the last step.

    Attributes
    ----------
    t, q, p : arrays
        Sample times (shape (m,)) and states (shape (m, n)), in the problem's coordinates; the
        sample at step 0 is the initial state exactly as given.
    steps : array of int
        The step index of each sample.
    energies : xarray.Dataset
        Every energy over ``t`` at the samples: ``total`` (H), ``oscillatory`` (H_ω), ``slow``
        (½|p₀|² + U), ``modified_oscillatory`` (H*_ω; NaN on the Krylov path), ``kinetic``
        (½|p₀|², the slow coordinates' kinetic energy; 0 on the Krylov path) and ``oscillatory_1`` …
        ``oscillatory_ℓ`` (the I_j); for a wave problem ``momentum`` (over ``axis``) and
        ``action`` (over ``mode``) in place of the per-block energies.
    max_deviation : Channels
        max |E(t_n) − E(0)| per energy over every step n (streamed, not from the samples); a
        read-only mapping from channel name to value.
    initial_energies : Channels
        E(0) per energy.
    h : float
        The step size.
    n_steps : int
        The last step reached (the requested number unless the run stopped early).
    n_steps_requested : int
        The number of steps asked for.
    status : str
        ``"completed"``, ``"blow-up"`` or ``"interrupted"``; `message` says more.
    message : str
        How the run ended, in words.
    success : bool
        True when every requested step was taken (``status == "completed"``).
    method : Method
        The method that ran.
    problem : OscillatoryProblem
        The problem it ran on.
    u, v : xarray.DataArray
        A wave problem's samples of q and p as grid values over (t, x[, y, z]).
    info : dict
        How the run went beyond the energies: on the Krylov path, the Lanczos ``iterations``
        (total), ``products`` (matrix functions applied), ``iterations_per_product`` and
        ``tolerance``; empty otherwise.

    Examples
    --------
    >>> import trigint as ti
    >>> prob = ti.problems.fpu(); q0, p0 = ti.problems.fpu_initial()
    >>> sol = ti.integrate(prob, "B", q0, p0, h=0.04, n_steps=100, save_every=50)
    >>> sol.steps.tolist(), sol.status, sol.q.shape
    ([0, 50, 100], 'completed', (3, 6))
    """

    t: np.ndarray
    q: np.ndarray
    p: np.ndarray
    steps: np.ndarray
    #: the energies' Dataset, or what builds it when `energies` is first read
    _energies: object = field(repr=False)
    max_deviation: Mapping
    initial_energies: Mapping
    h: float
    n_steps: int
    n_steps_requested: int
    status: str
    message: str
    method: object = field(repr=False)
    problem: object = field(repr=False)
    info: dict = field(default_factory=dict, repr=False)

    @property
    def energies(self) -> xr.Dataset:
        """Every energy over ``t`` at the samples: ``total`` (H), ``oscillatory`` (H_ω),
        ``slow`` (½|p₀|² + U), ``modified_oscillatory`` (H*_ω; NaN on the Krylov path),
        ``kinetic`` (½|p₀|², the slow coordinates' kinetic energy; 0 on the Krylov path) and
        ``oscillatory_1`` … ``oscillatory_ℓ`` (the I_j); for a wave problem ``momentum`` (over
        ``axis``) and ``action`` (over ``mode``) in place of the per-block energies.

        Built when first read: a short call on a large problem spends a millisecond on it (a
        2¹⁶-point wave equation), which a loop of calls that reads only the states need not pay."""
        built = self._energies
        if isinstance(built, Deferred):
            built = built()
            object.__setattr__(self, "_energies", built)
        return built

    @property
    def success(self) -> bool:
        """True when every requested step was taken."""
        return self.status == "completed"

    @property
    def u(self) -> xr.DataArray:
        """A wave problem's sampled positions as grid values: dims (``t``, ``x``), (``t``, ``x``,
        ``y``) or (``t``, ``x``, ``y``, ``z``), with the grid's coordinates (``sol.q`` holds the
        same numbers flat, N per sample, in the grid's C order).

        >>> import numpy as np, trigint as ti
        >>> prob = ti.problems.wave((8, 6), rho=1.0)
        >>> x, y = np.meshgrid(*prob.grid, indexing="ij")
        >>> sol = ti.integrate(prob, "B", np.cos(x) * np.cos(y), 0 * x, h=0.1, n_steps=4, save_every=2)
        >>> sol.u.dims, sol.u.shape
        (('t', 'x', 'y'), (3, 8, 6))
        """
        return self._grid_view(self.q, "u")

    @property
    def v(self) -> xr.DataArray:
        """A wave problem's sampled velocities u_t as grid values (see :attr:`u`)."""
        return self._grid_view(self.p, "v")

    def _grid_view(self, values: np.ndarray, name: str) -> xr.DataArray:
        shape = getattr(self.problem, "shape", None)
        if shape is None or not hasattr(self.problem, "grid"):
            raise AttributeError(f"{name}: grid values are for wave problems (trigint.problems.wave); use q and p")
        axes = ("x", "y", "z")[: len(shape)]
        data = np.asarray(values).reshape(self.t.size, *shape)
        coords = {"t": self.t, **dict(zip(axes, self.problem.grid, strict=True))}
        import xarray as xr

        return xr.DataArray(data, dims=("t", *axes), coords=coords, name=name)

    def deviation(self, energy: str = "oscillatory") -> xr.DataArray:
        """E(t) − E(0) at the samples for one energy.

        Parameters
        ----------
        energy : str
            A name of `energies`: ``"oscillatory"``, ``"total"``, ``"slow"``,
            ``"modified_oscillatory"``, ``"kinetic"`` or ``"oscillatory_j"``; for a wave
            problem ``"momentum"`` (per axis) and ``"action"`` (per mode) instead of
            ``"oscillatory_j"``.
        """
        if energy not in self.energies:
            raise KeyError(f"energy: unknown name {energy!r}; valid: {list(self.energies.data_vars)}")
        e = self.energies[energy]
        if energy in self.initial_energies:
            return e - self.initial_energies[energy]
        # a wave's momentum (per axis) and actions (per mode): E(0) is the sample at step 0
        return e - e.isel(t=0)

    def __post_init__(self):
        for name in ("max_deviation", "initial_energies"):
            if not isinstance(getattr(self, name), Channels):
                object.__setattr__(self, name, Channels(getattr(self, name)))

    def __repr__(self) -> str:
        devs = repr(self.max_deviation)[1:-1]
        return (
            f"Solution(status={self.status!r}, method={self.method!r}, h={self.h:g}, "
            f"n_steps={self.n_steps}, samples={self.t.size}, max_deviation: {devs})"
        )
