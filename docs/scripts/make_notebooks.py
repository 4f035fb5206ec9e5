"""Write the example notebooks docs/notebooks/*.ipynb (without outputs) from this source, so
that a change to them is a readable diff: ``python docs/scripts/make_notebooks.py``.
tests/test_notebooks.py executes them."""

from pathlib import Path

import nbformat as nbf
from nbformat.v4 import new_code_cell as code
from nbformat.v4 import new_markdown_cell as md
from nbformat.v4 import new_notebook


def save(cells, path):
    nb = new_notebook(cells=cells, metadata={
        "kernelspec": {"name": "python3", "display_name": "Python 3", "language": "python"},
        "language_info": {"name": "python"}})
    nbf.validate(nb)
    nbf.write(nb, path)

save([
 md("# The paper's case: an unbalanced rotor on a 6205 ball bearing\n\n"
    "Vakharia, Gupta, Kankar, *Nonlinear dynamic analysis of ball bearings due to varying "
    "number of balls and centrifugal force*: N_b = 6 and 10 balls at 5000 rpm, integrated "
    "with fixed-step RK4 (dt = 10 µs) as in the paper. SI units throughout (m, s, N); "
    "speeds in rpm. Runs in about 20 s."),
 code("%matplotlib inline\n"
      "from analysis import find_peaks, load_model, poincare_section, simulate\n"
      "from analysis.reports.plots import paper_figure\n\n"
      "model = load_model(\"vakharia2015\")\nmodel  # the model card: spec, hash, parameters"),
 md("Simulate 3 s and keep the last 2 s (the spec's defaults); the Dataset carries the "
    "run's provenance (model, spec sha256, every parameter, versions) in its attrs."),
 code("runs = {n: simulate(model, n_balls=n, speed_rpm=5000) for n in (6, 10)}\n"
      "ds = runs[6]\n"
      "{k: ds.attrs[k] for k in (\"model\", \"spec_sha256\", \"n_balls\", \"speed_rpm\", "
      "\"shaft_hz\", \"vc_hz\")}"),
 md("Spectral peaks of the x displacement, named as combinations of the shaft frequency X "
    "and the varying-compliance frequency VC (paper Table 2)."),
 code("for n, run in runs.items():\n"
      "    peaks = find_peaks(run, \"x\")[:5]\n"
      "    print(f\"N_b = {n}: \" + \", \".join(f\"{p.label} {p.frequency_hz:.1f} Hz\" "
      "for p in peaks))"),
 md("Spectra and shaft-synchronous Poincaré maps (paper Figs. 2 and 6)."),
 code("fig = paper_figure(runs[6], section=\"shaft\")\nfig"),
 code("section = poincare_section(runs[10], \"shaft\")\n"
      "low, high = float(section.x.min()), float(section.x.max())\n"
      "print(f\"{section.sizes['k']} section points, x from {low:.3e} to {high:.3e} m\")\n"
      "fig = paper_figure(runs[10], section=\"shaft\")\nfig"),
], Path(__file__).resolve().parents[1] / "notebooks" / "paper-case.ipynb")

save([
 md("# A stability study: Floquet multipliers, Lyapunov exponents, classification\n\n"
    "Periodic orbits of the balanced rotor (varying-compliance excitation only, period "
    "1/VC) found by Newton shooting, their Floquet multipliers over the radial load; then the "
    "unbalanced paper rotor, whose motion is quasi-periodic or chaotic, classified from its "
    "Poincaré section and its largest Lyapunov exponent. SI units; speeds in rpm. Runs in "
    "about 30 s."),
 code("%matplotlib inline\n"
      "import matplotlib.pyplot as plt\nimport numpy as np\n\n"
      "from analysis import load_model, simulate\n"
      "from analysis.stability.classify import classify\n"
      "from analysis.stability.lyapunov import lyapunov\n"
      "from analysis.stability.periodic import shoot\n\n"
      "load_model(\"balanced-rotor\")"),
 md("Shoot the period-1/VC orbit at each radial load and keep the spectral radius of its "
    "monodromy matrix (below 1: stable)."),
 code("loads = np.linspace(10.0, 200.0, 12)  # N\n"
      "orbits = [shoot(\"balanced-rotor\", 8, radial_load=float(p)) for p in loads]\n"
      "radius = np.array([o.spectral_radius for o in orbits])\n"
      "for p, o in zip(loads, orbits, strict=True):\n"
      "    print(f\"P_r = {p:6.1f} N: {o.stability:8s} spectral radius {o.spectral_radius:.4f}\")"),
 code("fig, ax = plt.subplots(figsize=(6, 3.5))\n"
      "ax.plot(loads, radius, \"o-\")\nax.axhline(1.0, color=\"0.5\", ls=\"--\", "
      "label=\"|μ| = 1\")\n"
      "ax.set_xlabel(\"radial load P_r (N)\")\n"
      "ax.set_ylabel(\"largest |Floquet multiplier| (–)\")\n"
      "ax.set_title(\"balanced rotor, N_b = 8, period 1/VC\")\nax.legend()\nfig.tight_layout()"),
 md("The paper's unbalanced rotor at 5000 rpm: Lyapunov spectrum (1/s) and the nature of the "
    "motion for N_b = 6 and 10."),
 code("for n in (6, 10):\n"
      "    res = lyapunov(\"vakharia2015\", n, speed_rpm=5000, duration=0.5)\n"
      "    lam = res.exponents.values\n"
      "    nature = classify(simulate(\"vakharia2015\", n_balls=n, speed_rpm=5000))\n"
      "    print(f\"N_b = {n}: λ = {np.array2string(lam, precision=1)} 1/s; \"\n"
      "          f\"{nature.nature} ({nature.detail})\")"),
], Path(__file__).resolve().parents[1] / "notebooks" / "stability-study.ipynb")
