"""The ``trigint`` command. Thin: parse arguments, call the library, print or write files."""

from __future__ import annotations

import argparse
import math
import os
import sys
import warnings
from pathlib import Path


def _positive(flag: str, value: float) -> None:
    """A command-line number that must be finite and > 0, reported under its flag."""
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{flag}: must be finite and > 0, got {value:g}")


def _check_chain(args) -> None:
    """The FPU chain's flags (--m, --omega, --t-end), checked before any work and reported as typed."""
    if args.m < 1:
        raise ValueError(f"--m: the number of stiff springs must be a whole number >= 1, got {args.m}")
    _positive("--omega", args.omega)
    _positive("--t-end", args.t_end)


def _fpu(args) -> int:

    import trigint as ti
    from trigint.plotting import plot_deviation, save

    _check_chain(args)
    _positive("--h-omega", args.h_omega)
    prob = ti.problems.fpu(m=args.m, omega=args.omega)
    q0, p0 = ti.problems.fpu_initial(m=args.m, omega=args.omega)
    h = args.h_omega / args.omega
    if not 0 < h < math.inf:
        raise ValueError(f"--h-omega, --omega: the step size h = {args.h_omega:g}/{args.omega:g} "
                         f"{'underflows to 0' if h == 0 else 'overflows'} in double precision")
    steps = args.t_end / h  # too many for a double: the library says how many steps are allowed
    sol = ti.integrate(prob, args.method, q0, p0, h=h, t_end=args.t_end,
                       save_every=max(1, int(round(steps / 4000))) if math.isfinite(steps) else 1)
    print(sol)
    title = f"FPU, m = {args.m}, ω = {args.omega:g}, hω = {args.h_omega:.6g}, method {sol.method!r}"
    for path in save(plot_deviation(sol, title=title), Path(args.out) / "fpu_oscillatory_energy"):
        print(f"wrote {path}")
    return 0 if sol.success else 1


def _lyapunov(args) -> int:
    import numpy as np

    import trigint as ti
    from trigint.plotting import save

    _check_chain(args)
    if not 1 <= args.exponents <= 4 * args.m:
        raise ValueError(f"--exponents: how many exponents, a whole number from 1 to 4m = {4 * args.m}, "
                         f"got {args.exponents}")
    prob = ti.problems.fpu(m=args.m, omega=args.omega)
    q0, p0 = ti.problems.fpu_initial(m=args.m, omega=args.omega)
    if args.h_omega_range is not None:
        a, b, count = args.h_omega_range
        if not float(count).is_integer() or count < 1:
            raise ValueError(f"--h-omega-range: the count must be a whole number >= 1, got {count:g}")
        h_omega = np.linspace(a, b, int(count))
    else:
        h_omega = np.asarray(args.h_omega, dtype=float)
    if np.any(~np.isfinite(h_omega)) or np.any(h_omega <= 0):
        raise ValueError("--h-omega: every value must be finite and > 0")
    ds = ti.ensemble(prob, args.method, q0, p0, h=h_omega / args.omega, t_end=args.t_end, track_energies=False,
                     lyapunov=args.exponents, progress=False)
    names = list(ds.exponent.values)
    print(f"FPU m = {args.m}, omega = {args.omega:g}, method {args.method}, t = {args.t_end:g}")
    print("h*omega      " + "  ".join(f"{n:>10}" for n in names) + "       MEGNO  status")
    for i, x in enumerate(h_omega):
        row = "  ".join(f"{v:10.4g}" for v in ds.lyapunov.values[i])
        print(f"{x:<12.6g} {row}  {ds.megno.values[i]:10.4g}  {ds.status.values[i]}")
    if h_omega.size > 1:
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4))
        ax.plot(h_omega, ds.lyapunov.values[:, 0], ".-", lw=0.8)
        for k in range(1, int(h_omega.max() / np.pi) + 1):
            ax.axvline(k * np.pi, color="0.7", lw=0.6, ls="--")
        ax.set_xlabel(r"$h\omega$")
        ax.set_ylabel(r"leading exponent $\lambda_1$")
        ax.set_title(f"FPU m = {args.m}, ω = {args.omega:g}, method {args.method}, t = {args.t_end:g}")
        for path in save(fig, Path(args.out) / "fpu_lyapunov"):
            print(f"wrote {path}")
    return 0


def _resonance(args) -> int:
    from trigint.resonance import analyze

    h = getattr(args, "h", None)
    if h is None:
        largest = max(args.omega)
        if not largest > 0:
            raise ValueError(f"--h-omega needs a frequency > 0 in --omega, got {args.omega}; or give --h")
        h = args.h_omega / largest
    report = analyze(h, args.omega, method=args.method, N_max=args.N_max, delta=args.delta)
    print(report.to_json() if args.json else report)
    return 0


def _reproduce(args) -> int:
    from trigint import experiments
    from trigint.experiments.schema import SEED_MAX

    if not 0 <= args.seed <= SEED_MAX:
        raise ValueError(f"--seed: 0 (the paper's initial values) or a realization set s from 1 to "
                         f"{SEED_MAX:,}, got {args.seed}")
    figures = experiments.FIGURES if "all" in args.figures else args.figures
    unknown = [f for f in figures if f not in experiments.FIGURES]
    if unknown:
        raise ValueError(f"figures: unknown {unknown}; valid: {', '.join(experiments.FIGURES)} or all")
    claims = experiments.reproduce(figures, args.out, quick=args.quick, seed=args.seed)
    print(f"figures, data (NetCDF) and report.md are in {Path(args.out).resolve()}")
    return 0 if all(c.passed for c in claims) else 1


def _run_toml(args) -> int:
    from trigint import experiments

    spec = experiments.load(args.spec, quick=args.quick)
    claims, _ = experiments.run_spec(spec, args.out)
    return 0 if all(c.passed for c in claims) else 1


def _spec(args) -> int:
    from importlib import resources

    from trigint import experiments

    if args.figure not in experiments.FIGURES:
        raise ValueError(f"figure: unknown {args.figure!r}; valid: {', '.join(experiments.FIGURES)}")
    text = (resources.files("trigint.experiments") / "specs" / f"{args.figure}.toml").read_text(encoding="utf-8")
    sys.stdout.write(text)
    return 0


def _info(args) -> int:
    from trigint._config import config, format_config

    cfg = config()
    if args.json:
        import json

        print(json.dumps(cfg, indent=2))
    else:
        print(format_config(cfg))
    return 0


def build_parser() -> argparse.ArgumentParser:
    from trigint import __version__

    fmt = argparse.ArgumentDefaultsHelpFormatter
    parser = argparse.ArgumentParser(
        prog="trigint", formatter_class=fmt,
        description="Trigonometric integrators for highly oscillatory Hamiltonian systems: integrate the "
                    "FPU problem, check the non-resonance conditions at a step size, reproduce the paper's "
                    "figures, or run an experiment spec.",
        epilog="'trigint COMMAND --help' describes each command and its defaults.")
    parser.add_argument("--version", action="version", version=f"trigint {__version__}")
    parser.add_argument("--debug", action="store_true", help="show the full traceback on errors")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    # --debug after the command as well ('trigint fpu --debug'); SUPPRESS: absent there, it does
    # not overwrite a --debug given before the command
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                        help="show the full traceback on errors")
    p = sub.add_parser(
        "fpu", parents=[common], formatter_class=fmt, help="integrate the FPU problem and plot the oscillatory energy",
        description="Integrates the Fermi-Pasta-Ulam chain (m stiff springs of frequency omega, the initial "
                    "values of Hairer-Lubich-Wanner I.5) with one method and step size h = (h*omega)/omega, "
                    "prints the run's summary and plots the deviation of the oscillatory energy. A step size "
                    "with h*omega near a multiple of pi is a numerical resonance: the run warns.")
    p.add_argument("--m", type=int, default=3, help="number of stiff springs")
    p.add_argument("--omega", type=float, default=50.0, help="stiff frequency omega")
    p.add_argument("--h-omega", type=float, default=2 * 3.141592653589793 / 3,
                   help="h*omega, the step size times omega; the default is 2*pi/3")
    p.add_argument("--method", default="B", help="A-E, a filter alias (gautschi, deuflhard, ...), imex or "
                                                 "stormer-verlet")
    p.add_argument("--t-end", type=float, default=3000.0, help="end time")
    p.add_argument("--out", default="reproduction", help="output folder for the plot")
    p.set_defaults(run=_fpu)

    ly = sub.add_parser(
        "lyapunov", parents=[common], formatter_class=fmt,
        help="Lyapunov exponents of the integrator's map on the FPU problem, over step sizes",
        description="The leading finite-time Lyapunov exponents (Benettin's method on the exact tangent map "
                    "of the step) and the MEGNO indicator of the FPU chain integrated by one method, for each "
                    "step size h = (h*omega)/omega; prints a table and, for several step sizes, plots the "
                    "leading exponent against h*omega with the multiples of pi marked.")
    ly.add_argument("--m", type=int, default=3, help="number of stiff springs")
    ly.add_argument("--omega", type=float, default=50.0, help="stiff frequency omega")
    ly.add_argument("--h-omega", type=float, nargs="+", default=[2 * 3.141592653589793 / 3],
                    help="values of h*omega")
    ly.add_argument("--h-omega-range", type=float, nargs=3, metavar=("FROM", "TO", "COUNT"), default=None,
                    help="COUNT values of h*omega from FROM to TO (replaces --h-omega)")
    ly.add_argument("--method", default="B", help="A-E, a filter alias, imex or stormer-verlet")
    ly.add_argument("--t-end", type=float, default=1000.0, help="end time")
    ly.add_argument("--exponents", type=int, default=1, help="how many exponents (1 to 4m)")
    ly.add_argument("--out", default="reproduction", help="output folder for the plot")
    ly.set_defaults(run=_lyapunov)

    r = sub.add_parser("resonance", parents=[common], formatter_class=fmt,
                       help="the paper's non-resonance conditions and assumptions at a step size",
                       description="Evaluates, for step size h and frequencies omega, the conditions of "
                                   "Cohen, Gauckler, Hairer, Lubich (2015): kappa = min|sin(h w_j)| >= sqrt(h) "
                                   "(eq. 3.2), Assumption B on the filters, the numerical non-resonance "
                                   "condition |h k.w - 2 pi r| >= sqrt(h) (eq. 3.6) and the older "
                                   "|sin(h k.w / 2)| >= sqrt(h) (eq. 3.7), with the times they guarantee.")
    step = r.add_mutually_exclusive_group(required=True)
    step.add_argument("--h", type=float, default=argparse.SUPPRESS, help="step size")
    step.add_argument("--h-omega", type=float, default=argparse.SUPPRESS,
                      help="the step size as h times the largest frequency, as `trigint fpu` takes it")
    r.add_argument("--omega", type=float, nargs="+", required=True, default=argparse.SUPPRESS,
                   help="frequencies (0 = slow)")
    r.add_argument("--method", default="B", help="A-E, a filter alias, imex or stormer-verlet")
    r.add_argument("--N-max", dest="N_max", type=int, default=10, help="largest N to test")
    r.add_argument("--delta", type=float, default=0.25, help="delta of Theorem 3.1")
    r.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    r.set_defaults(run=_resonance)

    rp = sub.add_parser("reproduce", parents=[common], formatter_class=fmt,
                        help="regenerate the paper's figures and measure its claims",
                        description="Runs the paper's Figures 1-5 and two wave experiments (wave1: resonances; "
                                    "strata: energy strata, Gauckler, Hairer, Lubich, Weiss 2012) from their "
                                    "shipped specs, writes each figure (PNG, PDF), its data (NetCDF) and report.md, "
                                    "every claim measured with its tolerance. Exit status 1 if a claim fails.")
    rp.add_argument("figures", nargs="*", default=["all"], help="fig1 ... fig5, wave1, strata, or all")
    rp.add_argument("--out", default="reproduction", help="output folder")
    rp.add_argument("--quick", action="store_true", help="a reduced run that finishes in seconds")
    rp.add_argument("--seed", type=int, default=0,
                    help="0: the paper's initial values; s from 1 to 1,000,000: another realization set "
                         "(y0,1(0) + s*1e-10), to check that no claim passes by luck")
    rp.set_defaults(run=_reproduce)

    ru = sub.add_parser("run", parents=[common], formatter_class=fmt,
                        help="run an experiment spec (a TOML file)",
                        description="Runs one experiment spec: a TOML file such as a figure's spec written by "
                                    "'trigint spec fig3 > my.toml' and edited, or a figure's name. Writes the "
                                    "figure, its data and the measured claims into --out.")
    ru.add_argument("spec", help="path of the TOML spec, or fig1 ... fig5, wave1, strata")
    ru.add_argument("--out", default="reproduction", help="output folder")
    ru.add_argument("--quick", action="store_true", help="apply the spec's [quick] table: a reduced run")
    ru.set_defaults(run=_run_toml)

    sp = sub.add_parser("spec", parents=[common], formatter_class=fmt,
                        help="print a figure's experiment spec (TOML), to copy and edit",
                        description="Prints the spec that 'trigint reproduce' runs for one figure, as TOML on "
                                    "standard output: 'trigint spec fig3 > my.toml', edit my.toml, then "
                                    "'trigint run my.toml'.")
    sp.add_argument("figure", help="fig1 ... fig5, wave1, strata")
    sp.set_defaults(run=_spec)

    inf = sub.add_parser("info", parents=[common], formatter_class=fmt,
                         help="the CPU, the kernel copies and the plans chosen, versions (for bug reports)",
                         description="Prints the CPU model, the instruction-set copies of the kernels it may "
                                     "run, how copies are chosen (TRIGINT_PLAN, TRIGINT_ISA), the plan cache's "
                                     "location with the plan chosen per loop, and the versions.")
    inf.add_argument("--json", action="store_true", help="one JSON object instead of the text")
    inf.set_defaults(run=_info)
    return parser


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning from the library as one line on stderr, the way errors are printed."""
    print(f"trigint: warning: {message}", file=sys.stderr if file is None else file)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        if getattr(args, "out", None) is not None:
            # Before any work: an output folder that cannot be made fails now, not after the run.
            try:
                Path(args.out).mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise ValueError(f"--out: cannot create the folder {args.out!r}: {exc.strerror}") from None
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            code = args.run(args)
            sys.stdout.flush()  # a closed pipe shows here, not at exit
        return code
    except BrokenPipeError:
        # The reader went away (`trigint resonance ... | head`): stop quietly, as other tools do.
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())  # so that the flush at exit fails no more
        except (OSError, ValueError, AttributeError):
            pass
        return 141  # 128 + SIGPIPE, the shell's status for a writer whose pipe closed
    except KeyboardInterrupt:
        print("trigint: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # one clear line, never a traceback (unless --debug)
        if args.debug:
            raise
        kind = "" if isinstance(exc, ValueError | TypeError) else f"{type(exc).__name__}: "
        print(f"trigint: error: {kind}{exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
