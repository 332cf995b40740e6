"""Runs `pip install -v ARGS…` and shows cargo's progress (its Compiling / Finished lines, warnings
and errors) instead of pip's silence during the long first build; on failure, the last 80 lines.
Exits with pip's status."""

import re
import subprocess
import sys
from collections import deque

SHOWN = re.compile(r"^\s*(Compiling|Finished|Building|Built wheel|Successfully installed|warning:|error)")


def main() -> int:
    cmd = [sys.executable, "-m", "pip", "install", "-v", *sys.argv[1:]]
    tail: deque[str] = deque(maxlen=80)
    with subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1) as proc:
        for line in proc.stdout:
            tail.append(line)
            if SHOWN.match(line):
                print(line.rstrip(), flush=True)
    if proc.returncode != 0:
        print("".join(tail), end="", file=sys.stderr)
    return proc.returncode


if __name__ == "__main__":
    sys.exit(main())
