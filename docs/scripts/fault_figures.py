"""The figures of docs/faults.md: time signals with the ball-passing times marked, and the
labelled envelope spectra of the three shipped 6205 defect models.

    python docs/scripts/fault_figures.py [--out docs/figures]

Each model runs its spec's defaults (5000 rpm, N_b = 9, 1 s recorded after 0.2 s, RK4 at
2 µs, every 5th step kept: 100 kHz). Writes fault-<race>-time.png (the first 25 ms of the
housing's x_housing, vx_housing and the acceleration d(vx_housing)/dt, with the passing times
of ``analysis.signal.passes`` as dashed lines) and fault-<race>-envelope.png (the envelope
spectrum of x_housing, band chosen by spectral kurtosis, peaks named by the defect
frequencies); and fault-outer-envelope-noise.png: the envelope of a 2.5 s outer-defect record
(every step kept, 500 kHz) with white noise at 0 dB SNR (seed 0) added to x_housing. About
45 s.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from analysis.integrate.simulate import simulate
from analysis.reports.fault_plots import envelope_figure, impulse_figure
from analysis.reports.plots import save_figure
from analysis.signal.envelope import envelope_peaks, envelope_spectrum
from analysis.signal.noise import add_noise
from analysis.signal.passes import passing_times

RACES = ("outer", "inner", "ball")
WHAT = {"outer": "a ball passes the outer-race pit",
        "inner": "a ball passes the inner-race pit",
        "ball": "the pit on ball 1 meets a race"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/figures"))
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for race in RACES:
        ds = simulate(f"6205-{race}-defect", save_every=5)
        t0, t1 = float(ds.t[0]), float(ds.t[-1])
        passes = passing_times(ds.attrs, race, t0, t1)
        save_figure(impulse_figure(ds, passes, 0.025, WHAT[race]),
                    args.out / f"fault-{race}-time.png")
        envelope_plot(ds, race, args.out / f"fault-{race}-envelope.png")
    long = simulate("6205-outer-defect", duration=2.7, transient=0.2)
    envelope_plot(add_noise(long, 0.0, 0, ("x_housing",)), "outer, 2.5 s, 0 dB noise",
                  args.out / "fault-outer-envelope-noise.png")


def envelope_plot(ds, what: str, path: Path) -> None:
    """The envelope figure of ds's x_housing (band by kurtosis) and its named lines."""
    peaks, band = envelope_peaks(ds, "x_housing", max_peaks=12)
    spectrum = envelope_spectrum(ds, "x_housing", (band.low_hz, band.high_hz))
    save_figure(envelope_figure(spectrum, peaks, band), path)
    named = ", ".join(f"{p.label} {p.frequency_hz:.2f} Hz" for p in peaks if p.label)
    print(f"{what}: band {band.low_hz:.0f}-{band.high_hz:.0f} Hz, K = {band.kurtosis:.3g}; "
          f"{named}")


if __name__ == "__main__":
    main()
