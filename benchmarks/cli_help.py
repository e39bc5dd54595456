"""How long ``exactgrasp --help`` and each command's ``--help`` take, against a numpy import.

Each measurement is a fresh Python process (this interpreter, ``PYTHONPATH`` set to this
checkout): the baseline runs ``python -c "import numpy"``, the others
``python -m exactgrasp.cli [COMMAND] --help``. Runs are interleaved (baseline, then every
command, ``--repeat`` times) so that the machine's load affects all alike; reported per case:
the median wall seconds and its ratio to the baseline's median. The goal is a ratio of at most
3 for every case; the test suite checks what makes it so (no numerical library is imported by
``--help``, ``tests/test_cli.py``), not the time.

    python benchmarks/cli_help.py [--repeat 15] [--json results.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMMANDS = ("demo", "descriptor", "compare", "close", "inspect", "show", "overlap", "validate",
            "batch", "separate", "evaluate")  # fmt: skip
GOAL = 3.0


def _seconds(argv: list[str], env: dict[str, str]) -> float:
    start = time.perf_counter()
    # From the checkout: `python -m` puts the working folder first on the path.
    subprocess.run(argv, env=env, cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def measure(repeat: int) -> dict[str, dict[str, float]]:
    """``{case: {"median_s": ..., "ratio": ...}}``; the case ``"import numpy"`` is the baseline."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cases = {"import numpy": [sys.executable, "-c", "import numpy"]}
    cases["exactgrasp --help"] = [sys.executable, "-m", "exactgrasp.cli", "--help"]
    for command in COMMANDS:
        cases[f"exactgrasp {command} --help"] = [
            sys.executable, "-m", "exactgrasp.cli", command, "--help"
        ]  # fmt: skip
    for argv in cases.values():  # one unmeasured run each: the files are in the page cache
        _seconds(argv, env)
    times: dict[str, list[float]] = {case: [] for case in cases}
    for _ in range(repeat):
        for case, argv in cases.items():
            times[case].append(_seconds(argv, env))
    base = statistics.median(times["import numpy"])
    return {
        case: {"median_s": statistics.median(t), "ratio": statistics.median(t) / base}
        for case, t in times.items()
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=15, help="runs per case (default 15)")
    parser.add_argument("--json", default=None, help="also write the results here")
    args = parser.parse_args()
    results = measure(args.repeat)
    print(f"{'case':<32} {'median s':>9} {'x numpy':>8}")
    for case, row in results.items():
        flag = "" if row["ratio"] <= GOAL else f"  above the goal of {GOAL:g}x"
        print(f"{case:<32} {row['median_s']:9.3f} {row['ratio']:8.2f}{flag}")
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
