"""The member engine at scale (issue 33): steps/s of each build, their ratios, and a basin.

In one run, on the same model and step:

- **one core, today's compiled path**: a few members one after the other through the
  model's compiled RK4 blocks (``analysis.integrate.compiled.run_rk4``, the path of
  ``simulate``);
- **CPU build, all cores**: ``kernels.run_members`` on ``--members`` members (state only,
  no sections kept: the kernel's throughput), OpenMP over every core this process may use;
  and on **one core** (``threads=1``, members / cores: the same work per core), the ratio
  being the build's scaling over the cores;
- **CUDA build**, when a GPU is visible (CuPy installed): the same call on the GPU, at
  ``--gpu-members`` members (default 2²⁰, where an H200 reaches its throughput);
- **the tangent variant** (λ1, as charts run it: ``sweeps.points.kernel_points``), on the
  CPU build (all cores) and, with a GPU, the CUDA build, on the same members and steps: one
  tangent vector renormalised at every VC section (``--steps`` // N sections of N steps
  per VC period, the rest a transient), the sections kept; its steps/s (tangent steps: a
  member-step carrying the tangent) and its ratio to the state variant on the same build
  (issue 33's target on an H200: >= 3·10⁹ tangent steps/s);
- **a basin**: ``--size`` × ``--size`` initial states of the balanced rotor (50 N, N_b 8,
  8000 rpm; x from −20 to 30 µm, y from −20 to 20 µm) mapped by the featurizing mapper
  (0.5 s transient = 213 VC periods, 24 VC sections) on the GPU when there is one, else on
  the cores; with a GPU, the CPU build also maps a 100 × 100 subset of the same grid and the
  share of the subset labelled alike is printed.

    python benchmarks/bench_engine.py [--size 100] [--members 65536] [--steps 2000]
        [--gpu-members 1048576] [--cuda-variants] [--json]

``--cuda-variants`` (with a GPU) also times, in the same run, the CUDA build compiled with
fused multiply-adds (NVRTC ``--fmad=true``; the default keeps a·b + c two roundings, as the
CPU build does) and at 64 and 256 threads per block (default 128), each with the largest
difference of its final states from the default build's on the same 4096 members after
``--steps`` steps (relative to the largest state): where the GPU's throughput is lost, and
what a faster option would cost in agreement with the CPU build.

The whole check of issue 33 on an H200 is ``python benchmarks/bench_engine.py --size 1000
--json``. Steps/s are member-steps per second of wall time (the best of ``--repeat``); the
first call of each build (compilation) is timed apart.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

from analysis.integrate.compiled import library, run_rk4
from analysis.integrate.ensemble import StroboscopicMap
from analysis.integrate.kernels import Schedule, device_info, run_members
from analysis.integrate.kernels.cpu import cores
from analysis.integrate.kernels.devices import gpu_problem
from analysis.model import System
from analysis.stability.attractors import Range, basins, grid_states
from analysis.stability.attractors.featurizing import FeatureOptions
from analysis.stability.attractors.study import make_study

ROTOR = dict(n_balls=8, radial_load=50.0, speed_rpm=8000.0)
X, Y = ("x", -20e-6, 30e-6), ("y", -20e-6, 20e-6)
BASIN_FEATURES = FeatureOptions(transient=213, sections=24)
"""0.5 s of transient at 8000 rpm (VC period 2.35 ms) and 24 VC sections: issue 33's run."""
TANGENT_TARGET = 3e9
"""Issue 33's target for the CUDA build's tangent variant on an H200, tangent steps/s."""


def members_of(system: System, count: int) -> np.ndarray:
    """``count`` initial states near the spec's (seeded)."""
    rng = np.random.default_rng(1)
    return system.state * (1 + 0.5 * rng.standard_normal((count, system.n_state))) \
        + 1e-7 * rng.standard_normal((count, system.n_state))


def best_of(repeat: int, run) -> float:
    """The shortest wall time of ``repeat`` calls of ``run``, s."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return min(times)


def one_core(system: System, h: float, steps: int, members: int, repeat: int) -> dict:
    """Today's path: ``members`` members one after the other through the RK4 blocks."""
    lib, p, z = library(system.model, system.structure), system.p, members_of(system, members)
    run_rk4(lib, p, z[0], h, 10, 10)  # loaded
    seconds = best_of(repeat, lambda: [run_rk4(lib, p, z[i], h, steps, steps)
                                       for i in range(members)])
    return {"members": members, "steps": steps, "seconds": seconds,
            "steps_per_s": members * steps / seconds}


def tangent_schedule(steps: int, every: int) -> Schedule:
    """The chart's schedule of the tangent variant (``sweeps.points.kernel_points``) over
    ``steps`` RK4 steps: sections every ``every`` steps (one period), the tangent
    renormalised at each and its first quarter not averaged, the sections kept; the steps
    before the last whole section are a transient (fewer ``steps`` than ``every``: one
    section of ``steps``)."""
    every = min(every, steps)
    count = steps // every
    return Schedule(steps - count * every, every, count, tangent=True,
                    lyapunov_skip=count // 4)


def kernel(system: System, h: float, steps: int, members: int, repeat: int,
           device: str, threads: int | None = None, every: int | None = None) -> dict:
    """The member kernel's build on ``device`` on ``threads`` CPU threads (None: every
    core): the state variant (nothing kept), or with ``every`` the tangent variant by
    ``tangent_schedule`` (sections every ``every`` steps)."""
    z = members_of(system, members)
    tangent = every is not None
    schedule = tangent_schedule(steps, every) if tangent \
        else Schedule(0, steps, 1, keep_sections=False)
    start = time.perf_counter()
    run_members(system, z[:1], None, h, Schedule(0, 1, 1, tangent=tangent),
                device=device)  # built, loaded
    first = time.perf_counter() - start
    seconds = best_of(repeat, lambda: run_members(system, z, None, h, schedule,
                                                  device=device, threads=threads))
    out = {"members": members, "steps": steps, "seconds": seconds, "first_use_s": first,
           "steps_per_s": members * steps / seconds}
    if tangent:
        out["steps_per_section"] = int(schedule.counts("steps_per_section"))
        out["sections"] = schedule.max_sections
    return out


def cuda_variants(system: System, h: float, steps: int, members: int,
                  repeat: int) -> dict:
    """The CUDA build's throughput with other NVRTC options and block sizes (the module's
    ``NVRTC_OPTIONS`` and ``THREADS_PER_BLOCK`` set for the call, the kernel cache
    cleared), and each variant's largest final-state difference from the default build."""
    from analysis.integrate.kernels import cuda

    z = members_of(system, 4096)
    schedule = Schedule(0, steps, 1, keep_sections=False)
    reference = run_members(system, z, None, h, schedule, device="gpu").final
    scale = float(np.max(np.abs(reference)))
    default = (cuda.NVRTC_OPTIONS, cuda.THREADS_PER_BLOCK)
    plain = tuple(o for o in default[0] if not o.startswith("--fmad"))
    out = {}
    for name, options, threads in (("fmad", (*plain, "--fmad=true"), default[1]),
                                   ("tpb64", default[0], 64), ("tpb256", default[0], 256)):
        cuda.NVRTC_OPTIONS, cuda.THREADS_PER_BLOCK = options, threads
        cuda.cuda_kernel.cache_clear()
        try:
            row = kernel(system, h, steps, members, repeat, "gpu")
            final = run_members(system, z, None, h, schedule, device="gpu").final
        finally:
            cuda.NVRTC_OPTIONS, cuda.THREADS_PER_BLOCK = default
            cuda.cuda_kernel.cache_clear()
        row["options"], row["threads_per_block"] = list(options), threads
        row["max_difference_over_max_state"] = float(np.max(np.abs(final - reference)) / scale)
        out[name] = row
    return out


def basin(system: System, size: int, device: str) -> dict:
    """A ``size`` × ``size`` basin by the featurizing mapper on ``device``: the whole
    ``studies.basins`` call (cell scale, grid, kernel runs, clustering, each attractor
    described) after the kernel was built."""
    x, y = Range(*X, size), Range(*Y, size)
    study = make_study(system, size * size, mapper="features", device=device,
                       feature_options=BASIN_FEATURES)
    start = time.perf_counter()
    ds = basins(system, x, y, mapper="features", device=device,
                feature_options=BASIN_FEATURES)
    seconds = time.perf_counter() - start
    steps = (BASIN_FEATURES.transient + BASIN_FEATURES.sections) * study.map.steps
    out = {"size": size, "device": device, "seconds": seconds,
           "member_steps": size * size * steps,
           "attractors": {int(i): str(ds.nature.sel(attractor=i).values)
                          for i in ds.attractor.values},
           "fractions": {int(i): float(ds.fraction.sel(attractor=i))
                         for i in ds.attractor.values}}
    return out, ds


def subset_agreement(system: System, ds, size: int, sub: int) -> dict:
    """The CPU build's labels of every (size // sub)-th grid state against ``ds``'s: the
    share labelled alike (labels matched by their most common pairing)."""
    x, y = Range(*X, size), Range(*Y, size)
    stride = max(size // sub, 1)
    states = grid_states(system, x, y).reshape(size, size, -1)[::stride, ::stride]
    states = states.reshape(-1, system.n_state)
    ours = ds.basin.values[::stride, ::stride].ravel()
    study = make_study(system, len(states), mapper="features", device="cpu",
                       feature_options=BASIN_FEATURES)
    cpu = study.find(states).labels
    pairs, counts = np.unique(np.stack([cpu, ours], axis=1), axis=0, return_counts=True)
    best: dict[int, int] = {}
    for (a, _), c in sorted(zip(map(tuple, pairs), counts, strict=True), key=lambda t: -t[1]):
        best.setdefault(int(a), int(c))
    return {"states": len(states), "alike": sum(best.values()) / len(states)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=100, help="basin grid side")
    parser.add_argument("--members", type=int, default=1 << 16, help="CPU build members")
    parser.add_argument("--gpu-members", type=int, default=1 << 20)
    parser.add_argument("--one-core-members", type=int, default=256)
    parser.add_argument("--steps", type=int, default=2000, help="RK4 steps per member")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--cuda-variants", action="store_true",
                        help="also time fmad=true and 64/256 threads per block (GPU)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    system = System.make("balanced-rotor", **ROTOR)
    smap = StroboscopicMap.make(system, "vc")
    h = smap.dt
    gpu = gpu_problem() is None
    out: dict = {"model": "balanced-rotor", **ROTOR, "h_s": h, "cores": cores(),
                 "threads_env": os.environ.get("BEARINGDYN_THREADS"),
                 "load": os.getloadavg(),
                 "devices": [d.__dict__ for d in device_info()]}
    out["one_core"] = one_core(system, h, args.steps, args.one_core_members, args.repeat)
    out["cpu_build"] = kernel(system, h, args.steps, args.members, args.repeat, "cpu")
    out["cpu_over_one_core"] = out["cpu_build"]["steps_per_s"] / out["one_core"]["steps_per_s"]
    out["cpu_build_1"] = kernel(system, h, args.steps, max(args.members // cores(), 1),
                                args.repeat, "cpu", 1)
    out["cpu_scaling"] = out["cpu_build"]["steps_per_s"] / out["cpu_build_1"]["steps_per_s"]
    out["cpu_1_over_one_core"] = (out["cpu_build_1"]["steps_per_s"]
                                  / out["one_core"]["steps_per_s"])
    out["cpu_tangent"] = kernel(system, h, args.steps, args.members, args.repeat, "cpu",
                                every=smap.steps)
    out["cpu_tangent_over_state"] = (out["cpu_tangent"]["steps_per_s"]
                                     / out["cpu_build"]["steps_per_s"])
    if gpu:
        out["cuda_build"] = kernel(system, h, args.steps, args.gpu_members, args.repeat, "gpu")
        out["cuda_over_cpu"] = out["cuda_build"]["steps_per_s"] / out["cpu_build"]["steps_per_s"]
        out["cuda_over_one_core"] = (out["cuda_build"]["steps_per_s"]
                                     / out["one_core"]["steps_per_s"])
        out["cuda_tangent"] = kernel(system, h, args.steps, args.gpu_members, args.repeat,
                                     "gpu", every=smap.steps)
        out["cuda_tangent_over_state"] = (out["cuda_tangent"]["steps_per_s"]
                                          / out["cuda_build"]["steps_per_s"])
        out["cuda_tangent_over_cpu_tangent"] = (out["cuda_tangent"]["steps_per_s"]
                                                / out["cpu_tangent"]["steps_per_s"])
        out["cuda_tangent_target_met"] = out["cuda_tangent"]["steps_per_s"] >= TANGENT_TARGET
        if args.cuda_variants:
            out["cuda_variants"] = cuda_variants(system, h, args.steps, args.gpu_members,
                                                 args.repeat)
    else:
        out["cuda_build"] = out["cuda_tangent"] = None
        out["no_gpu"] = gpu_problem()
    out["basin"], ds = basin(system, args.size, "gpu" if gpu else "cpu")
    if gpu:
        out["basin"]["cpu_subset"] = subset_agreement(system, ds, args.size, 100)
    if args.json:
        print(json.dumps(out, indent=2, default=float))
        return
    print(f"balanced-rotor N_b 8, 50 N, 8000 rpm, h = {h:.4g} s, {out['cores']} core(s), "
          f"load {', '.join(f'{v:.2f}' for v in out['load'])}")
    for key, name in (("one_core", "one core, compiled RK4 blocks"),
                      ("cpu_build", "CPU build, all cores"),
                      ("cpu_build_1", "CPU build, one core"), ("cuda_build", "CUDA build"),
                      ("cpu_tangent", "CPU build, all cores, tangent"),
                      ("cuda_tangent", "CUDA build, tangent")):
        row = out[key]
        if row is None:
            if key == "cuda_build":
                print(f"  {name:32s} no GPU: {out['no_gpu']}")
            continue
        print(f"  {name:32s} {row['steps_per_s']:10.3e} steps/s ({row['members']} members "
              f"× {row['steps']} steps in {row['seconds']:.3g} s)")
    print(f"  CPU build / one core: {out['cpu_over_one_core']:.1f}×; CPU build all cores / "
          f"one core: {out['cpu_scaling']:.2f}× on {out['cores']} cores; CPU build on one "
          f"core / compiled path: {out['cpu_1_over_one_core']:.2f}×")
    print(f"  tangent / state, CPU build: {out['cpu_tangent_over_state']:.2f}× (λ1 with "
          f"{out['cpu_tangent']['sections']} section(s) of "
          f"{out['cpu_tangent']['steps_per_section']} steps)")
    if gpu:
        print(f"  CUDA / CPU build: {out['cuda_over_cpu']:.1f}×;  CUDA / one core: "
              f"{out['cuda_over_one_core']:.1f}×")
        print(f"  tangent / state, CUDA build: {out['cuda_tangent_over_state']:.2f}×;  "
              f"CUDA tangent / CPU tangent: {out['cuda_tangent_over_cpu_tangent']:.1f}×;  "
              f"target >= {TANGENT_TARGET:.0e} tangent steps/s (H200): "
              f"{'met' if out['cuda_tangent_target_met'] else 'NOT met'}")
        for name, row in out.get("cuda_variants", {}).items():
            print(f"  CUDA variant {name:19s} {row['steps_per_s']:10.3e} steps/s "
                  f"({row['steps_per_s'] / out['cuda_build']['steps_per_s']:.2f}× the "
                  f"default; final states differ by "
                  f"{row['max_difference_over_max_state']:.1e} of the largest)")
    b = out["basin"]
    print(f"  basin {b['size']} × {b['size']} on the {b['device']}: {b['seconds']:.3g} s "
          f"({b['member_steps'] / b['seconds']:.3e} steps/s); attractors "
          + ", ".join(f"{i}: {n} {100 * b['fractions'][i]:.1f} %"
                      for i, n in b["attractors"].items()))
    if "cpu_subset" in b:
        print(f"  CPU build on a {b['cpu_subset']['states']}-state subset: "
              f"{100 * b['cpu_subset']['alike']:.2f} % labelled alike")


if __name__ == "__main__":
    main()
