"""Benchmark: what the ``bearingdyn`` command costs before it does anything (issue 39, item
6: ``bearingdyn --help`` within 0.3 s and a refused option within 0.5 s on an idle core),
against references measured in the same run.

Each case is a fresh process (the console script next to this Python, else ``python -m
analysis.cli``), run from a temporary folder:

- ``--help``: the command list;
- ``chart --help``: one command's help;
- ``chart --bogus``: an option the command does not have (refused, exit code 2);
- ``--dt abc``: ``simulate vakharia2015 --dt abc`` (a value of the wrong type, exit code 2);
- ``bad spec``: ``simulate bad.toml -o r.nc``, a copy of the shipped vakharia2015 spec with
  its first term's kind misspelt (refused by the spec's validation, exit code 2);

and the references ``python -c pass`` (the interpreter's own start) and ``python -c "import
numpy"``. Timed, each the median of ``--repeat`` turns taken alternately so that load hits
all alike: the wall time and the CPU time (user + system, of the child process). On a busy
machine the CPU time is the better estimate of the wall time on an idle core.

Printed: the medians, each case over ``python -c pass`` and over ``import numpy``, and the
targets (0.3 s for the helps, 0.5 s for the refusals) judged on the CPU time and the wall
time. Every case's exit code and message are checked: a case that did not do what it
stands for is an error, not a number.

    python benchmarks/bench_startup.py [--repeat 10] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "modelgen" / "specs" / "vakharia2015.toml"
HELP_TARGET_S = 0.3
REFUSAL_TARGET_S = 0.5


def command() -> list[str]:
    """The ``bearingdyn`` console script of this Python's environment (else ``python -m
    analysis.cli``, the same entry)."""
    script = Path(sys.executable).parent / "bearingdyn"
    if script.is_file():
        return [str(script)]
    found = shutil.which("bearingdyn")
    return [found] if found else [sys.executable, "-m", "analysis.cli"]


def cases(folder: Path) -> dict[str, tuple[list[str], int, str, float | None]]:
    """name -> (argv, exit code, text the output must hold, target in s or None)."""
    bad = folder / "bad.toml"
    bad.write_text(SPEC.read_text(encoding="utf-8").replace(
        'kind = "hertz_contact"', 'kind = "hertz_contakt"', 1), encoding="utf-8")
    cli = command()
    return {
        "--help": ([*cli, "--help"], 0, "Commands", HELP_TARGET_S),
        "chart --help": ([*cli, "chart", "--help"], 0, "Usage:", HELP_TARGET_S),
        "chart --bogus": ([*cli, "chart", "--bogus"], 2, "No such option", REFUSAL_TARGET_S),
        "--dt abc": ([*cli, "simulate", "vakharia2015", "--dt", "abc"], 2, "--dt",
                     REFUSAL_TARGET_S),
        "bad spec": ([*cli, "simulate", str(bad), "-o", "r.nc"], 2, "hertz_contakt",
                     REFUSAL_TARGET_S),
        "python -c pass": ([sys.executable, "-c", "pass"], 0, "", None),
        "import numpy": ([sys.executable, "-c", "import numpy"], 0, "", None),
    }


def run_once(argv: list[str], code: int, text: str, folder: Path) -> tuple[float, float]:
    """(wall s, CPU s) of one run of ``argv``; raises when its exit code or output is not
    the case's."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    res = subprocess.run(argv, cwd=folder, capture_output=True, text=True,
                         env={**os.environ, "COLUMNS": "100"})
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode != code or text not in res.stdout + res.stderr:
        raise SystemExit(f"{' '.join(argv)}: exit code {res.returncode} (expected {code}), "
                         f"output {(res.stdout + res.stderr)[-300:]!r}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=10)
    parser.add_argument("--json", dest="json_out", help="write the numbers to this file")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        table = cases(folder)
        for argv, code, text, _ in table.values():  # warm: the file cache, compiled .pyc
            run_once(argv, code, text, folder)
        times: dict[str, dict[str, list[float]]] = {k: {"wall": [], "cpu": []} for k in table}
        for _ in range(args.repeat):
            for key, (argv, code, text, _) in table.items():
                wall, cpu = run_once(argv, code, text, folder)
                times[key]["wall"].append(wall)
                times[key]["cpu"].append(cpu)
    median = {k: {m: statistics.median(v) for m, v in t.items()} for k, t in times.items()}
    bare, numpy = median["python -c pass"], median["import numpy"]
    report = {"command": command(), "repeat": args.repeat, "median_s": median,
              "load_average": os.getloadavg(), "cores": os.cpu_count(), "cases": {}}
    print(f"{' '.join(command())}: median of {args.repeat} runs each; load average "
          f"{os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    print(f"  {'case':<16}{'wall s':>8}{'CPU s':>8}{'/pass':>7}{'/numpy':>8}   target")
    for key, (_, _, _, target) in table.items():
        wall, cpu = median[key]["wall"], median[key]["cpu"]
        over_bare, over_numpy = cpu / max(bare["cpu"], 1e-9), cpu / max(numpy["cpu"], 1e-9)
        verdict = ""
        if target is not None:
            verdict = (f"<= {target:g} s: CPU {'met' if cpu <= target else 'MISSED'}, wall "
                       f"{'met' if wall <= target else 'MISSED'}")
        report["cases"][key] = {"wall_s": wall, "cpu_s": cpu, "cpu_over_pass": over_bare,
                                "cpu_over_numpy": over_numpy, "target_s": target,
                                "cpu_within_target": None if target is None else cpu <= target,
                                "wall_within_target": None if target is None else wall <= target}
        print(f"  {key:<16}{wall:8.3f}{cpu:8.3f}{over_bare:7.1f}{over_numpy:8.2f}   {verdict}")
    print("  (ratios of CPU time; on a busy machine CPU s estimates the wall time on an idle "
          "core)")
    if args.json_out:
        with open(args.json_out, "w", encoding="utf-8") as handle:
            json.dump(report, handle, indent=2)


if __name__ == "__main__":
    main()
