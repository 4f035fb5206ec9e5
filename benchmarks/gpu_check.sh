#!/usr/bin/env bash
# The whole GPU check of issue 33 in one script, for a session with a GPU (an H200).
#
#   OUT=/some/folder bash benchmarks/gpu_check.sh [PART ...]
#
# PARTs, in this order by default: env tests ptxas engine chart
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
#
# Everything goes under $OUT (default: ./gpu-check), one file per part, and a summary line
# per part in $OUT/summary.txt. Each part has its own time limit (seconds, PART_LIMIT);
# the default parts together take about 8 minutes (ptxas needs no GPU: where device time is
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
[ ${#parts[@]} -eq 0 ] && parts=(env tests ptxas engine chart)

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
    *)
      echo "unknown part $part (env tests ptxas engine chart)" | tee -a "$OUT/summary.txt"
      exit 2 ;;
  esac
done
