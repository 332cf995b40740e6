"""The paper's theory made computable (paper §3 and §5): non-resonance conditions, the
assumptions of Theorems 3.1/3.2, the gap lemma and the modified frequencies. Pure NumPy; it
never steps an ODE.

>>> import numpy as np
>>> from trigint import resonance
>>> resonance.analyze(np.pi/2/50, [50.0]).N
2
"""

from .conditions import ResonanceReport, Violation, analyze, nonresonance_violations, resonance_module
from .gap import ModifiedFrequencies, gap, modified_frequencies
from .steps import ResonantStep, resonant_step_sizes
from .strata import Combinations, combinations, predicted_strata, strata_resonances
from .wave import WaveResonance, cfl_number, energy_resonances, wave_resonances

__all__ = [
    "ModifiedFrequencies",
    "ResonanceReport",
    "ResonantStep",
    "Violation",
    "WaveResonance",
    "analyze",
    "cfl_number",
    "gap",
    "modified_frequencies",
    "nonresonance_violations",
    "resonance_module",
    "resonant_step_sizes",
    "energy_resonances",
    "predicted_strata",
    "combinations",
    "Combinations",
    "strata_resonances",
    "wave_resonances",
]
