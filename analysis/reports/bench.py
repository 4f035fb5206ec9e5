"""Speed and memory benchmark: one run of the paper's model through five implementations.

The run: ``vakharia2015``, N_b = 8, 1 s simulated from the spec's initial state with the
paper's RK4 step Δt = 1e-5 s (1e5 steps, every state kept), through

    (a) ``simulate()``, RK4 compiled to C (``analysis.integrate.compiled``),
    (b) ``simulate(compiled=False)``, the same RK4 blocks in the CasADi virtual machine,
    (c) a plain NumPy RK4 loop (one Python iteration per step, NumPy over the balls),
    (d) SciPy ``solve_ivp`` (RK45, adaptive) with the NumPy right-hand side of (c),
    (e) a hand-written numba RK4 (the practical limit): one sin/cos of the cage angle per
        evaluation, the ball angles by angle addition, δ^1.5 as δ·√δ behind a branch.

(c)-(e) are written here by hand from the paper's equations (docs/model.md), not from the
generated code; ``check_reference`` compares their right-hand side with the generated one
before anything is timed. Timings are medians of ``repeat`` runs in one process, the fast
paths interleaved so a slow moment of the machine hits them alike. The paper's parameters
make the motion sensitive to rounding (docs/numerics.md), so the paths are compared on
their final states in a non-chaotic setting (damping 2000 N·s/m) instead. Peak memory is
the peak resident set size (``VmHWM`` of ``/proc/self/status``; ``getrusage`` elsewhere)
of a fresh Python process that runs a long decimated simulation. About two minutes
(docs/performance.md).

    bearingdyn bench [--repeat 5] [--duration 1] [--memory-duration 100]
    python benchmarks/bench_simulate.py [--repeat 5]   (the same, from a source checkout)

Part of the installed package (``bearingdyn bench`` needs no source tree);
``benchmarks/bench_simulate.py`` is a thin script over ``main``. numba comes with the
``bench`` extra: ``python3 -m pip install -e '.[bench]'``.
"""

from __future__ import annotations

import json
import math
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from analysis.integrate.compiled import library, run_rk4
from analysis.integrate.simulate import simulate
from analysis.model import load_model

MODEL, N_BALLS, DT = "vakharia2015", 8, 1e-5
CALM = {"damping": 2000.0}
"""Non-chaotic parameters for comparing final states (the rotor settles)."""
IVP_TOL = {"rtol": 1e-9, "atol": 1e-14}
AGREEMENT = 1e-9
TARGET_NUMBA, TARGET_SCIPY = 1.2, 300.0


@dataclass(frozen=True)
class Reference:
    """The paper-literal model's constants for the hand-written paths (SI units)."""

    shaft_speed: float  # ω, rad/s
    cage_speed: float  # ω_cage, rad/s
    stiffness: float  # k, N/m^1.5
    clearance: float  # γ0, m
    centrifugal: float  # P_c of paper Eq. 9, N, subtracted from every ball
    damping: float  # c, N·s/m
    radial_load: float  # P_r, N
    unbalance: float  # P_u, N
    mass: float  # M_R, kg
    cos_phi: np.ndarray  # cos, sin of the balls' angular offsets 2π i / N_b
    sin_phi: np.ndarray

    @classmethod
    def from_parameters(cls, values: dict[str, float], n_balls: int) -> Reference:
        di, do = values["inner_race_diameter"], values["outer_race_diameter"]
        rpm = values["speed_rpm"]
        cage_rpm = rpm * di / (di + do)  # paper Eq. 1
        pc = 2.26e-11 * (values["ball_diameter"] * 1e3) ** 2 * cage_rpm * (
            values["pitch_diameter"] * 1e3)  # paper Eq. 9: mm and rpm
        phi = [2 * math.pi * i / n_balls for i in range(n_balls)]
        return cls(shaft_speed=math.pi * rpm / 30, cage_speed=math.pi * cage_rpm / 30,
                   stiffness=values["contact_stiffness"],
                   clearance=values["radial_clearance"], centrifugal=pc,
                   damping=values["damping"], radial_load=values["radial_load"],
                   unbalance=values["unbalance_force"], mass=values["rotor_mass"],
                   cos_phi=np.array([math.cos(a) for a in phi]),
                   sin_phi=np.array([math.sin(a) for a in phi]))

    def scalars(self) -> tuple:
        return (self.shaft_speed, self.cage_speed, self.stiffness, self.clearance,
                self.centrifugal, self.damping, self.radial_load, self.unbalance, self.mass,
                self.cos_phi, self.sin_phi)


def numpy_rhs(ref: Reference, t: float, z: np.ndarray) -> np.ndarray:
    """dz/dt of the paper's model with NumPy over the balls."""
    c0, s0 = math.cos(ref.cage_speed * t), math.sin(ref.cage_speed * t)
    c = ref.cos_phi * c0 - ref.sin_phi * s0
    s = ref.sin_phi * c0 + ref.cos_phi * s0
    delta = z[0] * c + z[1] * s - ref.clearance
    q = np.where(delta > 0, ref.stiffness * delta * np.sqrt(np.abs(delta)), 0.0)
    q -= ref.centrifugal
    wt = ref.shaft_speed * t
    fx = ref.radial_load - ref.damping * z[2] + ref.unbalance * math.cos(wt) - q @ c
    fy = -ref.damping * z[3] + ref.unbalance * math.sin(wt) - q @ s
    return np.array([z[2], z[3], fx / ref.mass, fy / ref.mass])


def numpy_rk4(ref: Reference, z0: np.ndarray, h: float, n_steps: int) -> np.ndarray:
    """Classical RK4 in a Python loop; every state, shape (n_steps + 1, 4)."""
    out = np.empty((n_steps + 1, 4))
    out[0] = z = np.asarray(z0, dtype=float)
    for i in range(n_steps):
        t = i * h
        k1 = numpy_rhs(ref, t, z)
        k2 = numpy_rhs(ref, t + h / 2, z + h / 2 * k1)
        k3 = numpy_rhs(ref, t + h / 2, z + h / 2 * k2)
        k4 = numpy_rhs(ref, t + h, z + h * k3)
        z = z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out[i + 1] = z
    return out


def scipy_rk45(ref: Reference, z0: np.ndarray, duration: float) -> Any:
    """SciPy ``solve_ivp`` RK45 with the NumPy right-hand side (tolerances ``IVP_TOL``)."""
    from scipy.integrate import solve_ivp

    return solve_ivp(lambda t, z: numpy_rhs(ref, t, z), (0.0, duration), z0, method="RK45",
                     **IVP_TOL)


def _scalar_rhs(t, x, y, vx, vy, w, wc, k, gam, pc, c, pr, pu, mass, cphi, sphi):
    """dz/dt with scalar arithmetic: the body of the numba path (e)."""
    c0 = math.cos(wc * t)
    s0 = math.sin(wc * t)
    fx = pr - c * vx + pu * math.cos(w * t)
    fy = -c * vy + pu * math.sin(w * t)
    for i in range(cphi.shape[0]):
        ci = cphi[i] * c0 - sphi[i] * s0
        si = sphi[i] * c0 + cphi[i] * s0
        d = x * ci + y * si - gam
        q = -pc
        if d > 0.0:
            q += k * (d * math.sqrt(d))
        fx -= q * ci
        fy -= q * si
    return vx, vy, fx / mass, fy / mass


def numba_rk4() -> Callable | None:
    """The numba RK4 ``rk4(ref, z0, h, n_steps) -> states (n_steps + 1, 4)``, or None
    without numba."""
    try:
        import numba
    except ImportError:
        return None
    jit = numba.njit(error_model="numpy")
    rhs = jit(_scalar_rhs)

    @jit
    def kernel(z0, h, n, w, wc, k, gam, pc, c, pr, pu, mass, cphi, sphi):
        out = np.empty((n + 1, 4))
        x, y, vx, vy = z0[0], z0[1], z0[2], z0[3]
        out[0, 0], out[0, 1], out[0, 2], out[0, 3] = x, y, vx, vy
        for i in range(n):
            t, g = i * h, h / 2
            a1, b1, c1, d1 = rhs(t, x, y, vx, vy,
                                 w, wc, k, gam, pc, c, pr, pu, mass, cphi, sphi)
            a2, b2, c2, d2 = rhs(t + g, x + g * a1, y + g * b1, vx + g * c1, vy + g * d1,
                                 w, wc, k, gam, pc, c, pr, pu, mass, cphi, sphi)
            a3, b3, c3, d3 = rhs(t + g, x + g * a2, y + g * b2, vx + g * c2, vy + g * d2,
                                 w, wc, k, gam, pc, c, pr, pu, mass, cphi, sphi)
            a4, b4, c4, d4 = rhs(t + h, x + h * a3, y + h * b3, vx + h * c3, vy + h * d3,
                                 w, wc, k, gam, pc, c, pr, pu, mass, cphi, sphi)
            x += h / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
            y += h / 6 * (b1 + 2 * b2 + 2 * b3 + b4)
            vx += h / 6 * (c1 + 2 * c2 + 2 * c3 + c4)
            vy += h / 6 * (d1 + 2 * d2 + 2 * d3 + d4)
            out[i + 1, 0], out[i + 1, 1], out[i + 1, 2], out[i + 1, 3] = x, y, vx, vy
        return out

    return lambda ref, z0, h, n: kernel(np.asarray(z0, dtype=float), h, n, *ref.scalars())


def check_reference(model: Any, values: dict[str, float], n_balls: int,
                    rtol: float = 1e-12) -> None:
    """The hand-written right-hand side equals the generated one at random states."""
    ref = Reference.from_parameters(values, n_balls)
    rhs = model.functions(n_balls).rhs
    p = model.parameter_vector(values)
    rng = np.random.default_rng(0)
    for _ in range(50):
        z = np.concatenate([rng.uniform(-2e-5, 2e-5, 2), rng.uniform(-0.05, 0.05, 2)])
        t = rng.uniform(0, 1)
        want = np.asarray(rhs(t, z, p)).ravel()
        got = numpy_rhs(ref, t, z)
        if not np.allclose(got, want, rtol=rtol, atol=rtol * np.abs(want[2:]).max()):
            raise AssertionError(f"the benchmark's hand-written model differs from the "
                                 f"generated '{model.name}' at t={t}, z={z}: {got} vs {want}")


@dataclass
class Row:
    key: str
    label: str
    seconds: float | None = None
    note: str = ""
    final_calm: np.ndarray | None = field(default=None, repr=False)


@dataclass
class Result:
    rows: dict[str, Row]
    repeat: int
    duration: float
    backend: str
    memory: dict[str, float] | None = None


def _timed(fn: Callable[[], Any]) -> tuple[float, Any]:
    start = time.perf_counter()
    out = fn()
    return time.perf_counter() - start, out


def _final(states: np.ndarray) -> np.ndarray:
    return np.asarray(states, dtype=float)[-1, :4]


def run_benchmark(repeat: int = 5, duration: float = 1.0, memory_duration: float = 100.0,
                  memory_save_every: int = 100, progress: Callable[[str], None] = print
                  ) -> Result:
    """Time the paths (median of ``repeat``), compare them, measure peak memory."""
    model = load_model(MODEL)
    n_steps = round(duration / DT)
    z0 = model.initial_state
    values, calm_values = model.defaults, model.parameters(CALM)
    for v in (values, calm_values):
        check_reference(model, v, N_BALLS)
    ref, calm = (Reference.from_parameters(v, N_BALLS) for v in (values, calm_values))
    backend = library(model, N_BALLS).backend  # compiles once, or loads from the cache

    def engine(compiled: bool, v: dict[str, float]) -> Callable[[], np.ndarray]:
        lib, p = library(model, N_BALLS, compiled), model.parameter_vector(v)
        return lambda: run_rk4(lib, p, z0, DT, n_steps).T

    def end_to_end(**params: float) -> Callable[[], np.ndarray]:
        def run() -> np.ndarray:
            ds = simulate(model, N_BALLS, duration=duration, transient=0.0, dt=DT, **params)
            return np.stack([ds[v].values for v in ("x", "y", "vx", "vy")], axis=1)
        return run

    compiled_label = ("bearingdyn RK4, compiled C" if backend == "compiled"
                      else "bearingdyn RK4 (no C compiler: CasADi VM)")
    rows = {
        "a": Row("a", compiled_label, note="analysis.integrate.compiled.run_rk4: states array"),
        "a+": Row("a+", "(a) through simulate()",
                  note="plus input checks, blow-up checks, xarray Dataset, provenance"),
        "b": Row("b", "bearingdyn RK4, CasADi VM", note="run_rk4, compiled=False"),
        "c": Row("c", "NumPy RK4 loop, Python per step"),
        "d": Row("d", "SciPy solve_ivp RK45, Python rhs"),
        "e": Row("e", "numba RK4, hand-written", note="JIT compilation not timed"),
    }
    paths: dict[str, tuple[Callable[[], Any], Callable[[], Any]]] = {
        "a": (engine(True, values), engine(True, calm_values)),
        "a+": (end_to_end(), end_to_end(**CALM)),
        "b": (engine(False, values), engine(False, calm_values)),
        "c": (lambda: numpy_rk4(ref, z0, DT, n_steps), lambda: numpy_rk4(calm, z0, DT, n_steps)),
        "d": (lambda: scipy_rk45(ref, z0, duration), lambda: scipy_rk45(calm, z0, duration)),
    }
    import scipy.integrate  # noqa: F401  (imported before the clock starts)

    kernel = numba_rk4()
    if kernel is None:
        rows["e"].note = "numba not installed: pip install -e '.[bench]'"
    else:
        kernel(ref, z0, DT, 10)  # JIT compilation
        paths["e"] = (lambda: kernel(ref, z0, DT, n_steps), lambda: kernel(calm, z0, DT, n_steps))
    times: dict[str, list[float]] = {k: [] for k in paths}
    progress(f"timing {', '.join(f'({k})' for k in paths)}: {repeat} runs each …")
    for _ in range(repeat):  # the fast paths interleaved: a slow moment hits all alike
        for k in ("a", "a+", "b", "e"):
            if k in paths:
                times[k].append(_timed(paths[k][0])[0])
    for k in ("c", "d"):
        for _ in range(repeat):
            seconds, out = _timed(paths[k][0])
            times[k].append(seconds)
    rows["d"].note = (f"{out.nfev} rhs evaluations, rtol {IVP_TOL['rtol']:g}, "
                      f"atol {IVP_TOL['atol']:g}")
    for k, ts in times.items():
        rows[k].seconds = statistics.median(ts)
    progress(f"comparing final states (damping {CALM['damping']:g} N·s/m) …")
    for k, (_, calm_run) in paths.items():
        out = calm_run()
        rows[k].final_calm = out.y[:, -1] if k == "d" else _final(out)
    memory = None
    if memory_duration > 0:
        progress(f"peak memory of a {memory_duration:g} s run in a fresh process …")
        memory = peak_memory(memory_duration, memory_save_every)
    return Result(rows, repeat, duration, backend, memory)


_MEMORY_CHILD = '''
import json, resource, sys, time
from analysis import load_model, simulate


def peak_mib():
    # VmHWM: peak RSS of this process image. getrusage's ru_maxrss would also count the
    # parent's pages when the process was forked from a big one (Linux keeps it over exec).
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / (
        2**20 if sys.platform == "darwin" else 1024)


duration, save_every = float(sys.argv[1]), int(sys.argv[2])
name, n_balls = sys.argv[3], int(sys.argv[4])
model = load_model(name)
simulate(model, n_balls, duration=0.001, transient=0.0)  # load the compiled library
before = peak_mib()
start = time.perf_counter()
ds = simulate(model, n_balls, duration=duration, transient=0.0, save_every=save_every)
wall = time.perf_counter() - start
print(json.dumps({"before_mb": before, "peak_mb": peak_mib(), "wall_s": wall,
                  "samples": ds.sizes["t"], "steps": round(duration / 1e-5)}))
'''


def peak_memory(duration: float, save_every: int) -> dict[str, float]:
    """Peak resident set size (MiB) of a fresh process simulating ``duration`` s of the
    benchmark model (Δt = 1e-5 s, every ``save_every``-th state kept), and before the run
    (after the imports and a first short run)."""
    res = subprocess.run([sys.executable, "-c", _MEMORY_CHILD, str(duration), str(save_every),
                          MODEL, str(N_BALLS)], capture_output=True, text=True, check=True)
    out = json.loads(res.stdout.strip().splitlines()[-1])
    out.update(duration=duration, save_every=save_every)
    return out


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b) / np.abs(b)))


def format_result(res: Result) -> str:
    """The table of medians and ratios, the targets, the agreement and the memory."""
    rows = res.rows
    base_key = "e" if rows["e"].seconds is not None else "a"
    base = rows[base_key].seconds
    n_steps = round(res.duration / DT)
    lines = [f"{MODEL}, N_b = {N_BALLS}, {res.duration:g} s simulated ({n_steps:.0e} RK4 steps "
             f"of {DT:g} s, every state kept), paper parameters; median of {res.repeat} runs",
             "",
             f"| path | median (s) | ratio to ({base_key}) | note |",
             "|---|---:|---:|---|"]
    for row in rows.values():
        if row.seconds is None:
            lines.append(f"| ({row.key}) {row.label} | – | – | {row.note} |")
        else:
            lines.append(f"| ({row.key}) {row.label} | {row.seconds:.4f} | "
                         f"{row.seconds / base:.2f} | {row.note} |")
    lines.append("")
    a = rows["a"].seconds
    if rows["e"].seconds is not None:
        ratio = a / rows["e"].seconds
        verdict = "met" if ratio <= TARGET_NUMBA else "MISSED"
        lines.append(f"target (a)/(e) <= {TARGET_NUMBA}: {ratio:.2f}, {verdict}")
    ratio = rows["d"].seconds / a
    verdict = "met" if ratio >= TARGET_SCIPY else "MISSED"
    lines.append(f"target (d)/(a) >= {TARGET_SCIPY:g}: {ratio:.0f}, {verdict}")
    want = rows["a"].final_calm
    same = {k: _relative(rows[k].final_calm, want) for k in ("a+", "b", "c", "e")
            if rows[k].final_calm is not None}
    verdict = "met" if max(same.values()) <= AGREEMENT else "MISSED"
    lines += [
        f"final state at {res.duration:g} s, damping {CALM['damping']:g} N·s/m (non-chaotic), "
        f"max relative difference to (a) over x, y, vx, vy:",
        "  " + ", ".join(f"({k}) {d:.1e}" for k, d in same.items())
        + f": target <= {AGREEMENT:g} {verdict}",
        f"  (d) {_relative(rows['d'].final_calm, want):.1e}: RK4's own truncation error at "
        f"dt = {DT:g} s (docs/numerics.md) against RK45 at rtol {IVP_TOL['rtol']:g}",
    ]
    mem = res.memory
    if mem is not None:
        lines += [
            f"peak memory of a {mem['duration']:g} s run ({mem['steps']:.0e} steps, every "
            f"{mem['save_every']}th state kept: {mem['samples']} samples; "
            f"{mem['wall_s']:.2f} s, {res.backend}):",
            f"  {mem['peak_mb']:.0f} MiB peak resident set size of a fresh process (VmHWM), "
            f"{mem['before_mb']:.0f} MiB of it before the run (Python, NumPy, SciPy, xarray, "
            f"CasADi, the model)",
        ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    """Command-line entry point of ``benchmarks/bench_simulate.py`` (argparse; the same
    options as ``bearingdyn bench``)."""
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=5, help="runs per path (median)")
    parser.add_argument("--duration", type=float, default=1.0, help="simulated time, s")
    parser.add_argument("--memory-duration", type=float, default=100.0,
                        help="simulated time of the memory run, s (0: skip)")
    args = parser.parse_args(argv)
    res = run_benchmark(args.repeat, args.duration, args.memory_duration,
                        progress=lambda msg: print(msg, file=sys.stderr))
    print(format_result(res))

