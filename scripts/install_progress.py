"""Installs the package in editable form with its dependencies and an extra, showing cargo's
progress (its Compiling / Finished lines, warnings and errors) instead of pip's silence during
the long first build; on failure, the last 80 lines. Exits with the first failing pip's status.

    python scripts/install_progress.py [EXTRA]

Two pips run at once: one installs the dependencies (read from pyproject.toml), the other
builds the Rust extension and installs the package alone (``--no-deps``). Installing the
dependencies is about a minute of one core (mostly compiling their bytecode) that would
otherwise wait for the build; beside it, it fills a core the build leaves idle while the binding
crate's front end runs. The two touch different files.
"""

import re
import subprocess
import sys
import tempfile
import tomllib
from collections import deque
from pathlib import Path

SHOWN = re.compile(r"^\s*(Compiling|Finished|Building|Built wheel|Successfully installed|warning:|error)")
ROOT = Path(__file__).resolve().parent.parent


def requirements(extra: str | None) -> list[str]:
    """The dependencies of pyproject.toml, with those of `extra`."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    return [*project["dependencies"], *(project["optional-dependencies"][extra] if extra else [])]


def main() -> int:
    extra = sys.argv[1] if len(sys.argv) > 1 else None
    pip = [sys.executable, "-m", "pip", "install"]
    # (the dependencies' output goes to a file, not a pipe: nothing waits on a full pipe)
    with tempfile.TemporaryDirectory() as tmp, open(Path(tmp) / "dependencies.log", "w+") as log:
        listed = Path(tmp) / "requirements.txt"
        listed.write_text("\n".join(requirements(extra)) + "\n")
        deps = subprocess.Popen([*pip, "--quiet", "-r", str(listed)], stdout=log, stderr=subprocess.STDOUT)
        tail: deque[str] = deque(maxlen=80)
        with subprocess.Popen([*pip, "-v", "--no-deps", "-e", str(ROOT)], stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True, bufsize=1) as build:
            for line in build.stdout:
                tail.append(line)
                if SHOWN.match(line):
                    print(line.rstrip(), flush=True)
        deps.wait()
        log.seek(0)
        deps_output = log.read()
    if build.returncode != 0:
        print("".join(tail), end="", file=sys.stderr)
        return build.returncode
    if deps.returncode != 0:
        print(deps_output, end="", file=sys.stderr)
        print(f"trigint: installing the dependencies failed ({' '.join(requirements(extra))})", file=sys.stderr)
        return deps.returncode
    print(f"trigint: installed with the dependencies{f' and the {extra!r} extra' if extra else ''}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
