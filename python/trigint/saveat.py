"""What a run keeps: one value object, checked when it is built, taken by every entry point."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _check

#: the longest run accepted: 2**53 steps (step numbers stay exact in a double; at 7 ns per
#: step it would take two years)
MAX_STEPS = 2**53


def check_steps(n: int, name: str) -> int:
    """n, if it is a run length this library can count (at most 2**53 steps)."""
    if n > MAX_STEPS:
        count = f"{n:.3g} steps" if n < 10**300 else f"{_check.shown(n)} (steps)"
        raise ValueError(f"{name}: {count} is more than 2**53 = {MAX_STEPS:.3g}, the most allowed "
                         "(at 7 ns per step that would take two years)")
    return n


@dataclass(frozen=True)
class SaveAt:
    """What :func:`trigint.integrate` and :func:`trigint.ensemble` keep of a run.

    Parameters
    ----------
    every : int or None
        Keep the state (q, p and every energy) every this many steps, always with step 0 and
        the last step. ``None`` keeps no states in :func:`~trigint.ensemble` (only the energy
        statistics) and only step 0 and the last step in :func:`~trigint.integrate`.
    track_energies : bool
        Stream max |E(t_n) − E(0)| over every step (default). Off, energies are computed only
        at the samples and ``max_deviation`` is NaN.

    Examples
    --------
    >>> import trigint as ti
    >>> ti.SaveAt(every=10).samples(1000)
    102
    >>> ti.SaveAt(every=0)
    Traceback (most recent call last):
        ...
    ValueError: save_every: must be an integer >= 1 or None, got 0
    """

    every: int | None = 1
    track_energies: bool = True

    def __post_init__(self):
        every = self.every
        if every is not None:
            if not _check.is_integer(every):
                raise _check.IntegerTypeError(f"save_every: must be an integer >= 1 or None, got {every!r}")
            if every < 1:
                raise ValueError(f"save_every: must be an integer >= 1 or None, got {every!r}")
            check_steps(int(every), "save_every")
            object.__setattr__(self, "every", int(every))
        if not isinstance(self.track_energies, bool | np.bool_):
            raise TypeError(f"track_energies: expected True or False, got {self.track_energies!r}")
        object.__setattr__(self, "track_energies", bool(self.track_energies))

    def samples(self, n_steps: int) -> int:
        """The most states kept of one run.

        Parameters
        ----------
        n_steps : int
            The run's number of steps.

        Returns
        -------
        int
            States kept at most (0 when no states are kept).
        """
        return 0 if self.every is None else int(n_steps) // self.every + 2

    @classmethod
    def resolve(cls, saveat: SaveAt | None, save_every, track_energies) -> SaveAt:
        """The SaveAt of an entry point's arguments.

        Parameters
        ----------
        saveat : SaveAt or None
            Taken as it is when given (it replaces the other two).
        save_every : int or None
            As ``every``.
        track_energies : bool
            As ``track_energies``.

        Returns
        -------
        SaveAt
        """
        if saveat is None:
            return cls(save_every, track_energies)
        if not isinstance(saveat, SaveAt):
            raise TypeError(f"saveat: expected a trigint.SaveAt, got {type(saveat).__name__}")
        return saveat
