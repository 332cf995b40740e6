"""Two builds of trigint timed against each other, alternately, through the public API.

    python benchmarks/compare_builds.py OLD NEW [--rounds 3]

OLD and NEW are folders that hold a built `trigint` package (each a checkout's `python/` folder
with its compiled `_core` in place). Each round runs the kernels once with OLD and once with NEW,
each in its own process; the table gives the best of the rounds and the ratio NEW / OLD. This is
how a change to the core is shown not to slow any kernel: same machine, same run.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

KERNELS = r'''
import time
import numpy as np
import trigint as ti
from trigint.potentials import fpu_linear_forms
import sympy as sp

H = 2 * np.pi / 3 / 50
prob = ti.problems.fpu(m=3, omega=50.0)
q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)


def best(fn, work):
    fn()  # machine code compiled, caches warm
    times = []
    for _ in range(3):
        t = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t) / work * 1e9)
    return min(times)


N, S, M = 3_000_000, 3000, 3000
Q0, P0 = ti.perturb(q0, p0, np.linspace(-1e-9, 1e-9, 1000))
hs = np.linspace(2.04, 2.14, 1000) / 50
x = sp.symbols("x0:6")
U = sum(sum(c * x[i] for i, c in row) ** 4 for row in fpu_linear_forms(3)) / 4
expr = ti.OscillatoryProblem([0, 0, 0, 50, 50, 50], ti.ExpressionPotential(U, x))
big = ti.problems.fpu(m=1000, omega=50.0)
bq, bp = ti.problems.fpu_initial(m=1000, omega=50.0)
springs = np.zeros((1001, 2000))
for k, row in enumerate(fpu_linear_forms(1000)):
    for i, c in row:
        springs[k, i] = c
chain = ti.OscillatoryProblem(big.omega, ti.ChainPotential(2000).add("y**4/4", "y", matrix=springs))
BQ, BP = ti.perturb(bq, bp, np.linspace(-1e-9, 1e-9, 16))
W = 300
wave = ti.problems.wave(2**16, rho=1.0, potential="u**4/4")
u0 = 0.1 * np.cos(2 * np.pi * np.arange(2**16) / 2**16)
rows = {
    "one trajectory, energies streamed": best(lambda: ti.integrate(prob, "B", q0, p0, h=H, n_steps=N, save_every=N), N),
    "one trajectory, no energies": best(
        lambda: ti.integrate(prob, "B", q0, p0, h=H, n_steps=N, save_every=N, track_energies=False), N),
    "1000 trajectories, 1 thread, streamed": best(
        lambda: ti.ensemble(prob, "B", Q0, P0, h=H, n_steps=S, threads=1), S * 1000),
    "1000 trajectories, 1 thread, no energies": best(
        lambda: ti.ensemble(prob, "B", Q0, P0, h=H, n_steps=S, threads=1, track_energies=False), S * 1000),
    "1000 step sizes (scan), 1 thread": best(
        lambda: ti.ensemble(prob, "B", np.tile(q0, (1000, 1)), np.tile(p0, (1000, 1)), h=hs, n_steps=S,
                            threads=1), S * 1000),
    "FPU as an expression, one trajectory": best(
        lambda: ti.integrate(expr, "B", q0, p0, h=H, n_steps=N, save_every=N), N),
    "FPU as an expression, 1000 trajectories": best(
        lambda: ti.ensemble(expr, "B", Q0, P0, h=H, n_steps=S, threads=1), S * 1000),
    "FPU m = 1000, one trajectory": best(lambda: ti.integrate(big, "B", bq, bp, h=H, n_steps=M, save_every=M), M),
    "FPU m = 1000 as a chain, one trajectory": best(
        lambda: ti.integrate(chain, "B", bq, bp, h=H, n_steps=M // 4, save_every=M // 4), M // 4),
    "FPU m = 1000, 16 trajectories, 1 thread": best(
        lambda: ti.ensemble(big, "B", BQ, BP, h=H, n_steps=M // 10, threads=1), M // 10 * 16),
    "FPU m = 1000 as a chain, 16 trajectories, 1 thread": best(
        lambda: ti.ensemble(chain, "B", BQ, BP, h=H, n_steps=M // 10, threads=1), M // 10 * 16),
    "wave equation, 2^16 points, energies streamed": best(
        lambda: ti.integrate(wave, "B", u0, np.zeros_like(u0), h=0.01, n_steps=W, save_every=W, progress=False), W),
}
for name, ns in rows.items():
    print(f"{name}\t{ns:.4f}")
'''


def run(path: str) -> dict[str, float]:
    env = {**os.environ, "PYTHONPATH": path}
    out = subprocess.run([sys.executable, "-c", KERNELS], env=env, check=True, capture_output=True, text=True)
    return {name: float(ns) for name, ns in (line.split("\t") for line in out.stdout.strip().splitlines())}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("old", help="folder holding the old build's trigint package")
    parser.add_argument("new", help="folder holding the new build's trigint package")
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds (default 3)")
    args = parser.parse_args(argv)
    old, new = [], []
    for _ in range(args.rounds):
        old.append(run(args.old))
        new.append(run(args.new))
    print("| kernel | old ns | new ns | new/old |\n|---|---:|---:|---:|")
    for name in old[0]:
        a, b = min(r[name] for r in old), min(r[name] for r in new)
        print(f"| {name} | {a:.2f} | {b:.2f} | {b / a:.3f} |")


if __name__ == "__main__":
    main()
