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
        Whether it does (always true for a measurement).
    measurement : bool
        A number the report states without claiming it: a hypothesis that failed its test is
        kept in view this way, with what was stated in advance and what was found in its row.
    verdict : str
        ``"PASS"``, ``"FAIL"`` or ``"MEASURED"``.

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
    measurement: bool = False

    @property
    def verdict(self) -> str:
        """``"PASS"``, ``"FAIL"``, or ``"MEASURED"`` for a measurement."""
        if self.measurement:
            return "MEASURED"
        return "PASS" if self.passed else "FAIL"
