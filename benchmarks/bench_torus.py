"""Benchmark: the torus of vakharia2015 at N_b = 10, 5000 rpm by torus harmonic balance,
against the time integration that reaches the same accuracy, in the same run.

For each (H1, H2) of ``--harmonics``:

* **torus**: the wall time of ``solve_torus`` without λ1 (its guess's settled simulation
  and fit included, the CasADi function built on first use included), and its accuracy
  ``e_H``: the largest |z_torus(t) − z(t)| / amplitude over the states, z a reference run
  on the attractor (RK4 at the spec's 1e-5 s, after a 3 s transient, 2 s long);
* **integration**: how long a run of ``simulate`` from the spec's initial state must last
  to be within ``e_H`` of the attractor: t* is the first time after which its distance to
  the reference (the same integration continued: the forced attractor is unique, so the
  run itself after 3 s is the reference; before that, the distance to a second run started
  on the torus) stays below e_H·amplitude, and its wall time is that of ``simulate`` over
  t* (and over t* + ``--window`` s of attractor, the series a spectrum or a section is read
  from); the shortest of three calls, the torus's of one.

Ratio = torus time / integration time (< 1: the torus is faster). The torus gives the
whole attractor as a function of (θ1, θ2) (any t, any section); the integration gives one
series.

The last lines give the error per state, largest and rms (the table of docs/frequency.md,
Tori: ``--harmonics 8,4 12,6 16,8 20,10 24,12``).

For each N of ``--points``, the same torus by the invariant circle of the shaft map
(``circle.solve.solve_circle`` without λ1 and without its 2N solve): its wall time,
its error at the shaft sections t = k·T1 of the reference (the circle u(ω2 t)), at every
reference time (the Dataset's series on the N1 × N grid), and at the sections outside the
cage phases 0.5–2.5 rad (where the shaft map's local multiplier is a flip below −1; the
table of docs/frequency.md, "Tori by the invariant circle of the shaft map").

    python benchmarks/bench_torus.py [--harmonics 8,4 12,6 16,8] [--window 1]
        [--points 33 65 129]

``--between SECONDS`` measures instead the default torus at every time, as issue 32 does:
the circle of N = ``--points``' first value (default 65) is solved (its wall time, without
and with the 2N check), its run integrated from each section's circle point
(``circle_run.circle_states``, what ``torus --run`` writes) over SECONDS s, and compared
with simulations started on the circle at RK4 steps 1e-5, 5e-6, 2.5e-6, 1.25e-6 and
6.25e-7 s (every time kept at 1e-5 s after 0.5 s, the largest difference relative to each
state's amplitude, at every time and at the shaft sections); each simulation against the
next finer one says how far the reference itself is from the flow; the stored 2-D series is
compared over 1 s.

    python benchmarks/bench_torus.py --between 20
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from analysis.frequency.circle.solve import DEFAULT_POINTS, solve_circle
from analysis.frequency.torus.solve import solve_torus
from analysis.integrate.simulate import simulate
from analysis.model import System

MODEL, N_BALLS, SPEED = "vakharia2015", 10, 5000.0
SETTLE, REFERENCE = 3.0, 2.0


def states(run, names) -> np.ndarray:
    return np.column_stack([run[v].values for v in names])


def first_within(t: np.ndarray, distance: np.ndarray, bound: float) -> float:
    """First time after which ``distance`` stays at or below ``bound`` (inf: never)."""
    above = np.nonzero(distance > bound)[0]
    if above.size == 0:
        return float(t[0])
    return float(t[above[-1] + 1]) if above[-1] + 1 < len(t) else float("inf")


def timed(fn, repeat: int = 1):
    """(result, the shortest wall time of ``repeat`` calls, s)."""
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return out, best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--harmonics", nargs="+", default=["8,4", "12,6", "16,8"])
    parser.add_argument("--window", type=float, default=1.0,
                        help="Attractor time after t* in the second integration row, s.")
    parser.add_argument("--points", nargs="*", type=int, default=None,
                        help="Circle points N of the shooting rows (default 33 65 129; "
                             "with --between its first value, default 65).")
    parser.add_argument("--between", type=float, default=None, metavar="SECONDS",
                        help="Measure the default circle's run at every time over SECONDS s "
                             "against simulations at finer and finer steps (only this).")
    args = parser.parse_args()
    system = System.make(MODEL, n_balls=N_BALLS, speed_rpm=SPEED)
    if args.between is not None:
        between(system, args.points[0] if args.points else DEFAULT_POINTS, args.between)
        return
    if args.points is None:
        args.points = [33, 65, 129]
    names = system.state_names
    simulate(system, duration=0.01, transient=0.0)  # load the compiled blocks once
    long_run, _ = timed(lambda: simulate(system, duration=SETTLE + REFERENCE, transient=0.0,
                                         save_every=5))
    t_all = long_run.t.values
    z_all = states(long_run, names)
    on = t_all >= SETTLE
    amp = np.ptp(z_all[on], axis=0) / 2
    print(f"{MODEL}, N_b = {N_BALLS}, {SPEED:g} rpm; load average "
          f"{os.getloadavg()[0]:.2f}; cores {os.cpu_count()}")
    print(f"{'H1,H2':>7} {'unknowns':>8} {'torus s':>8} {'e_H':>7} {'t* s':>6} "
          f"{'sim(t*) s':>9} {'ratio':>6} {'sim(t*+w) s':>11} {'ratio':>6}")
    errors = []
    for text in args.harmonics:
        pair = tuple(int(v) for v in text.split(","))
        response, torus_s = timed(lambda pair=pair: solve_torus(
            system, None, "shaft,vc", pair, stability=False))
        if not response.converged:
            print(f"{text:>7} no torus ({response.message})")
            continue
        diff = np.abs(response.states(t_all[on]) - z_all[on])
        per_state = np.max(diff, axis=0) / amp
        rms = np.sqrt(np.mean(diff ** 2, axis=0)) / amp
        e_h = float(np.max(per_state))
        errors.append((text, per_state, rms))
        start_on = response.states(np.array([0.0]))[0]
        second = simulate(system.replace(state=start_on), duration=SETTLE, transient=0.0,
                          save_every=5)
        z2 = states(second, names)
        early = t_all < SETTLE
        distance = np.max(np.abs(z_all[early] - z2[:early.sum()]) / amp, axis=1)
        t_star = first_within(t_all[early], distance, e_h)
        t_star = max(t_star, 5e-3)
        _, sim_s = timed(lambda t_star=t_star: simulate(system, duration=t_star,
                                                        transient=0.0), 3)
        _, sim_w = timed(lambda t_star=t_star: simulate(
            system, duration=t_star + args.window, transient=t_star), 3)
        print(f"{text:>7} {response.torus.size:>8} {torus_s:>8.2f} {e_h:>7.3f} "
              f"{t_star:>6.3f} {sim_s:>9.3f} {torus_s / sim_s:>6.1f} {sim_w:>11.3f} "
              f"{torus_s / sim_w:>6.1f}")

    print(f"\nerror / amplitude per state ({', '.join(names)}), max and rms:")
    for text, per_state, rms in errors:
        print(f"{text:>7}  max {', '.join(f'{v:.3g}' for v in per_state)}   rms "
              f"{', '.join(f'{v:.2g}' for v in rms)}")
    if not args.points:
        return
    period = 60.0 / SPEED
    sections = on & (np.abs(np.mod(t_all / period + 0.5, 1.0) - 0.5) < 1e-6)
    print(f"\ninvariant circle of the shaft map (max error / amplitude over the states; "
          f"{sections.sum()} sections):")
    print(f"{'N':>5} {'circle s':>8} {'tail':>8} {'sections':>9} {'all t':>8} "
          f"{'outside flip':>12}  per state at the sections")
    for n in args.points:
        circle, circle_s = timed(lambda n=n: solve_circle(
            system, None, "shaft,vc", n, convergence=False, stability=False))
        if not circle.converged:
            print(f"{n:>5} no circle ({circle.message})")
            continue
        t_k = t_all[sections]
        at_k = np.abs(circle.at_sections(t_k) - z_all[sections]) / amp
        every = np.abs(circle.torus.at_times(circle.coefficients, t_all[on]) - z_all[on]) / amp
        phase = np.mod(circle.omegas[1] * t_k, 2 * np.pi)
        outside = (phase < 0.5) | (phase > 2.5)
        print(f"{n:>5} {circle_s:>8.2f} {circle.tail:>8.1e} {at_k.max():>9.2e} "
              f"{every.max():>8.2e} {at_k[outside].max():>12.2e}  "
              f"{', '.join(f'{v:.2g}' for v in at_k.max(axis=0))}")


REFERENCE_STEPS = (1e-5, 5e-6, 2.5e-6, 1.25e-6, 6.25e-7)
"""RK4 steps (s) of the simulations the circle's run is compared with (``--between``)."""


def between(system: System, points: int, duration: float) -> None:
    """The ``--between`` measurement (module docstring)."""
    from analysis.frequency.circle.solve import circle_dataset
    from analysis.frequency.circle_run import circle_states
    from analysis.frequency.torus.dataset import torus_of

    simulate(system, duration=0.01, transient=0.0)  # load the compiled blocks once
    _, with_check = timed(lambda: solve_circle(system, None, "shaft,vc", points,
                                               stability=False))
    circle, circle_s = timed(lambda: solve_circle(system, None, "shaft,vc", points,
                                                  convergence=False, stability=False))
    print(f"{MODEL}, N_b = {N_BALLS}, {SPEED:g} rpm, N = {points}; load average "
          f"{os.getloadavg()[0]:.2f}; cores {os.cpu_count()}")
    print(f"circle: {circle_s:.2f} s (with the 2N check {with_check:.2f} s), "
          f"{circle.steps} RK4 steps per revolution")
    data = circle_dataset(circle)
    (t, z), run_s = timed(lambda: circle_states(data, duration))
    print(f"run integrated from the circle over {duration:g} s: {run_s:.1f} s")
    amp = np.ptp(z, axis=0) / 2
    keep = t >= 0.5
    section = np.arange(len(t)) % circle.steps == 0
    refs = {}
    for dt in REFERENCE_STEPS:
        run = simulate(system.replace(state=z[0]), duration=duration, transient=0.0, dt=dt,
                       save_every=round(float(t[1] - t[0]) / dt))
        refs[dt] = states(run, system.state_names)[:len(z)]

    def worst(a, b, where):
        return float(np.max(np.abs(a[where] - b[where]) / amp))

    print(f"{'reference dt':>12} {'run: every t':>12} {'sections':>9} "
          f"{'ref vs next finer':>17}")
    for dt, finer in zip(REFERENCE_STEPS, (*REFERENCE_STEPS[1:], None), strict=True):
        own = worst(refs[dt], refs[finer], keep) if finer else float("nan")
        print(f"{dt:>12.3g} {worst(z, refs[dt], keep):>12.2e} "
              f"{worst(z, refs[dt], keep & section):>9.2e} {own:>17.2e}")
    ts, coeffs = torus_of(data)
    window = keep & (t < 1.5)
    best = refs[REFERENCE_STEPS[-1]]
    print(f"stored 2-D series (N1 = {circle.samples}) over 0.5-1.5 s against the finest: "
          f"{float(np.max(np.abs(ts.at_times(coeffs, t[window]) - best[window]) / amp)):.2e}")


if __name__ == "__main__":
    main()
