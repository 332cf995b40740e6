"""trigint's benchmark suite: `make bench` (full) and `make bench-smoke` (tiny, for CI).

Measures ns per step of trigint next to hand-written C loops compiled here with
`cc -O3 -march=native`, and writes benchmarks/results.md. Timings are the best of several
repetitions; the C loops print their own timing of the stepping loop alone.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import platform
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import trigint as ti

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import competitors  # noqa: E402

BUILD = HERE / "build"


def warm_up() -> None:
    """Loads what the first calls load lazily (xarray's array backends, thread pools)."""
    prob = ti.problems.fpu()
    q0, p0 = ti.problems.fpu_initial()
    ti.integrate(prob, "B", q0, p0, h=0.01, n_steps=10)
    ti.ensemble(prob, "B", q0, p0, h=0.01, n_steps=10, progress=False)


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def compile_c(name: str, defines: dict[str, int] | None = None) -> Path:
    """Compiles benchmarks/c/NAME.c with cc -O3 -march=native; returns the executable."""
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        raise RuntimeError("no C compiler (cc) found; the C baselines need one")
    BUILD.mkdir(exist_ok=True)
    flags = [f"-D{k}={v}" for k, v in (defines or {}).items()]
    exe = BUILD / (name + "".join(f"_{k}{v}" for k, v in (defines or {}).items()))
    subprocess.run([cc, "-O3", "-march=native", *flags, "-o", str(exe), str(HERE / "c" / f"{name}.c"), "-lm"],
                   check=True)
    return exe


def run_c(exe: Path, *args, repeat: int = 3) -> float:
    """Best ns/step reported by a C baseline."""
    best = float("inf")
    for _ in range(repeat):
        out = subprocess.run([str(exe), *map(str, args)], check=True, capture_output=True, text=True).stdout
        best = min(best, float(out.split()[0]))
    return best


def best_time(fn, repeat: int = 3) -> float:
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def case_single_trajectory(n_steps: int, repeat: int) -> list[dict]:
    """(a) FPU m = 3, ω = 50, hω = 2π/3, method B, one trajectory, save_every = n_steps."""
    prob = ti.problems.fpu(m=3, omega=50.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
    h = 2 * np.pi / 3 / 50.0
    c_ns = run_c(compile_c("fpu_scalar", {"M": 3}), n_steps, repeat=repeat)
    rows = [dict(case="(a) FPU m=3, B, 1 trajectory", impl="C loop, -O3 -march=native (no energies)",
                 ns=c_ns, ratio=1.0)]
    for track, label in ((True, "trigint, streaming max-deviation of every energy"),
                         (False, "trigint, energies only at samples")):
        for form in ("two-step", "one-step"):
            def run(form=form, track=track):
                ti.integrate(prob, "B", q0, p0, h=h, n_steps=n_steps, save_every=n_steps,
                             form=form, track_energies=track, progress=False)

            seconds = best_time(run, repeat)
            ns = seconds / n_steps * 1e9
            rows.append(dict(case="", impl=f"{label} ({form})", ns=ns, ratio=ns / c_ns))
    kernel = competitors.numba_kernel()
    competitors.numba_run(h, prob.omega, q0, p0, 10, kernel)  # compile outside the timing
    ns = best_time(lambda: competitors.numba_run(h, prob.omega, q0, p0, n_steps, kernel), repeat) / n_steps * 1e9
    rows.append(dict(case="", impl="Numba, the same recursion (compilation excluded)", ns=ns, ratio=ns / c_ns))
    few = max(n_steps // 100, 1000)
    ns = best_time(lambda: competitors.numpy_run(h, prob.omega, q0, p0, few), 1) / few * 1e9
    rows.append(dict(case="", impl=f"NumPy, the same recursion ({few:.0e} steps)", ns=ns, ratio=ns / c_ns))
    return rows


def case_scipy(t_end: float, rtols) -> list[dict]:
    """(a') FPU to t_end: trigint (B, hω = 2π/3 and hω = 0.5) against SciPy's DOP853."""
    prob = ti.problems.fpu(m=3, omega=50.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
    rows = []
    for h_omega in (2 * np.pi / 3, 0.5):
        h = h_omega / 50.0
        t = time.perf_counter()
        sol = ti.integrate(prob, "B", q0, p0, h=h, t_end=t_end, save_every=10**9, progress=False)
        seconds = time.perf_counter() - t
        deviation = sol.max_deviation["oscillatory"]
        rows.append(dict(case=f"(a') FPU to t = {t_end:g}", impl=f"trigint, method B, hω = {h_omega:.3g}",
                         unit="s", value=seconds, extra=f"max osc. energy deviation {deviation:.3g}"))
    for rtol in rtols:
        r = competitors.scipy_run(prob.omega, q0, p0, t_end, rtol)
        rows.append(dict(case="", impl=f"SciPy solve_ivp DOP853, rtol = {rtol:g}", unit="s", value=r["seconds"],
                         extra=f"max osc. energy deviation {r['oscillatory_deviation']:.3g} "
                               f"({r['rhs_evaluations']} right-hand sides)"))
    return rows


def case_scalar_experiment1(n_steps: int, repeat: int) -> list[dict]:
    """(c) Experiment 1's scalar problem, ω = 100, hω = 2π/3: the per-step overhead."""
    prob = ti.problems.experiment1(100.0)
    q0, p0 = ti.problems.experiment1_initial(100.0)
    h = 2 * np.pi / 3 / 100.0
    rows = []
    for track in (True, False):
        def run(track=track):
            ti.integrate(prob, "B", q0, p0, h=h, n_steps=n_steps, save_every=n_steps, track_energies=track,
                         progress=False)

        ns = best_time(run, repeat) / n_steps * 1e9
        rows.append(dict(case="(c) Experiment 1, one coordinate" if track else "",
                         impl=f"trigint, {'streamed energies' if track else 'energies at samples'}",
                         ns=ns, ratio=float("nan")))
    return rows


def case_large(m: int, n_steps: int, repeat: int) -> list[dict]:
    """(d) FPU with m = 1000 (2000 coordinates): the potential dominates."""
    prob = ti.problems.fpu(m=m, omega=50.0)
    q0, p0 = ti.problems.fpu_initial(m=m, omega=50.0)
    h = 2 * np.pi / 3 / 50.0
    c_ns = run_c(compile_c("fpu_scalar", {"M": m}), n_steps, repeat=repeat)
    rows = [dict(case=f"(d) FPU m={m} ({2 * m} coordinates)", impl="C loop, -O3 -march=native (no energies)",
                 ns=c_ns, ratio=1.0)]
    for track in (True, False):
        def run(track=track):
            ti.integrate(prob, "B", q0, p0, h=h, n_steps=n_steps, save_every=n_steps, track_energies=track,
                         progress=False)

        ns = best_time(run, repeat) / n_steps * 1e9
        rows.append(dict(case="", impl=f"trigint, {'streamed energies' if track else 'energies at samples'}",
                         ns=ns, ratio=ns / c_ns))
    kernel = competitors.numba_kernel()
    competitors.numba_run(h, prob.omega, q0, p0, 10, kernel)
    ns = best_time(lambda: competitors.numba_run(h, prob.omega, q0, p0, n_steps, kernel), repeat) / n_steps * 1e9
    rows.append(dict(case="", impl="Numba, the same recursion", ns=ns, ratio=ns / c_ns))
    ns = best_time(lambda: competitors.numpy_run(h, prob.omega, q0, p0, n_steps), 1) / n_steps * 1e9
    rows.append(dict(case="", impl="NumPy, the same recursion", ns=ns, ratio=ns / c_ns))
    return rows


SCALING_SCRIPT = """
import resource, sys, time, numpy as np, trigint as ti
kind, size = sys.argv[1], int(float(sys.argv[2]))
prob = ti.problems.fpu(); q0, p0 = ti.problems.fpu_initial(); h = 2 * np.pi / 3 / 50
ti.integrate(prob, "B", q0, p0, h=h, n_steps=10)
ti.ensemble(prob, "B", q0, p0, h=h, n_steps=10, progress=False)
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t = time.perf_counter()
if kind == "steps":
    ti.integrate(prob, "B", q0, p0, h=h, n_steps=size, save_every=size, progress=False)
    work = size
else:
    Q0, P0 = ti.perturb(q0, p0, np.linspace(0, 1e-3, size))
    ti.ensemble(prob, "B", Q0, P0, h=h, n_steps=20000, progress=False)
    work = size * 20000
seconds = time.perf_counter() - t
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(seconds, work, before, after)
"""


def case_scaling(steps, trajectories) -> list[str]:
    """Cost against steps (one trajectory) and trajectories (2·10⁴ steps each); peak memory."""
    lines = ["| run | size | seconds | ns per (trajectory-)step | peak RSS (MiB) |", "|---|---:|---:|---:|---:|"]
    for kind, sizes in (("steps", steps), ("trajectories", trajectories)):
        for size in sizes:
            out = subprocess.run([sys.executable, "-c", SCALING_SCRIPT, kind, str(size)], check=True,
                                 capture_output=True, text=True).stdout.split()
            seconds, work, _, after = float(out[0]), int(out[1]), int(out[2]), int(out[3])
            label = "one trajectory, steps" if kind == "steps" else "trajectories × 2·10⁴ steps"
            lines.append(f"| {label} | {size:.0e} | {seconds:.3g} | {seconds / work * 1e9:.2f} | {after / 1024:.0f} |")
    return lines


def plot(rows: list[dict], path: Path) -> None:
    from trigint.plotting import _pyplot

    plt = _pyplot()
    timed = [r for r in rows if "unit" not in r and np.isfinite(r["ns"])]
    labels = [(r["case"] or "") + "\n" + r["impl"] if r["case"] else r["impl"] for r in timed]
    fig, ax = plt.subplots(figsize=(11, 0.32 * len(timed) + 1.4))
    colors = ["tab:blue" if r["impl"].startswith("trigint") else "0.6" for r in timed]
    ax.barh(range(len(timed)), [r["ns"] for r in timed], color=colors)
    ax.set_yticks(range(len(timed)), [lab.replace("\n", " | ") for lab in labels], fontsize=6)
    ax.invert_yaxis()
    ax.set_xscale("log")
    ax.set_xlabel("ns per (trajectory-)step, log scale (blue: trigint; gray: C, Numba, NumPy)", fontsize=8)
    ax.set_title(f"FPU, method B, hω = 2π/3 — {cpu_model()}, {dt.date.today().isoformat()}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)


def case_batch(count: int, n_steps: int, repeat: int) -> list[dict]:
    """(b) FPU m = 3, B, `count` trajectories × `n_steps` steps (perturbed x₀,₁), one and all threads."""
    prob = ti.problems.fpu(m=3, omega=50.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
    h = 2 * np.pi / 3 / 50.0
    Q0, P0 = ti.perturb(q0, p0, np.linspace(0.0, 1e-3, count))
    c_ns = run_c(compile_c("fpu_soa", {"M": 3}), count, n_steps, repeat=repeat)
    rows = [dict(case=f"(b) FPU m=3, B, {count} trajectories", impl="C structure-of-arrays loop, -O3 -march=native "
                 "(no energies)", ns=c_ns, ratio=1.0)]
    threads_all = os.cpu_count() or 1
    for threads in sorted({1, threads_all}):
        for track, label in ((False, "energies at the first and last step"), (True, "streaming max-deviation")):
            def run(threads=threads, track=track):
                ti.ensemble(prob, "B", Q0, P0, h=h, n_steps=n_steps, threads=threads, track_energies=track,
                            chunk_size=count, progress=False)

            ns = best_time(run, repeat) / (count * n_steps) * 1e9
            rows.append(dict(case="", impl=f"trigint ensemble, {threads} thread{'s' * (threads > 1)}, {label}",
                             ns=ns, ratio=ns / c_ns))
    return rows


def case_figure3_scan(t_end: float, points: int) -> list[dict]:
    """The resonance scan of Figure 3: 5 panels × `points` step sizes, FPU to t_end, all cores."""
    prob = ti.problems.fpu(m=3, omega=50.0)
    q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
    centres = np.pi * np.array([1 / 4, 1 / 3, 1 / 2, 2 / 3, 3 / 4])
    h_omega = np.concatenate([np.linspace(c - 0.05, c + 0.05, points) for c in centres])
    t = time.perf_counter()
    s = ti.scan(prob, "B", q0, p0, h_omega=h_omega, t_end=t_end, progress=False)
    seconds = time.perf_counter() - t
    steps = int(s.n_steps.sum())
    return [dict(case=f"Figure 3 scan, 5 x {points} step sizes to t = {t_end:g} ({steps:.3g} steps)",
                 impl=f"trigint scan, {os.cpu_count()} threads", ns=seconds * 1e9 / steps, ratio=float("nan"),
                 unit="s", value=seconds)]


def case_resonance(repeat: int) -> list[dict]:
    """The resonance toolkit: analyze() for ℓ = 4 frequencies with N_max = 10 (11 969 vectors k)."""
    from trigint.resonance import analyze

    omega = 50.0 * np.sqrt([1.0, 2.0, 3.0, 5.0])
    seconds = best_time(lambda: analyze(0.01, omega, N_max=10), max(repeat, 3))
    return [dict(case="resonance.analyze, l=4, N_max=10", impl="trigint (NumPy)", ns=seconds * 1e9, ratio=float("nan"),
                 unit="ms", value=seconds * 1e3)]


def write_report(rows: list[dict], path: Path, n_steps: int, scaling: list[str]) -> None:
    lines = [
        "# trigint benchmarks",
        "",
        f"Machine: {cpu_model()}, {platform.system()} {platform.machine()}, "
        f"Python {platform.python_version()}; {dt.date.today().isoformat()}.",
        f"Single trajectory: {n_steps:.2g} steps; best of 3 runs.",
        "",
        "| case | implementation | ns per (trajectory-)step | × C loop |",
        "|---|---|---:|---:|",
    ]
    for r in rows:
        if "unit" in r:
            continue
        lines.append(f"| {r['case']} | {r['impl']} | {r['ns']:.2f} | {r['ratio']:.2f} |")
    lines += ["", "| other case | implementation | time | notes |", "|---|---|---:|---|"]
    for r in rows:
        if "unit" in r:
            value = f"{r['value']:.3g} {r['unit']}" if r["unit"] != "s" else f"{r['value']:.3g} s"
            lines.append(f"| {r['case']} | {r['impl']} | {value} | {r.get('extra', '')} |")
    lines += ["", "Speed-up of trigint over each competitor of the same case (competitor time / trigint time; "
              "trigint with streamed energies, and without):", ""]
    group: list[dict] = []
    for r in [*rows, {"case": "end"}]:
        if r.get("case") and group:
            ours = [g for g in group if g["impl"].startswith("trigint")]
            for g in group:
                if not g["impl"].startswith("trigint") and ours:
                    ratios = ", ".join(f"{g['ns'] / o['ns']:.2f}×" for o in ours)
                    lines.append(f"- {group[0]['case']}, {g['impl']}: {ratios}")
            group = []
        if "unit" not in r and r.get("case") != "end":
            group.append(r)
    lines += ["", "Scaling: cost linear in steps and trajectories, memory flat in steps:", "", *scaling]
    path.write_text("\n".join(lines) + "\n")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--smoke", action="store_true", help="tiny sizes, to check the suite runs")
    parser.add_argument("--out", type=Path, default=None, help="results file (default benchmarks/results.md)")
    args = parser.parse_args(argv)
    n_steps = 200_000 if args.smoke else 20_000_000
    repeat = 1 if args.smoke else 3
    warm_up()
    rows = case_single_trajectory(n_steps, repeat)
    rows += case_batch(1000, 2_000 if args.smoke else 200_000, repeat)
    rows += case_scalar_experiment1(n_steps, repeat)
    rows += case_large(1000, 2_000 if args.smoke else 200_000, repeat)
    rows += case_scipy(10.0 if args.smoke else 100.0, (1e-6,) if args.smoke else (1e-6, 1e-9))
    rows += case_figure3_scan(100.0 if args.smoke else 100_000.0, 11 if args.smoke else 591)
    rows += case_resonance(repeat)
    scaling = case_scaling((1e4, 1e5) if args.smoke else (1e5, 1e6, 1e7, 1e8),
                           (10, 100) if args.smoke else (10, 100, 1000, 10000))
    out = args.out or (BUILD / "results-smoke.md" if args.smoke else HERE / "results.md")
    out.parent.mkdir(exist_ok=True)
    write_report(rows, out, n_steps, scaling)
    plot(rows, out.with_suffix(".png"))
    print(out.read_text())
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
