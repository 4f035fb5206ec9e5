"""Registers and spills of the CUDA member kernels (``nvcc -Xptxas -v``, no GPU needed).

For every shipped model (its default balls, and the extra ball counts given) and both
variants (states, tangent): registers per thread and spill stores/loads (bytes) as ptxas
reports them for ``--arch`` (sm_90: H100/H200). Needs ``nvcc`` on PATH.

    python benchmarks/ptxas_table.py [--arch sm_90] [--json out.json] [--only NAME ...]
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from analysis.integrate.kernels.cuda import NVRTC_OPTIONS, cuda_source
from analysis.model import System, available_models

EXTRA_BALLS = {"vakharia2015": (12,)}
"""Ball counts checked beside each model's default (the chart's N_b 5-12 ends at 12)."""


def ptxas_report(text: str, arch: str = "sm_90") -> dict:
    """Registers and spill stores/loads (bytes) of the kernel of ``text``, from ptxas."""
    with tempfile.TemporaryDirectory() as tmp:
        source = Path(tmp) / "member.cu"
        source.write_text(text)
        done = subprocess.run(["nvcc", f"-arch={arch}", "-cubin", "-Xptxas", "-v",
                               *NVRTC_OPTIONS, "-x", "cu", "-o", str(Path(tmp) / "m.cubin"),
                               str(source)], capture_output=True, text=True, timeout=900)
    report = done.stdout + done.stderr
    if done.returncode != 0:
        raise RuntimeError(report[-2000:])
    regs = [int(r) for r in re.findall(r"Used (\d+) registers", report)]
    spills = [(int(a), int(b)) for a, b in
              re.findall(r"(\d+) bytes spill stores, (\d+) bytes spill loads", report)]
    stack = [int(s) for s in re.findall(r"(\d+) bytes stack frame", report)]
    return {"registers": max(regs), "spill_stores": max(a for a, _ in spills),
            "spill_loads": max(b for _, b in spills), "stack": max(stack, default=0)}


def cases(only: list[str] | None) -> list[tuple[str, int | None]]:
    """(model, balls or None for the default) of every shipped model and extra balls."""
    out = []
    for name in available_models():
        if only and name not in only:
            continue
        out.append((name, None))
        out += [(name, n) for n in EXTRA_BALLS.get(name, ())]
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arch", default="sm_90")
    parser.add_argument("--json", type=Path)
    parser.add_argument("--only", nargs="*")
    args = parser.parse_args(argv)
    rows = []
    print(f"{'model':28s} {'N_b':>4s} {'variant':8s} {'regs':>5s} {'spill st/ld (B)':>16s} "
          f"{'stack':>6s} {'s':>5s}")
    for name, balls in cases(args.only):
        system = System.make(name, balls) if balls else System.make(name)
        for tangent in (False, True):
            start = time.perf_counter()
            row = {"model": name, "structure": list(system.structure),
                   "variant": "tangent" if tangent else "states",
                   **ptxas_report(cuda_source(system, tangent), args.arch)}
            rows.append(row)
            print(f"{name:28s} {system.structure[0] if system.structure else '-'!s:>4s} "
                  f"{row['variant']:8s} {row['registers']:5d} "
                  f"{row['spill_stores']:>7d}/{row['spill_loads']:<8d} {row['stack']:6d} "
                  f"{time.perf_counter() - start:5.0f}", flush=True)
    if args.json:
        args.json.write_text(json.dumps({"arch": args.arch, "rows": rows}, indent=1))
    return 0 if all(r["spill_stores"] == 0 and r["spill_loads"] == 0 for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
