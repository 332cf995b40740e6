"""One measured claim of a figure (its own module, so that the per-kind modules that measure
claims and the dispatch in claims.py do not import each other)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Claim:
    """One claim of the paper's §4, measured on a figure's data: the number, what the paper
    expects, the tolerance and whether it passes (one row of report.md).

    Attributes
    ----------
    figure : str
        The figure, ``"fig1"`` … ``"fig5"``.
    claim : str
        What the paper states, in words.
    measured : float
        The number measured on the data.
    expected : str
        What the paper's statement makes of it.
    tolerance : str
        How close the measurement must come.
    passed : bool
        Whether it does.
    verdict : str
        ``"PASS"`` or ``"FAIL"``.

    Examples
    --------
    >>> from trigint import experiments
    >>> ds = experiments.run(experiments.load("fig5", quick=True))
    >>> claim = experiments.measure(ds)[0]
    >>> claim.figure, claim.passed, claim.verdict
    ('fig5', True, 'PASS')
    """

    figure: str
    claim: str
    measured: float
    expected: str
    tolerance: str
    passed: bool

    @property
    def verdict(self) -> str:
        """``"PASS"`` or ``"FAIL"``."""
        return "PASS" if self.passed else "FAIL"
