"""The FPU problem of Experiment 2: oscillatory energy of Deuflhard's method (B) at hω = 2π/3.

Run:  python examples/fpu_energy.py [OUTPUT_DIR]
"""

import sys
from pathlib import Path

import numpy as np

import trigint as ti
from trigint.plotting import plot_deviation, save


def main(out: Path) -> list[Path]:
    omega = 50.0
    prob = ti.problems.fpu(m=3, omega=omega)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=omega)
    h = 2 * np.pi / 3 / omega
    black = ti.integrate(prob, "B", q0, p0, h=h, t_end=3000.0, save_every=20)
    grey = []
    for delta in (7e-16, -7e-16, 3e-16):
        q = q0.copy()
        q[0] += delta
        grey.append(ti.integrate(prob, "B", q, p0, h=h, t_end=3000.0, save_every=20))
    print(black)
    ax = plot_deviation([black, *grey],
                        title="FPU, ω = 50, hω = 2π/3, method B: grey curves start at x₀,₁ = 1 ± δ, |δ| ≤ 7·10⁻¹⁶")
    return save(ax, out / "fpu_oscillatory_energy")


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("reproduction")
    for path in main(target):
        print(f"wrote {path}")
