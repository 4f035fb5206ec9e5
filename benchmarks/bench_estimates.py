"""Do the estimates hold (issue 39, item 3)? Each of the seven long commands (chart, basins,
attractors, sweep, calibrate, hb, torus) runs a small-but-not-tiny instance (10–60 s on
two idle cores) through the command line as a subprocess; the estimate it printed before
the work ("estimate: in all about … for the whole command", calibrate's host line "in all
about …") is read from its stderr and set against the wall time the subprocess took.

    python benchmarks/bench_estimates.py [--only chart sweep …] [--json] [--keep DIR]

Prints a table: command, estimate s, taken s, ratio (estimate / taken), the 1-minute load
average at the command's start and at its end, and whether the command's estimate said the
machine was loaded. The target: every ratio within [1/1.5, 1.5] on an idle machine; on a
loaded one the estimate says so (its "note: the machine was loaded …" line). The printed
estimate has two significant figures ("about 42 s", "about 3.5 min"): that rounding is
part of the ratio.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PRIORS = ("--prior", "rotor_mass:0.1:10:log", "--prior", "damping:10:3162:log",
          "--prior", "contact_stiffness:3e9:2e10:log")
DUFFING = ("--set", "linear_stiffness=1.0", "--set", "cubic_stiffness=0.5", "--set",
           "damping=0.1", "--set", "forcing_amplitude=0.3", "--set", "speed_rpm=12.0")
COMMANDS: dict[str, tuple[str, ...]] = {
    "chart": ("chart", "vakharia2015", "--x", "speed_rpm:3000:9000:40", "--y", "n_balls:8:11",
              "--transient", "1.0", "--revolutions", "200", "-o", "chart.nc"),
    "basins": ("basins", "vakharia2015", "--x", "x:-1e-5:1e-5:14", "--y", "y:-1e-5:1e-5:14",
               "-o", "basins.nc"),
    "attractors": ("attractors", "vakharia2015", "--samples", "100", "--box",
                   "x:-1e-5:1e-5", "--box", "y:-1e-5:1e-5", "-o", "attractors.nc"),
    "sweep": ("sweep", "vakharia2015", "--n-balls", "8", "--param", "speed_rpm", "--from",
              "3000", "--to", "9000", "--num", "60", "--transient", "0.5", "--samples", "300",
              "-o", "sweep.nc"),
    "calibrate": ("calibrate", "vakharia2015", "--target", "paper-table2", *PRIORS,
                  "--samples", "96", "--rounds", "2", "--seed", "0", "--executor",
                  "processes", "-o", "calibrate.nc"),
    "hb": ("hb", "duffing", "--period", "shaft", *DUFFING, "--harmonics", "60", "--param",
           "speed_rpm", "--from", "10", "--to", "16", "--ds-max", "0.1", "--max-points",
           "100", "-o", "hb.nc"),
    "torus": ("torus", "vakharia2015", "--frequencies", "shaft,vc", "--points", "33",
              "--n-balls", "10", "--set", "speed_rpm=5000", "-o", "torus.nc"),
}
"""Each command's arguments after ``bearingdyn`` (run in a fresh folder)."""
IN_ALL = re.compile(r"in all (?:about (?P<value>[0-9.]+) (?P<unit>s|min|h)|under a second)")
UNITS = {"s": 1.0, "min": 60.0, "h": 3600.0}
LOADED = "note: the machine was loaded"
TARGET = 1.5
"""An estimate within this factor of the time taken holds (issue 39)."""


def estimate_of(stderr: str) -> float | None:
    """The whole command's estimate (s) printed on ``stderr``: the first "in all about …";
    None when none was printed."""
    for line in stderr.splitlines():
        if line.startswith("estimate:"):
            found = IN_ALL.search(line)
            if found:
                if found.group("value") is None:
                    return 0.5
                return float(found.group("value")) * UNITS[found.group("unit")]
    return None


def load() -> float:
    """The 1-minute load average."""
    return os.getloadavg()[0]


def run(name: str, args: tuple[str, ...], folder: Path, timeout: float) -> dict:
    """Run ``bearingdyn *args`` in ``folder``; its estimate, wall time and loads."""
    exe = shutil.which("bearingdyn") or "bearingdyn"
    before = load()
    start = time.perf_counter()
    res = subprocess.run([exe, *args], cwd=folder, capture_output=True, text=True,
                         timeout=timeout, check=False)
    taken = time.perf_counter() - start
    estimate = estimate_of(res.stderr)
    lines = [line for line in res.stderr.splitlines()
             if line.startswith(("estimate:", "note:", "hint:"))]
    return {"command": name, "estimate_s": estimate, "taken_s": round(taken, 2),
            "ratio": round(estimate / taken, 3) if estimate else None,
            "load_start": round(before, 2), "load_end": round(load(), 2),
            "said_loaded": any(line.startswith(LOADED) for line in lines),
            "returncode": res.returncode, "estimate_lines": lines,
            "error": res.stderr.strip().splitlines()[-1:] if res.returncode else []}


def table(rows: list[dict]) -> str:
    """The rows as a Markdown table."""
    out = ["| command | estimate s | taken s | ratio | load at start | load at end | said "
           "loaded |", "|---|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        est = "—" if r["estimate_s"] is None else f"{r['estimate_s']:.3g}"
        ratio = "—" if r["ratio"] is None else f"{r['ratio']:.2f}"
        if r["returncode"]:
            ratio += f" (exit {r['returncode']})"
        out.append(f"| {r['command']} | {est} | {r['taken_s']:.1f} | {ratio} | "
                   f"{r['load_start']:.1f} | {r['load_end']:.1f} | "
                   f"{'yes' if r['said_loaded'] else 'no'} |")
    held = [r for r in rows if r["ratio"] and 1 / TARGET <= r["ratio"] <= TARGET]
    out.append(f"\n{len(held)}/{len(rows)} within {TARGET}x; {os.cpu_count()} cores")
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=list(COMMANDS), default=list(COMMANDS))
    parser.add_argument("--timeout", type=float, default=900.0,
                        help="seconds a command may run")
    parser.add_argument("--keep", type=Path, default=None,
                        help="run in this folder and keep the files (default: a temporary one)")
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--lines", action="store_true", help="also print each estimate")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-estimates-") as tmp:
        base = args.keep or Path(tmp)
        for name in args.only:
            folder = base / name
            folder.mkdir(parents=True, exist_ok=True)
            rows.append(run(name, COMMANDS[name], folder, args.timeout))
            print(f"{name}: {rows[-1]['estimate_s']} s estimated, {rows[-1]['taken_s']} s "
                  f"taken", file=sys.stderr, flush=True)
    if args.json:
        print(json.dumps(rows, indent=1))
        return
    print(table(rows))
    if args.lines:
        for r in rows:
            print(f"\n{r['command']}:", *r["estimate_lines"], *r["error"], sep="\n  ")


if __name__ == "__main__":
    main()
