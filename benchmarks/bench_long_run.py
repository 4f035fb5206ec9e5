"""Peak memory of a long run written to netCDF: streamed (``bearingdyn simulate``) against the
run held in memory and then saved (``save_dataset(simulate(...))``), both measured here.

    python benchmarks/bench_long_run.py                 # 300 s at the default step (~3 min)
    python benchmarks/bench_long_run.py --duration 30   # quicker

Each path runs in its own process; its peak resident set size comes from ``getrusage`` of
the finished child. Target (issue "Hardened"): the streamed 300 s run peaks at <= 400 MiB.
The files are written to a temporary folder (about 1.2 GB each for 300 s) and removed.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

IN_MEMORY = """
import sys
from analysis.integrate.simulate import simulate
from analysis.io import save_dataset
save_dataset(simulate("vakharia2015", 8, duration=float(sys.argv[1]), transient=0.0),
             sys.argv[2])
"""


def peak_of(command: list[str]) -> tuple[float, float]:
    """(peak RSS in MiB, wall s) of ``command`` run to completion in a fresh child."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    start = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    if after <= before:
        raise RuntimeError("run the paths in order of growing memory (ru_maxrss is a maximum)")
    return after / 1024, wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=300.0, help="simulated s")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        streamed = peak_of([sys.executable, "-m", "analysis.cli", "simulate", "vakharia2015",
                            "--n-balls", "8", "--duration", str(args.duration),
                            "--transient", "0", "-o", os.path.join(tmp, "streamed.nc")])
        size = os.path.getsize(os.path.join(tmp, "streamed.nc")) / 2**20
        os.unlink(os.path.join(tmp, "streamed.nc"))
        held = peak_of([sys.executable, "-c", IN_MEMORY, str(args.duration),
                        os.path.join(tmp, "held.nc")])
    result = {"duration_s": args.duration, "file_MiB": round(size, 1),
              "streamed_peak_MiB": round(streamed[0], 1), "streamed_wall_s": round(streamed[1], 1),
              "in_memory_peak_MiB": round(held[0], 1), "in_memory_wall_s": round(held[1], 1),
              "ratio_streamed_to_in_memory": round(streamed[0] / held[0], 3),
              "target_streamed_peak_MiB": 400}
    verdict = "met" if args.duration < 300 or streamed[0] <= 400 else "MISSED"
    print(f"{args.duration:g} s run ({size:.0f} MiB file): streamed peak {streamed[0]:.0f} MiB "
          f"({streamed[1]:.1f} s), in memory {held[0]:.0f} MiB ({held[1]:.1f} s); ratio "
          f"{streamed[0] / held[0]:.3f}; target <= 400 MiB for 300 s: {verdict}")
    if args.json:
        args.json.write_text(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
