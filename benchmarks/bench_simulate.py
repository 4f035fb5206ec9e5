"""Speed and memory benchmark of bearingdyn's RK4 (docs/performance.md).

The same 1 s run of the paper's model (N_b = 8, Δt = 1e-5 s) through the compiled model,
the CasADi VM, a NumPy RK4 loop, SciPy solve_ivp and a hand-written numba RK4; medians and
ratios, the targets, the paths' agreement, and the peak memory of a 100 s run. The same as
``bearingdyn bench``; the implementation is ``analysis/bench.py``. About two minutes.

    python benchmarks/bench_simulate.py [--repeat 5] [--duration 1] [--memory-duration 100]

numba comes with the ``bench`` extra: ``python3 -m pip install -e '.[bench]'``.
"""

from analysis.bench import main

if __name__ == "__main__":
    main()
