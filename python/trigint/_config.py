"""What this installation runs on: the CPU, the kernel copies, the planner's choices, versions.

``trigint info`` prints it; ``show_config()`` is the same from Python. Paste it into a bug report.
"""

from __future__ import annotations

import platform
import sys


def config() -> dict:
    """The configuration as a dict (see :func:`show_config`)."""
    import numpy

    from . import __version__, _core

    kernels = dict(_core.kernel_config())
    return {
        "trigint": __version__,
        "core": kernels.pop("core_version"),
        "core_build": kernels.pop("core_build"),
        "python": sys.version.split()[0],
        "numpy": numpy.__version__,
        "platform": platform.platform(),
        **kernels,
    }


def format_config(cfg: dict) -> str:
    """``config()`` as the text ``show_config`` prints."""
    cap = cfg["isa_cap"]
    lines = [
        f"trigint {cfg['trigint']} (core {cfg['core']}, build {cfg['core_build']}), Python {cfg['python']}, "
        f"NumPy {cfg['numpy']}",
        f"platform:      {cfg['platform']}",
        f"CPU:           {cfg['cpu']}",
        f"features:      {', '.join(cfg['features']) or 'none of avx2, avx512f/vl/dq'}",
        f"kernel copies: {', '.join(cfg['copies'])}" + (f"  (capped by TRIGINT_ISA={cap})" if cap else ""),
        f"plan mode:     {cfg['plan_mode']}  (TRIGINT_PLAN=measure|estimate)",
        f"plan cache:    {cfg['plan_cache'] or 'none (no cache directory)'}",
    ]
    plans = cfg["plans"]
    if not plans:
        lines.append("plans:         none yet (each loop is measured the first time it runs)")
    else:
        lines.append(f"plans:         {len(plans)}")
        for p in plans:
            chosen = p["chosen"] or "measuring"
            lines.append(f"  {chosen:<9} {p['loop']}")
            if p["timings"]:
                lines.append(f"            [ns/step: {p['timings']}]")
    return "\n".join(lines)


def show_config() -> None:
    """Prints the CPU, the kernel copies it may run, the plan chosen per loop, the plan cache and
    the versions: what to paste into a bug report.

    Examples
    --------
    >>> import trigint as ti
    >>> ti.show_config()  # doctest: +ELLIPSIS
    trigint ... (core ...), Python ..., NumPy ...
    ...
    """
    print(format_config(config()))
