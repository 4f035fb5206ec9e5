"""Two-contact balls vs the loaded-zone centrifugal force, quasi-static, 0…30 000 rpm.

    python docs/scripts/two_contact_speed.py [-o docs/figures/two-contact-speed.png]

The rotor of Table 1 (N_b = 6, radial load 6 N, no unbalance, cage at ψ = 0 so ball 0 is on
the load line) is put in static equilibrium, F_x(x, 0) = 0, at each speed with
- ``vakharia2015-two-contact``: inner and outer contact in series, outer load = inner + F_c;
- ``vakharia2015-consistent`` (loaded zone, Q = max(0, k δ^1.5 − F_c)) with k set to the same
  geometric constant (``--set contact_stiffness=7.2055e9``), so only the centrifugal model
  differs;
- the same without centrifugal force (speed-independent reference, the value at 0 rpm).
It plots the static approach, the radial stiffness of the bearing there (from the generated
Jacobian) and, with zero clearance, how many balls stay on the inner race. Both generated
models are used as they are (rhs, Jacobian, ball load); about 10 s.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from scipy.optimize import brentq

from analysis import load_model
from modelgen.hertz import combined_stiffness, race_contact

N_BALLS = 6
SPEEDS = np.linspace(0.0, 30000.0, 61)


def equilibrium(model, values: dict[str, float]) -> float:
    """Rotor displacement x (m) along the load with F_x = 0 (y = 0 by symmetry)."""
    rhs = model.functions(N_BALLS).rhs
    p = model.parameter_vector(values)

    def force(x: float) -> float:
        return float(rhs(0.0, [x, 0.0, 0.0, 0.0], p)[2])

    gamma = values["radial_clearance"]
    return brentq(force, gamma, gamma + 1e-4, xtol=1e-15)


def centrifugal_force(values: dict[str, float]) -> float:
    """F_c = ½ m_b D_m ω_cage² (N), ω_cage of paper Eq. 1."""
    cage = values["speed_rpm"] * np.pi / 30 * values["inner_race_diameter"] / (
        values["inner_race_diameter"] + values["outer_race_diameter"])
    mass = values["ball_density"] * np.pi * values["ball_diameter"] ** 3 / 6
    return 0.5 * mass * values["pitch_diameter"] * cage**2


def state(model, values: dict[str, float]) -> dict[str, float]:
    """Equilibrium approach (m), radial stiffness −∂F_x/∂x (N/m) from the generated Jacobian,
    and the balls on the inner race there."""
    x = equilibrium(model, values)
    p = model.parameter_vector(values)
    jac = np.asarray(model.functions(N_BALLS).jac(0.0, [x, 0.0, 0.0, 0.0], p))
    theta = 2 * np.pi * np.arange(N_BALLS) / N_BALLS
    loads = [float(model.module.ball_load_bearing(np.cos(a), np.sin(a), 1, 6, [x, 0, 0, 0], 0, p))
             for a in theta]
    return {"approach": x - values["radial_clearance"],
            "stiffness": -jac[2, 0] * values["rotor_mass"],
            "loaded": sum(q > 0 for q in loads)}


def curves(models: dict, bases: dict) -> dict[str, dict[str, np.ndarray]]:
    """For each model: approach, stiffness and loaded balls over SPEEDS."""
    out = {}
    for name, model in models.items():
        rows = [state(model, {**bases[name], "speed_rpm": s}) for s in SPEEDS]
        out[name] = {key: np.array([r[key] for r in rows]) for key in rows[0]}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", type=Path,
                        default=Path(__file__).parent.parent / "figures" / "two-contact-speed.png")
    out = parser.parse_args().output

    two = load_model("vakharia2015-two-contact")
    zone = load_model("vakharia2015-consistent")
    base = {**two.defaults, "unbalance_force": 0.0}
    k = combined_stiffness(*(race_contact(
        base["ball_diameter"], base["pitch_diameter"], base[f"groove_conformity_{r}"],
        base["youngs_modulus"], base["poisson_ratio"], r).stiffness for r in ("inner", "outer")))
    zone_base = {**zone.defaults, "unbalance_force": 0.0, "contact_stiffness": k}
    models = {"two-contact": two, "loaded zone (same k)": zone}
    paper = curves(models, {"two-contact": base, "loaded zone (same k)": zone_base})
    tight = curves(models, {"two-contact": {**base, "radial_clearance": 0.0},
                            "loaded zone (same k)": {**zone_base, "radial_clearance": 0.0}})
    f_c = np.array([centrifugal_force({**base, "speed_rpm": s}) for s in SPEEDS])

    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    styles = {"two-contact": "-", "loaded zone (same k)": "--"}
    for name, style in styles.items():
        axes[0].plot(SPEEDS, paper[name]["approach"] * 1e6, style, label=name)
        axes[1].plot(SPEEDS, paper[name]["stiffness"] * 1e-6, style, label=name)
        axes[2].step(SPEEDS, tight[name]["loaded"], style, where="mid", label=name)
    for ax in axes[:2]:
        ax.axhline(ax.lines[0].get_ydata()[0], color="gray", lw=0.8,
                   label="no centrifugal force")
    axes[0].set_ylabel("static approach x − γ₀ (µm)")
    axes[0].set_title(f"P_r = {base['radial_load']:g} N, γ₀ = 10 µm: one ball loaded")
    axes[1].set_ylabel("radial stiffness −∂F_x/∂x (N/µm)")
    axes[1].set_title("bearing stiffness at that equilibrium")
    axes[2].set_ylabel("balls touching the inner race")
    axes[2].set_title("γ₀ = 0: loaded zone")
    axes[2].set_yticks(range(N_BALLS // 2 + 1))
    axes[2].set_ylim(0, N_BALLS // 2 + 0.5)
    twin = axes[0].twinx()
    twin.plot(SPEEDS, f_c, color="gray", lw=0.6, ls=":")
    twin.set_ylabel("F_c (N, dotted)")
    for ax, place in zip(axes, ("upper left", "upper left", "lower left"), strict=True):
        ax.set_xlabel("shaft speed (rpm)")
        ax.legend(fontsize=8, loc=place)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    for s in (5000, 15000, 30000):
        i = int(np.argmin(abs(SPEEDS - s)))
        print(f"{s:6d} rpm, F_c = {f_c[i]:.3f} N: " + "; ".join(
            f"{n}: approach {paper[n]['approach'][i] * 1e6:.3f} µm, stiffness "
            f"{paper[n]['stiffness'][i] * 1e-6:.2f} N/µm, γ₀ = 0 loaded balls "
            f"{tight[n]['loaded'][i]}" for n in models))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
