#!/usr/bin/env bash
# The whole GPU check of issue 33 in one script, for a session with a GPU (an H200).
#
#   OUT=/some/folder bash benchmarks/gpu_check.sh [PART ...]
#
# PARTs, in this order by default: env tests ptxas engine chart basin
#   env     the machine: nvidia-smi, `bearingdyn devices --json`, the commit
#   tests   the GPU tests (CUDA build against the CPU build, states and λ1; the CPU twin;
#           ptxas spills of every shipped model): tests/integrate/test_kernels_gpu.py and
#           the kernel chart's tests
#   ptxas   registers and spills of every shipped model, both variants (sm_90)
#   engine  benchmarks/bench_engine.py --size 1000 --cuda-variants --json: steps/s of the
#           one-core compiled path, the CPU build (all cores and one), the CUDA build at 2^20
#           members (and with fmad=true, 64 and 256 threads per block), and the 1000 x 1000
#           basin (target: >= 1e10 steps/s, >= 100x the CPU build, basin <= 10 s)
#   chart   the 160 000-point chart on the GPU (20 000 speeds x N_b 5-12, lambda1; target
#           <= 30 s), then the host side of the same chart alone (kernel replayed)
#   basin   the featurizing 1000 x 1000 basin end to end: `bearingdyn basins ... --device gpu`
#           (features reduced on the device, 2n numbers per member copied back; wall time
#           of the whole command, file included), then in one process the same basin with
#           the device's features and with every section point copied back
#           (featurizing.DEVICE_FEATURES off): seconds of each, their ratio, members run
#           again for their points, and whether the labels agree (target: basin <= 10 s)
#
# Everything goes under $OUT (default: ./gpu-check), one file per part, and a summary line
# per part in $OUT/summary.txt. Each part has its own time limit (seconds, PART_LIMIT);
# the default parts together take about 9 minutes (ptxas needs no GPU: where device time is
# short, run `env tests engine chart` on the GPU machine and ptxas anywhere). Needs
# bearingdyn installed with its GPU extra (pip install -e ".[gpu-cuda13]" on a CUDA 13
# driver, ".[gpu]" on CUDA 12) and, for ptxas, nvcc on PATH; PYTHON names the interpreter
# (default python3).
set -u
OUT=${OUT:-gpu-check}
PART_LIMIT=${PART_LIMIT:-240}
PY=${PYTHON:-python3}
mkdir -p "$OUT" && OUT=$(cd "$OUT" && pwd)
cd "$(dirname "$0")/.." || exit 2
parts=("$@")
[ ${#parts[@]} -eq 0 ] && parts=(env tests ptxas engine chart basin)

run_part() {  # name, limit (s), command...: output to $OUT/name.txt, a line to summary.txt
  local name=$1 limit=$2
  shift 2
  local start=$SECONDS
  timeout "$limit" "$@" > "$OUT/$name.txt" 2>&1
  local rc=$?
  echo "$name: rc $rc, $((SECONDS - start)) s (limit $limit s)" | tee -a "$OUT/summary.txt"
}

env_report() {  # the machine and what bearingdyn sees
  date -u; git rev-parse HEAD; nproc; uptime
  nvidia-smi
  "$PY" -c "import cupy; print('cupy', cupy.__version__)"
  bearingdyn devices --json
}
export -f env_report
export PY

basin_report() {  # the featurizing basin, end to end, then features on the device or not
  local start=$SECONDS
  bearingdyn basins balanced-rotor --n-balls 8 --set radial_load=50 --speed-rpm 8000 \
    --x x:-20e-6:30e-6:1000 --y y:-20e-6:20e-6:1000 --mapper features --device gpu \
    -o "$OUT/basin.nc" || return $?
  echo "basin end to end (bearingdyn basins, 1000 x 1000, --device gpu): $((SECONDS - start)) s"
  "$PY" - <<'PYEOF'
import time

import numpy as np

from analysis.model import System
from analysis.stability.attractors import Range, basins, featurizing
from analysis.stability.attractors.featurizing import FeaturizingMapper

system = System.make("balanced-rotor", n_balls=8, radial_load=50.0, speed_rpm=8000.0)
x, y = Range("x", -20e-6, 30e-6, 1000), Range("y", -20e-6, 20e-6, 1000)
reruns, real = [], FeaturizingMapper.points_of


def counted(self, *args):
    out = real(self, *args)
    reruns.append(self.rerun)
    return out


FeaturizingMapper.points_of = counted
basins(system, Range("x", -20e-6, 30e-6, 4), Range("y", -20e-6, 20e-6, 4),
       mapper="features", device="gpu")  # kernels built, GPU warm
seconds, labels = {}, {}
for on in (True, False):
    featurizing.DEVICE_FEATURES = on
    reruns.clear()
    began = time.perf_counter()
    ds = basins(system, x, y, mapper="features", device="gpu")
    seconds[on], labels[on] = time.perf_counter() - began, ds.basin.values
    print(f"basin 1000 x 1000, features on the device {on}: {seconds[on]:.3g} s, "
          f"members run again {sum(reruns)}, attractors {ds.sizes['attractor']}")
print(f"ratio sections/features: {seconds[False] / seconds[True]:.3g}; labels equal: "
      f"{bool(np.array_equal(labels[True], labels[False]))}")
PYEOF
}
export -f basin_report
export OUT

for part in "${parts[@]}"; do
  case $part in
    env)
      run_part env 60 bash -c env_report ;;
    tests)
      run_part tests "$PART_LIMIT" "$PY" -m pytest -q -rs tests/integrate/test_kernels_gpu.py \
        tests/integrate/test_kernel_chart.py ;;
    ptxas)
      if command -v nvcc > /dev/null; then
        run_part ptxas "$PART_LIMIT" "$PY" benchmarks/ptxas_table.py --json "$OUT/ptxas.json"
      else
        echo "ptxas: skipped, no nvcc on PATH" | tee -a "$OUT/summary.txt"
      fi ;;
    engine)
      run_part engine "$PART_LIMIT" bash -c \
        "$PY benchmarks/bench_engine.py --size 1000 --cuda-variants --json > '$OUT/engine.json'" ;;
    chart)
      run_part chart "$PART_LIMIT" "$PY" benchmarks/bench_chart.py --speeds 20000 \
        --device gpu --reference-points 0 --host-points 0 --host-speeds 20000 ;;
    basin)
      run_part basin "$PART_LIMIT" bash -c basin_report ;;
    *)
      echo "unknown part $part (env tests ptxas engine chart basin)" | tee -a "$OUT/summary.txt"
      exit 2 ;;
  esac
done
