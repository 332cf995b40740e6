"""The wave equation's step against FFTW and NumPy (part of `make bench`).

The same step everywhere: u_tt = u_xx − ρu − u³ (V = u⁴/4, ρ = 1, h = 0.01), method B in the
two-step form, energies streamed at every step (H and every mode's energy, with their running
extremes). The C loop (benchmarks/c/wave_fftw.c) uses FFTW's real transforms planned with
FFTW_MEASURE; it needs FFTW's headers (Debian: ``apt-get install libfftw3-dev``), and its row
says so when they are missing. The NumPy loop is the step as a user writes it with numpy.fft.
"""

from __future__ import annotations

import shutil
import subprocess
import time
import warnings
from pathlib import Path

import numpy as np

import trigint as ti

HERE = Path(__file__).resolve().parent
RHO, H = 1.0, 0.01


def compile_fftw(build: Path) -> Path | None:
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        return None
    build.mkdir(exist_ok=True)
    exe = build / "wave_fftw"
    done = subprocess.run([cc, "-O3", "-march=native", "-o", str(exe), str(HERE / "c" / "wave_fftw.c"),
                           "-lfftw3", "-lm"], capture_output=True)
    return exe if done.returncode == 0 else None


def initial(shape):
    x = np.meshgrid(*[2 * np.pi * np.arange(n) / n for n in shape], indexing="ij")
    return 0.1 * np.cos(x[0]) + 0.05 * np.sin(3 * x[-1]), np.zeros(shape)


def trigint_step(shape, steps: int, track: bool = True) -> float:
    """µs per step of ti.integrate on the wave problem: the difference of a run of 3·steps and
    one of `steps`, so that the per-call work (planning the FFTs, compiling V, the transforms of
    the samples) cancels."""
    prob = ti.problems.wave(shape if len(shape) > 1 else shape[0], rho=RHO, potential="u**4/4")
    u0, v0 = initial(shape)

    def run(n: int) -> float:
        t = time.perf_counter()
        ti.integrate(prob, "B", u0, v0, h=H, n_steps=n, save_every=n, track_energies=track, progress=False)
        return time.perf_counter() - t

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a high mode near a multiple of π: the step is timed, not judged
        run(2)
        # the fastest of three runs of each length: the machine's noise only ever adds time
        short, long = (min(run(n) for _ in range(3)) for n in (steps, 3 * steps))
    return (long - short) / (2 * steps) * 1e6


def numpy_step(shape, steps: int) -> float:
    """µs per step of the same step with numpy.fft (real transforms over all axes)."""
    u0, _ = initial(shape)
    k = np.meshgrid(*[np.fft.fftfreq(n, 1.0 / n) for n in shape[:-1]], np.arange(shape[-1] // 2 + 1),
                    indexing="ij")
    w = np.sqrt(RHO + sum(kk.astype(float) ** 2 for kk in k))
    c2, hps, inv = 2 * np.cos(H * w), H * H * np.sinc(H * w / np.pi), 1 / (2 * H * np.sinc(H * w / np.pi))
    weight = np.full(w.shape, 2.0)
    weight[..., 0] = 1.0
    weight[..., -1] = 1.0
    n = u0.size
    q = np.fft.rfftn(u0) / n
    qm = q.copy()
    hi, lo = np.full(w.shape, -np.inf), np.full(w.shape, np.inf)
    h_hi, h_lo = -np.inf, np.inf
    t = time.perf_counter()
    for _ in range(steps):
        u = np.fft.irfftn(q * n, s=shape)
        energy_u = 0.25 * np.mean(u**4)
        g = -np.fft.rfftn(u**3) / n
        qn = c2 * q - qm + hps * g
        p = (qn - qm) * inv
        e = 0.5 * weight * (np.abs(p) ** 2 + w**2 * np.abs(q) ** 2)
        np.maximum(hi, e, out=hi)
        np.minimum(lo, e, out=lo)
        total = e.sum() + energy_u
        h_hi, h_lo = max(h_hi, total), min(h_lo, total)
        qm, q = q, qn
    return (time.perf_counter() - t) / steps * 1e6


def rows(build: Path, smoke: bool) -> list[dict]:
    """One row per grid: µs per step of the C/FFTW loop (1-D), NumPy and trigint."""
    out = []
    fftw = compile_fftw(build)
    grids = [(2**12,), (64, 64)] if smoke else [(2**16,), (512, 512), (128, 128, 128)]
    for shape in grids:
        points = int(np.prod(shape))
        steps = max(4, (2**16 if smoke else 2**25) // points)
        c = None
        if len(shape) == 1 and fftw is not None:
            c = float(subprocess.run([str(fftw), str(shape[0]), str(steps)], check=True, capture_output=True,
                                     text=True).stdout.split()[0])
        ours = trigint_step(shape, steps)
        untracked = trigint_step(shape, steps, track=False)
        npy = numpy_step(shape, max(2, steps // 8))
        out.append(dict(grid=" × ".join(map(str, shape)), c=c, numpy=npy, ours=ours, untracked=untracked,
                        fftw_missing=len(shape) == 1 and fftw is None))
    return out


def fixed_cost(shape, step_us: float) -> tuple[float, float, float]:
    """µs of a call beyond its steps: everything a call does once (the state in and out of the
    Fourier coordinates, the set up, the first force, the Solution), then the same with
    ``sol.energies`` read (the Dataset is built when first read); and the µs of a step measured
    beside them. A 2-step call and a (2 + k)-step call alternate over eight rounds, so that the
    step and the call are timed in the same minutes on a busy machine: fixed = (fastest 2-step
    call) − 2 · step, step = (fastest long call − fastest 2-step call) / k, with k steps about
    20 ms (`step_us`, from the longer runs, chooses k)."""
    prob = ti.problems.wave(shape if len(shape) > 1 else shape[0], rho=RHO, potential="u**4/4")
    u0, v0 = initial(shape)
    k = int(min(256, max(8, 2e4 / step_us)))

    def call(n_steps: int, read: bool) -> float:
        t = time.perf_counter()
        sol = ti.integrate(prob, "B", u0, v0, h=H, n_steps=n_steps, save_every=n_steps, progress=False)
        if read:
            _ = sol.energies  # built here
        return time.perf_counter() - t

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        call(2, True)  # the problem's kept conversions made
        two, two_read, long = [], [], []
        for _ in range(8):
            two.append(min(call(2, False) for _ in range(3)))
            two_read.append(min(call(2, True) for _ in range(3)))
            long.append(call(2 + k, False))
    step = (min(long) - min(two)) / k
    return (min(two) - 2 * step) * 1e6, (min(two_read) - 2 * step) * 1e6, step * 1e6


def scaling(smoke: bool) -> list[dict]:
    """trigint's µs per step against n (1-D), with the ratio to n log₂ n and a call's fixed cost."""
    sizes = [2**k for k in ((8, 10, 12) if smoke else (10, 12, 14, 16, 18))]
    out = []
    for n in sizes:
        us = trigint_step((n,), max(4, (2**16 if smoke else 2**23) // n))
        fixed, fixed_read, beside = fixed_cost((n,), us)
        out.append(dict(n=n, us=us, per_nlogn=us * 1e3 / (n * np.log2(n)), fixed=fixed, fixed_read=fixed_read,
                        beside=beside))
    return out


def report(table: list[dict], grow: list[dict]) -> list[str]:
    lines = ["| grid | C + FFTW (µs) | NumPy (µs) | trigint (µs) | trigint / FFTW | trigint, no energies (µs) |",
             "|---|---:|---:|---:|---:|---:|"]
    for r in table:
        c = "FFTW headers missing (apt-get install libfftw3-dev)" if r["fftw_missing"] else \
            ("" if r["c"] is None else f"{r['c']:.1f}")
        ratio = "" if r["c"] is None else f"{r['ours'] / r['c']:.2f} (target ≤ 1.3)"
        lines.append(f"| {r['grid']} | {c} | {r['numpy']:.1f} | {r['ours']:.1f} | {ratio} | {r['untracked']:.1f} |")
    lines += ["", "A call's fixed cost: a 2-step `ti.integrate` less two steps (target ≤ max(1 ms, 5 steps)), "
              "in steps of a call's own steps timed beside it (the same minutes).", "",
              "| n (1-D) | trigint µs per step | ns per n log₂ n | fixed cost of a call (ms) | µs per step beside it "
              "| in steps | with `sol.energies` read (ms) | in steps |",
              "|---:|---:|---:|---:|---:|---:|---:|---:|"]
    lines += [f"| {r['n']} | {r['us']:.1f} | {r['per_nlogn']:.3f} | {r['fixed'] / 1e3:.2f} | {r['beside']:.1f} | "
              f"{r['fixed'] / r['beside']:.1f} | {r['fixed_read'] / 1e3:.2f} | {r['fixed_read'] / r['beside']:.1f} |"
              for r in grow]
    return lines
