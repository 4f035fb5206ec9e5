"""Speed and memory benchmark: one run of the paper's model through five implementations.

The benchmark itself lives in the package, ``analysis.reports.bench`` (what it runs and
compares is described there and in docs/performance.md); this script runs it from a source
checkout, as ``bearingdyn bench`` does:

    python benchmarks/bench_simulate.py [--repeat 5] [--duration 1] [--memory-duration 100]
"""

from analysis.reports.bench import main

if __name__ == "__main__":
    main()
