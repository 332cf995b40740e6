"""trigint's benchmark suite: `make bench` (full) and `make bench-smoke` (tiny, for CI).

Every trigint timing stands next to the strongest baseline measured in the same run:
the straight-line C kernels of benchmarks/c/fpu_limit.c (`scalar`, `scalar-tracked`, `soa`,
`soa-tracked`), benchmarks/c/toda_limit.c and benchmarks/c/lanczos_limit.c, compiled here with
`cc -O3 -march=native`, or trigint's own native FPU for the compiled-potential rows. Baseline and
trigint runs alternate, and each figure is the median of the repetitions (the machine is shared and noisy). The C
kernels time their stepping loop alone; trigint is timed through its Python API (what users
call), on runs long enough that the call overhead is below 0.1%.

Writes benchmarks/results.md and results.png.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.sparse
import sympy as sp

import trigint as ti
from trigint.potentials import fpu_linear_forms

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import wave as wave_bench  # noqa: E402  (benchmarks/wave.py)

BUILD = HERE / "build"
OMEGA = 50.0
H = 2 * np.pi / 3 / OMEGA


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def kernel_isa() -> str:
    """The widest instruction set whose copies of the kernels run here (their run-time dispatch
    takes AVX-512 where the CPU has AVX-512F, else AVX2, else the baseline x86-64)."""
    try:
        flags = next(line for line in Path("/proc/cpuinfo").read_text().splitlines() if line.startswith("flags"))
    except (OSError, StopIteration):
        return "unknown"
    words = set(flags.split(":", 1)[1].split())
    cap = isa_cap()
    if "avx512f" in words and cap not in ("avx2", "baseline", "sse2"):
        return "AVX-512"
    return "AVX2" if "avx2" in words and cap not in ("baseline", "sse2") else "SSE2"


def compile_c(name: str, flags: list[str] | None = None, suffix: str = "") -> Path:
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        raise RuntimeError("no C compiler (cc) found; the C baselines need one")
    BUILD.mkdir(exist_ok=True)
    exe = BUILD / f"{name}{suffix}"
    flags = c_isa_flags() if flags is None else flags
    subprocess.run([cc, "-O3", "-march=native", *flags, "-o", str(exe), str(HERE / "c" / f"{name}.c"), "-lm"],
                   check=True)
    return exe


#: the C flags that keep a baseline within an instruction-set copy's limits
C_FLAGS = {"avx512": [], "avx2": ["-mno-avx512f"], "baseline": ["-mno-avx"]}

#: timed in a child process per instruction-set copy (TRIGINT_ISA is read once per process)
ISA_CHILD = """
import json, sys, time, numpy as np, trigint as ti
n, count, steps, repeat = map(int, sys.argv[1:5])
prob = ti.problems.fpu(m=3, omega=50.0); q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0); h = 2 * np.pi / 3 / 50
Q0, P0 = ti.perturb(q0, p0, np.linspace(0.0, 1e-3, count))
wave = ti.problems.wave((1 << 14,), rho=1.0, potential="u**4/4"); (x,) = wave.mesh
def best(f, work):
    f()
    out = []
    for _ in range(repeat):
        t = time.perf_counter(); f(); out.append((time.perf_counter() - t) / work * 1e9)
    return min(out)
print(json.dumps({
    "streamed": best(lambda: ti.integrate(prob, "B", q0, p0, h=h, n_steps=n, save_every=n, progress=False), n),
    "untracked": best(lambda: ti.integrate(prob, "B", q0, p0, h=h, n_steps=n, save_every=n, track_energies=False,
                                           progress=False), n),
    "lanes": best(lambda: ti.ensemble(prob, "B", Q0, P0, h=h, n_steps=steps, threads=1, chunk_size=count,
                                      progress=False), count * steps),
    "wave": best(lambda: ti.integrate(wave, "B", 0.1 * np.cos(x), 0 * x, h=0.01, n_steps=200, save_every=200,
                                      progress=False), 200) / 1000,
    "lyapunov": best(lambda: ti.lyapunov(prob, "B", q0, p0, h=h, n_steps=n // 4), n // 4),
}))
"""


def isa_rows(n: int, count: int, batch_steps: int, repeat: int) -> list[dict]:
    """Every instruction-set copy the CPU runs (TRIGINT_ISA), and the default (the planner's
    choice), against the C loops compiled within the same limits."""
    from trigint._config import config

    rows = []
    for copy in [None, *config()["copies"]]:
        env = {k: v for k, v in os.environ.items() if k != "TRIGINT_ISA"}
        if copy is not None:
            env["TRIGINT_ISA"] = copy
        exe = compile_c("fpu_limit", C_FLAGS.get(copy or "", []), f"-{copy or 'native'}")
        c = {k: statistics.median(c_timer(exe, *a)() for _ in range(repeat))
             for k, a in (("scalar-tracked", ("scalar-tracked", n)), ("scalar", ("scalar", n)),
                          ("soa-tracked", ("soa-tracked", count, batch_steps)))}
        out = subprocess.run([sys.executable, "-c", ISA_CHILD, str(n), str(count), str(batch_steps), str(repeat)],
                             env=env, check=True, capture_output=True, text=True).stdout
        t = json.loads(out.strip().splitlines()[-1])
        rows.append(dict(copy=copy or "default (planner)", c=c, t=t))
    return rows


def isa_table(rows: list[dict]) -> list[str]:
    out = ["| copy | streamed ns (C `scalar-tracked`) | untracked ns (C `scalar`) | 1000 lanes, 1 thread, ns "
           "(C `soa-tracked`) | wave 2¹⁴ step µs | leading exponent ns |",
           "|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        c, t = r["c"], r["t"]
        def cell(ours, base, t=t, c=c):
            return f"{t[ours]:.2f} ({c[base]:.2f}, {t[ours] / c[base]:.2f}×)"

        out.append(f"| {r['copy']} | {cell('streamed', 'scalar-tracked')} | {cell('untracked', 'scalar')} | "
                   f"{cell('lanes', 'soa-tracked')} | {t['wave']:.1f} | {t['lyapunov']:.1f} |")
    return out


def isa_cap() -> str | None:
    """The instruction-set cap of the kernels (`TRIGINT_ISA`), if any."""
    cap = os.environ.get("TRIGINT_ISA", "").strip().lower()
    return cap or None


def c_isa_flags() -> list[str]:
    """The C baselines under the same cap as the kernels (`TRIGINT_ISA=avx2`: no AVX-512)."""
    return {"avx2": ["-mno-avx512f"], "baseline": ["-mno-avx"], "sse2": ["-mno-avx"]}.get(isa_cap() or "", [])


def c_timer(exe: Path, *args):
    def run() -> float:
        out = subprocess.run([str(exe), *map(str, args)], check=True, capture_output=True, text=True).stdout
        return float(out.split()[0])

    return run


def py_timer(fn, work: int):
    """ns per unit of work of fn()."""

    def run() -> float:
        t = time.perf_counter()
        fn()
        return (time.perf_counter() - t) / work * 1e9

    return run


def interleaved(timers: list, repeat: int) -> list[float]:
    """Median of `repeat` rounds, the timers run alternately within each round."""
    rounds = [[t() for t in timers] for _ in range(repeat)]
    return [statistics.median(col) for col in zip(*rounds, strict=True)]


def fpu(m: int = 3):
    return ti.problems.fpu(m=m, omega=OMEGA), ti.problems.fpu_initial(m=m, omega=OMEGA)


def single(prob, q0, p0, n: int, track: bool):
    return lambda: ti.integrate(prob, "B", q0, p0, h=H, n_steps=n, save_every=n, track_energies=track,
                                progress=False)


def fpu_expression(m: int):
    x = sp.symbols(f"x0:{2 * m}")
    forms = [sum(c * x[i] for i, c in row) for row in fpu_linear_forms(m)]
    return ti.ExpressionPotential(sp.Rational(1, 4) * sum(y**4 for y in forms), x)


def fpu_matrix(m: int) -> np.ndarray:
    L = np.zeros((m + 1, 2 * m))
    for k, row in enumerate(fpu_linear_forms(m)):
        for i, c in row:
            L[k, i] = c
    return L


def numpy_fpu(m: int):
    """The FPU potential U and ∇U in NumPy, over the last axis (one state or a block)."""

    def forms(x):
        x0, x1 = x[..., :m], x[..., m:]
        y = np.empty(x.shape[:-1] + (m + 1,))
        y[..., 0] = x0[..., 0] - x1[..., 0]
        y[..., 1:m] = x0[..., 1:] - x1[..., 1:] - x0[..., :-1] - x1[..., :-1]
        y[..., m] = x0[..., -1] + x1[..., -1]
        return y

    def value(x):
        return 0.25 * np.sum(forms(x) ** 4, axis=-1)

    def gradient(x):
        d = forms(x) ** 3
        g0, g1 = d[..., :m].copy(), -d[..., :m]
        for g in (g0, g1):
            g[..., :-1] -= d[..., 1:m]
            g[..., -1] += d[..., m]
        return np.concatenate([g0, g1], axis=-1)

    return value, gradient


def row(case, base_label, base, ours_label, ours, target=None) -> dict:
    return dict(case=case, base_label=base_label, base=base, ours_label=ours_label, ours=ours,
                ratio=ours / base, target=target)


def limit_rows(n: int, count: int, batch_steps: int, repeat: int) -> list[dict]:
    """Issue-10 rows: FPU m = 3, ω = 50, hω = 2π/3, method B, against fpu_limit.c."""
    exe = compile_c("fpu_limit")
    prob, (q0, p0) = fpu()
    rows = []
    for track, kernel, target in ((False, "scalar", 1.2), (True, "scalar-tracked", 1.25)):
        c, t = interleaved([c_timer(exe, kernel, n), py_timer(single(prob, q0, p0, n, track), n)], repeat)
        rows.append(row(f"one trajectory, {'energies streamed' if track else 'no energies'}",
                        f"C `{kernel}`", c, "trigint integrate()", t, target))
    Q0, P0 = ti.perturb(q0, p0, np.linspace(0.0, 1e-3, count))
    h_each = H * (1 + 1e-6 * np.arange(count))

    def batch(track, threads, h=H):
        return lambda: ti.ensemble(prob, "B", Q0, P0, h=h, n_steps=batch_steps, threads=threads, track_energies=track,
                                   chunk_size=count, progress=False)

    work = count * batch_steps
    c_u, t_u = interleaved([c_timer(exe, "soa", count, batch_steps), py_timer(batch(False, 1), work)], repeat)
    rows.append(row(f"{count} trajectories, 1 thread, no energies", "C `soa`", c_u, "trigint ensemble()", t_u, 1.3))
    c_t, c_h, t_t, t_h = interleaved([c_timer(exe, "soa-tracked", count, batch_steps),
                                      c_timer(exe, "soa-tracked-h", count, batch_steps),
                                      py_timer(batch(True, 1), work), py_timer(batch(True, 1, h_each), work)], repeat)
    rows.append(row(f"{count} trajectories, 1 thread, energies streamed", "C `soa-tracked`", c_t,
                    "trigint ensemble()", t_t, 1.3))
    rows.append(row(f"{count} trajectories, 1 thread, energies streamed, a step size per trajectory (scan)",
                    "C `soa-tracked-h`", c_h, "trigint ensemble()", t_h, 1.3))
    cores = os.cpu_count() or 1
    if cores >= 2:
        one, two = interleaved([py_timer(batch(True, 1), work), py_timer(batch(True, 2), work)], repeat)
        rows.append(dict(case=f"{count} trajectories, energies streamed: 2 threads vs 1", base_label="1 thread",
                         base=one, ours_label="2 threads", ours=two, ratio=one / two, target=1.8, speedup=True))
    m = 1000
    prob_l, (ql, pl) = fpu(m)
    steps_l = max(200, n // 1000)
    un, tr = interleaved([py_timer(single(prob_l, ql, pl, steps_l, False), steps_l),
                          py_timer(single(prob_l, ql, pl, steps_l, True), steps_l)], repeat)
    rows.append(row(f"FPU m = {m}, one trajectory: energies streamed vs not", "trigint, no energies", un,
                    "trigint, energies streamed", tr, 1.3))
    return rows


def potential_rows(n: int, count: int, batch_steps: int, repeat: int) -> list[dict]:
    """Issue-9 rows: the user's own potentials against native and hand-written C."""
    prob, (q0, p0) = fpu()
    expr = ti.OscillatoryProblem(prob.omega, fpu_expression(3))
    rows = []
    a, b = interleaved([py_timer(single(prob, q0, p0, n // 4, True), n // 4),
                        py_timer(single(expr, q0, p0, n // 4, True), n // 4)], repeat)
    rows.append(row("FPU m = 3 as an ExpressionPotential, integrate(), energies streamed", "native FPUPotential", a,
                    "ExpressionPotential", b, 1.3))
    Q0, P0 = ti.perturb(q0, p0, np.linspace(0.0, 1e-3, count))

    def batch(p):
        return lambda: ti.ensemble(p, "B", Q0, P0, h=H, n_steps=batch_steps, threads=1, chunk_size=count,
                                   progress=False)

    a, b = interleaved([py_timer(batch(prob), count * batch_steps), py_timer(batch(expr), count * batch_steps)], repeat)
    rows.append(row(f"FPU m = 3 as an ExpressionPotential, {count} trajectories, 1 thread", "native FPUPotential", a,
                    "ExpressionPotential", b, 1.3))
    m = 1000
    prob_l, (ql, pl) = fpu(m)
    chain = ti.OscillatoryProblem(prob_l.omega, ti.ChainPotential(2 * m).add("y**4/4", "y", matrix=fpu_matrix(m)))
    steps_l = max(200, n // 1000)
    a, b = interleaved([py_timer(single(prob_l, ql, pl, steps_l, True), steps_l),
                        py_timer(single(chain, ql, pl, steps_l, True), steps_l)], repeat)
    rows.append(row(f"FPU m = {m} as a ChainPotential, integrate(), energies streamed", "native FPUPotential", a,
                    "ChainPotential", b, 1.5))
    toda_c = compile_c("toda_limit")
    toda_chain = (ti.ChainPotential(6).add("exp(y) - 1 - y", "y", matrix=fpu_matrix(3))
                  .add("1 - cos(y)", "y", sites=[0, 1, 2]))
    x = sp.symbols("x0:6")
    forms = [sum(c * x[i] for i, c in r) for r in fpu_linear_forms(3)]
    toda_u = sum(sp.exp(y) - 1 - y for y in forms) + sum(1 - sp.cos(x[i]) for i in range(3))
    toda_expr = ti.ExpressionPotential(toda_u, x)
    steps_t = n // 8

    def toda(pot):
        return py_timer(single(ti.OscillatoryProblem(prob.omega, pot), q0, p0, steps_t, True), steps_t)

    c, e, ch = interleaved([c_timer(toda_c, steps_t), toda(toda_expr), toda(toda_chain)], repeat)
    rows.append(row("Toda springs + on-site 1 − cos, m = 3, integrate(), energies streamed", "C `toda_limit`", c,
                    "ExpressionPotential", e, 1.5))
    rows.append(row("", "C `toda_limit`", c, "ChainPotential", ch, 1.5))
    # Python callables written in NumPy: one call per trajectory and step, or one per block of
    # lanes and step (the same functions; they work on (n,) and (lanes, n) arrays alike).
    value, gradient = numpy_fpu(3)
    per = ti.PythonPotential(lambda q: float(value(q)), gradient)
    vec = ti.PythonPotential(value, gradient, vectorized=True)
    # The per-trajectory calls cost the same per trajectory-step at any count: 128 of them keep
    # the run short; the vectorized potential runs the 1000 trajectories.
    few = min(128, count)
    steps_p = max(20, batch_steps // 200)

    def python_batch(pot, k):
        p = ti.OscillatoryProblem(prob.omega, pot)
        return lambda: ti.ensemble(p, "B", Q0[:k], P0[:k], h=H, n_steps=steps_p, threads=1, chunk_size=k,
                                   progress=False)

    slow, fast = interleaved([py_timer(python_batch(per, few), few * steps_p),
                              py_timer(python_batch(vec, count), count * steps_p)], max(1, repeat // 2))
    rows.append(dict(case=f"PythonPotential, ns per trajectory-step: vectorized ({count} trajectories) vs one "
                          f"call per trajectory ({few})",
                     base_label="per trajectory", base=slow, ours_label="vectorized=True", ours=fast,
                     ratio=slow / fast, target=50, speedup=True))
    return rows


def stiffness_rows(n: int, count: int, batch_steps: int, repeat: int, smoke: bool) -> tuple[list[dict], list[dict]]:
    """Issue-11 rows: a non-diagonal stiffness matrix, dense (FPU in its original coordinates)
    and sparse (the Krylov path on a long chain)."""
    prob, (q0, p0) = fpu()
    orig = ti.problems.fpu(3, OMEGA, coordinates="original")
    oq, op = ti.problems.fpu_initial(3, OMEGA, coordinates="original")
    a, b = interleaved([py_timer(single(prob, q0, p0, n // 4, True), n // 4),
                        py_timer(single(orig, oq, op, n // 4, True), n // 4)], repeat)
    rows = [row("FPU m = 3 in original coordinates (stiffness=A), integrate(), energies streamed",
                "diagonal FPU", a, "stiffness=A", b, 1.5)]
    Q0, P0 = ti.perturb(q0, p0, np.linspace(0.0, 1e-3, count))
    t = ti.problems.fpu_original_basis(3)
    OQ, OP = Q0 @ t.T, P0 @ t.T

    def batch(p, x, y):
        return lambda: ti.ensemble(p, "B", x, y, h=H, n_steps=batch_steps, threads=1, chunk_size=count,
                                   progress=False)

    a, b = interleaved([py_timer(batch(prob, Q0, P0), count * batch_steps),
                        py_timer(batch(orig, OQ, OP), count * batch_steps)], repeat)
    rows.append(row(f"FPU m = 3 in original coordinates, {count} trajectories, 1 thread", "diagonal FPU", a,
                    "stiffness=A", b, 1.5))
    size, steps = (10_000, 3) if smoke else (100_000, 20)
    stiff = scipy.sparse.diags([-np.ones(size - 1), 2 * np.ones(size), -np.ones(size - 1)], [-1, 0, 1]) * 100.0
    pot = (ti.ChainPotential(size).add("y**4 / 4", "y", pairs=[(i, i + 1) for i in range(size - 1)])
           .add("1 - cos(y)", "y", sites=range(size)))
    chain = ti.OscillatoryProblem(stiffness=stiff.tocsr(), potential=pot, path="krylov")
    x = np.linspace(0.0, 1.0, size)
    q0, p0 = 0.1 * np.sin(3 * np.pi * x), np.sin(2 * np.pi * x)
    lanczos_c = compile_c("lanczos_limit")
    infos = []

    def ours() -> float:
        start = time.perf_counter()
        sol = ti.integrate(chain, "B", q0, p0, h=0.05, n_steps=steps, progress=False, track_energies=False)
        infos.append(sol.info)
        return (time.perf_counter() - start) / steps * 1e3

    def theirs() -> float:
        out = subprocess.run([str(lanczos_c), str(size), str(steps)], check=True, capture_output=True, text=True)
        return float(out.stdout.splitlines()[-1].split()[0])

    c_ms, ours_ms = interleaved([theirs, ours], max(1, min(repeat, 3)))
    info = infos[-1]
    krylov = [dict(case=f"Krylov path: chain of n = {size} (A = 100 tridiag(−1, 2, −1), h√λ_max ≈ 1), method B, "
                        f"{steps} steps, tolerance {info['tolerance']:g}",
                   c=c_ms, per_step=ours_ms, per_iteration=ours_ms * steps / info["iterations"] * 1e3,
                   iterations=info["iterations_per_product"], products=info["products"] / steps)]
    return rows, krylov


def other_rows(smoke: bool) -> list[dict]:
    prob, (q0, p0) = fpu()
    centres = np.pi * np.array([1 / 4, 1 / 3, 1 / 2, 2 / 3, 3 / 4])
    points, t_end = (11, 100.0) if smoke else (591, 100_000.0)
    h_omega = np.concatenate([np.linspace(c - 0.05, c + 0.05, points) for c in centres])
    t = time.perf_counter()
    s = ti.scan(prob, "B", q0, p0, h_omega=h_omega, t_end=t_end, progress=False)
    seconds = time.perf_counter() - t
    steps = int(s.n_steps.sum())
    rows = [dict(case=f"Figure 3 scan: 5 × {points} step sizes to t = {t_end:g} ({steps:.3g} steps), "
                      f"{os.cpu_count()} threads", seconds=seconds, per=seconds * 1e9 / steps)]
    # The main job as `make reproduce` runs it (the package already built): the whole process.
    with tempfile.TemporaryDirectory() as out:
        command = [str(Path(sys.executable).with_name("trigint")), "reproduce", "all", "--out", out]
        t = time.perf_counter()
        subprocess.run(command + (["--quick"] if smoke else []), check=True, capture_output=True)
        seconds = time.perf_counter() - t
    rows.append(dict(case=f"The main job, `trigint reproduce all{' --quick' if smoke else ''}` "
                          f"({'reduced' if smoke else 'every figure at full resolution'}), {os.cpu_count()} cores",
                     seconds=seconds, per=float("nan")))
    return rows


#: The child of an interrupt measurement: starts a run far too long to finish, says so, and
#: prints the monotonic clock (system-wide on Linux) when the call has returned.
INTERRUPT_CHILD = """
import signal, sys, time
signal.signal(signal.SIGINT, signal.default_int_handler)  # even if this suite runs with SIGINT ignored
import warnings
import numpy as np, trigint as ti
warnings.simplefilter("ignore")
prob = ti.problems.fpu(); q0, p0 = ti.problems.fpu_initial()
kind = sys.argv[1]
if kind == "python":
    prob = ti.OscillatoryProblem(prob.omega, ti.PythonPotential(lambda q: float(q @ q) ** 2,
                                                                lambda q: 4 * float(q @ q) * q))
print("started", flush=True)
if kind == "ensemble":
    ds = ti.ensemble(prob, "B", q0, p0, h=0.01 * np.linspace(1.0, 1.1, 64), n_steps=10**10, progress=False)
    status = sorted(set(ds.status.values))[0]
else:
    status = ti.integrate(prob, "B", q0, p0, h=0.01, n_steps=10**10, save_every=10**6, progress=False).status
print(time.monotonic(), status, flush=True)
"""


def interrupt_rows(repeat: int) -> list[dict]:
    """Ctrl-C latency: the time from SIGINT to the call's return with status 'interrupted', for
    runs of 10¹⁰ steps (the tests check that Ctrl-C stops a run and keeps its samples; how fast,
    which depends on the machine's load, is measured here)."""
    cases = [("native", "integrate(), FPU (native), one trajectory"),
             ("python", "integrate(), PythonPotential, one trajectory"),
             ("ensemble", "ensemble(), FPU (native), 64 trajectories, all cores")]
    rows = []
    for kind, case in cases:
        latencies = []
        for _ in range(repeat):
            proc = subprocess.Popen([sys.executable, "-c", INTERRUPT_CHILD, kind], stdout=subprocess.PIPE,
                                    stderr=subprocess.DEVNULL, text=True)
            if proc.stdout.readline().strip() != "started":
                raise RuntimeError(f"interrupt benchmark ({kind}): the child did not start")
            time.sleep(1.0)
            sent = time.monotonic()
            proc.send_signal(signal.SIGINT)
            out, _ = proc.communicate(timeout=600)
            returned, status = out.split()
            if status != "interrupted":
                raise RuntimeError(f"interrupt benchmark ({kind}): status {status!r}, expected 'interrupted'")
            latencies.append((float(returned) - sent) * 1e3)
        rows.append(dict(case=case, median=statistics.median(latencies), worst=max(latencies), runs=repeat,
                         target=1000.0))
    return rows


def per_step(ns: float) -> str:
    return "" if np.isnan(ns) else f"{ns:.2f}"


def tangent_rows(n: int, count: int, repeat: int, smoke: bool) -> list[dict]:
    """The leading Lyapunov exponent (tangent step beside the step) against integrate() with
    energies streamed, on the same problem and steps; and a scan's exponent per lane."""
    rows = []
    prob, (q0, p0) = fpu()
    names = [f"x{i}" for i in range(3)]
    toda = ti.OscillatoryProblem([0.0, 3.0, 4.0], ti.ExpressionPotential(
        " + ".join(f"exp({names[i]} - {names[(i + 1) % 3]})" for i in range(3)), names))
    tq, tp = np.array([0.5, 0.2, -0.1]), np.array([0.3, 0.0, 0.1])
    wave = ti.problems.wave((1 << 10,) if smoke else (1 << 16,), rho=1.0, potential="u**4/4")
    (x,) = wave.mesh
    wq, wp = 0.1 * np.cos(x), np.zeros_like(x)
    steps_w = 20 if smoke else 200
    for label, pr, q, p, h, steps in [("FPU m = 3, native", prob, q0, p0, H, n // 10),
                                      ("Toda m = 3, ExpressionPotential", toda, tq, tp, 0.05, n // 10),
                                      (f"wave equation, {wave.dim} points", wave, wq, wp, 0.01, steps_w)]:
        a, b = interleaved([py_timer(single(pr, q, p, steps, True), steps),
                            py_timer(lambda pr=pr, q=q, p=p, h=h, steps=steps: ti.lyapunov(pr, "B", q, p, h=h,
                                                                                        n_steps=steps), steps)],
                           repeat)
        rows.append(row(f"{label}: leading exponent vs integrate()", "integrate(), energies streamed", a,
                        "lyapunov()", b, 2.5))
    h_omega = np.linspace(1.0, 3.0, count // 10 if smoke else count)
    t_end = 20.0 if smoke else 200.0

    def scan(extra):
        return lambda: ti.scan(prob, "B", q0, p0, h_omega=h_omega, t_end=t_end, threads=1, progress=False, **extra)

    work = int(np.sum(np.round(t_end / (h_omega / OMEGA))))
    a, b = interleaved([py_timer(scan({}), work), py_timer(scan({"lyapunov": 1}), work)], repeat)
    rows.append(row(f"scan over {h_omega.size} step sizes, 1 thread: with the leading exponent per lane",
                    "scan()", a, "scan(lyapunov=1)", b, 2.5))
    return rows


def write_report(limits, potentials, stiffness, krylov, others, interrupts, waves, path: Path,
                 tangents=(), isas=()) -> None:
    def table(rows):
        out = ["| workload | baseline | ns | trigint | ns | ratio | target |", "|---|---|---:|---|---:|---:|---:|"]
        for r in rows:
            if r.get("speedup"):
                ok = r["ratio"] >= r["target"]
                target = f"≥ {r['target']:g}× faster"
                ratio = f"{r['ratio']:.2f}× faster"
            else:
                ok = r["target"] is None or r["ratio"] <= r["target"]
                target = f"≤ {r['target']:g}" if r["target"] else ""
                ratio = f"{r['ratio']:.2f}"
            mark = "" if ok else " (missed)"
            out.append(f"| {r['case']} | {r['base_label']} | {r['base']:.2f} | {r['ours_label']} | {r['ours']:.2f} | "
                       f"{ratio}{mark} | {target} |")
        return out

    lines = [
        "# trigint benchmarks",
        "",
        f"Machine: {cpu_model()}, {os.cpu_count()} cores, {platform.system()} {platform.machine()}, "
        f"the kernels' {kernel_isa()} copies (C baselines: cc -O3 -march=native {' '.join(c_isa_flags())}".rstrip()
        + (f"; TRIGINT_ISA={isa_cap()}" if isa_cap() else "") + "), "
        f"Python {platform.python_version()}; {dt.date.today().isoformat()}. ns per (trajectory-)step, "
        "median of interleaved repetitions; ratio = trigint / baseline.",
        "",
        "## FPU kernels against the hand-written C limit (benchmarks/c/fpu_limit.c)",
        "",
        "FPU m = 3, ω = 50, hω = 2π/3, method B, two-step form. Energies streamed: max and min of H_ω, "
        "H_slow and H at every step, as `scalar-tracked` / `soa-tracked` do.",
        "",
        *table(limits),
        "",
        "## Every instruction-set copy",
        "",
        "The same FPU loops (and a 2¹⁴-point wave step, streamed) in a child process per copy "
        "(`TRIGINT_ISA`), and with none set (the planner's choice); the C loops compiled within the "
        "same limits (`-mno-avx512f` for the AVX2 copy, `-mno-avx` for the baseline). ns per "
        "(trajectory-)step, best of the repetitions; in brackets the C time and trigint / C.",
        "",
        *isa_table(isas),
        "",
        "## The user's own potentials",
        "",
        *table(potentials),
        "",
        "## A non-diagonal stiffness matrix",
        "",
        *table(stiffness),
        "",
        "One step of the one-step form, against benchmarks/c/lanczos_limit.c (the same chain, functions, "
        "stopping rule and tridiagonal solver in straight C).",
        "",
        "| Krylov path | C ms per step | trigint ms per step | ratio | target | µs per Lanczos iteration | "
        "iterations per product | products per step |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
        *[f"| {r['case']} | {r['c']:.2f} | {r['per_step']:.2f} | {r['per_step'] / r['c']:.2f}"
          f"{'' if r['per_step'] / r['c'] <= 1.3 else ' (missed)'} | ≤ 1.3 | {r['per_iteration']:.1f} | "
          f"{r['iterations']:.1f} | {r['products']:.1f} |" for r in krylov],
        "",
        "## Tangent maps and Lyapunov exponents",
        "",
        "ns per step of `lyapunov()` (one deviation vector, re-orthonormalized every 16 steps, MEGNO) "
        "against `integrate()` of the same problem and steps with energies streamed; target ≤ 2.5.",
        "",
        *table(tangents),
        "",
        "## Whole jobs",
        "",
        "| job | seconds | ns per step |",
        "|---|---:|---:|",
        *[f"| {r['case']} | {r['seconds']:.2f} | {per_step(r['per'])} |" for r in others],
        "",
        "## The wave equation (benchmarks/wave.py)",
        "",
        "u_tt = u_xx − u − u³ spectrally discretized, method B, h = 0.01; µs per step with H and every mode's "
        "energy streamed (their extremes at every step), against the same step in C with FFTW (FFTW_MEASURE) "
        "and in NumPy.",
        "",
        *wave_bench.report(*waves),
        "",
        "## Ctrl-C latency",
        "",
        "From SIGINT to the call's return with status 'interrupted', runs of 10¹⁰ steps interrupted "
        "after one second (the monotonic clock of both processes).",
        "",
        "| run | median ms | worst ms | runs | target |",
        "|---|---:|---:|---:|---:|",
        *[f"| {r['case']} | {r['median']:.0f} | {r['worst']:.0f} | {r['runs']} | ≤ {r['target']:.0f} ms"
          f"{'' if r['median'] <= r['target'] else ' (missed)'} |" for r in interrupts],
    ]
    path.write_text("\n".join(lines) + "\n")


def plot(rows: list[dict], path: Path) -> None:
    from trigint.plotting import _pyplot

    plt = _pyplot()
    rows = [r for r in rows if not r.get("speedup")]
    fig, ax = plt.subplots(figsize=(10, 0.45 * len(rows) + 1.2))
    y = np.arange(len(rows))
    ax.barh(y - 0.2, [r["base"] for r in rows], height=0.4, color="0.6", label="baseline")
    ax.barh(y + 0.2, [r["ours"] for r in rows], height=0.4, color="tab:blue", label="trigint")
    ax.set_yticks(y, [f"{r['case'][:60]} ({r['ours_label']} vs {r['base_label']})" for r in rows], fontsize=6)
    ax.invert_yaxis()
    ax.set_xscale("log")
    ax.set_xlabel("ns per (trajectory-)step, log scale")
    ax.legend(fontsize=7)
    ax.set_title(f"trigint vs baselines — {cpu_model()}, {dt.date.today().isoformat()}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="tiny sizes, to check that the suite runs")
    parser.add_argument("--out", type=Path, default=None, help="results file (default benchmarks/results.md)")
    args = parser.parse_args(argv)
    n, count, batch_steps, repeat = (200_000, 64, 2_000, 1) if args.smoke else (20_000_000, 1000, 200_000, 5)
    single(*fpu()[:1], *fpu()[1], 10, True)()  # load what the first call loads lazily
    limits = limit_rows(n, count, batch_steps, repeat)
    potentials = potential_rows(n, count, batch_steps, repeat)
    stiffness, krylov = stiffness_rows(n, count, batch_steps, repeat, args.smoke)
    others = other_rows(args.smoke)
    waves = (wave_bench.rows(BUILD, args.smoke), wave_bench.scaling(args.smoke))
    interrupts = interrupt_rows(1 if args.smoke else 5)
    tangents = tangent_rows(n, count, repeat, args.smoke)
    isas = isa_rows(n // 4, count, batch_steps // 4, repeat)
    out = args.out or (BUILD / "results-smoke.md" if args.smoke else HERE / "results.md")
    out.parent.mkdir(exist_ok=True)
    write_report(limits, potentials, stiffness, krylov, others, interrupts, waves, out, tangents, isas)
    plot(limits + potentials + stiffness, out.with_suffix(".png"))
    print(out.read_text())
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
