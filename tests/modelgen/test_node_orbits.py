"""Orbits at any shaft node of a flexible rotor (``analysis.signal.orbit.node_orbit``,
``bearingdyn plot RUN --orbit --node K``): node K's translation from the reduced state
through the generated module's ``NODE_MAP``.

Checked against what does not share that map: a bearing node's own states (node 0 is
``x``, ``y``) and the right bearing's station map (the orbit ``plot --orbit`` draws); and,
for the middle disk, the full unreduced finite-element model (``modelgen.fe.assembly``)
solved statically under the radial load alone (speed 0, no unbalance force), its bearing
reactions checked against the Hertz contact law written out here.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import root

from analysis.errors import InputError
from analysis.integrate.simulate import simulate, simulate_to_file
from analysis.model import load_model
from analysis.provenance import load_dataset
from analysis.signal.orbit import node_orbit, orbits
from modelgen.fe.assembly import assemble, dof
from modelgen.spec import load_spec
from tests.conftest import SPECS

MODEL = "three-disk-rotor"


def _static_state(model, values: dict[str, float]) -> np.ndarray:
    """The reduced coordinates where the generated rhs's accelerations vanish (speed 0)."""
    funcs = model.functions(None)
    p = np.asarray(model.parameter_vector(values), dtype=float)
    half = model.n_state // 2

    def accel(q):
        return np.array(funcs.rhs(0.0, np.r_[q, np.zeros(half)], p)).ravel()[half:]

    def jac(q):
        return np.array(funcs.jac(0.0, np.r_[q, np.zeros(half)], p))[half:, :half]

    guess = np.zeros(half)
    guess[[0, 2]] = 2e-5  # both bearings in contact (x_q1 is node 12's x, NODE_MAP)
    sol = root(accel, guess, jac=jac, method="hybr", options={"xtol": 1e-14})
    assert sol.success and np.abs(accel(sol.x)).max() < 1e-6
    return sol.x


def test_a_disk_nodes_orbit_is_the_full_models_static_deflection():
    """At rest under the radial load (100 N at node 6, speed 0: no unbalance force) a run
    started at the reduced equilibrium stays there; node 6's orbit from NODE_MAP equals the
    full 52-DOF model's static deflection there (bearing translations imposed) within the
    reduction's stated error, and the full model's bearing reactions are the Hertz loads."""
    model = load_model(MODEL)
    values = {**model.defaults, "speed_rpm": 0.0}
    q = _static_state(model, values)
    z0 = np.r_[q, np.zeros(q.size)]
    ds = simulate(MODEL, duration=0.002, transient=0.0, initial_state=z0, compiled=False,
                  speed_rpm=0.0)
    at = {k: node_orbit(ds, k) for k in (0, 6, 12)}
    u_b = np.array([at[0].x[-1], at[0].y[-1], at[12].x[-1], at[12].y[-1]])
    spec = load_spec(SPECS / f"{MODEL}.toml")[0]
    rotor = assemble(spec.shaft)
    b = [dof(0, "x"), dof(0, "y"), dof(12, "x"), dof(12, "y")]
    i = [k for k in range(rotor.n_dof) if k not in b]
    force = np.zeros(rotor.n_dof)
    force[dof(6, "x")] = values["radial_load"]
    u = np.zeros(rotor.n_dof)
    u[b] = u_b
    u[i] = np.linalg.solve(rotor.K[np.ix_(i, i)], force[i] - rotor.K[np.ix_(i, b)] @ u_b)
    full = u[dof(6, "x")]
    error = model.module.REDUCTION["error"]
    assert full > 3e-4  # the shaft bends: 0.39 mm at the middle disk, 14 µm at the bearings
    assert abs(at[6].x[-1] - full) <= error * full
    assert np.all(np.abs(at[6].x - full) <= error * full)
    assert np.abs(at[6].y).max() < 1e-12 * full
    assert at[6].x[-1] > 20 * at[0].x[-1]  # not a bearing's orbit
    # the full model's reactions at the bearings are the Hertz loads at those translations
    reaction = rotor.K[b] @ u - force[b]
    theta = 2 * np.pi * np.arange(8) / 8
    for k, (x, y) in enumerate((u_b[:2], u_b[2:])):
        load = values["contact_stiffness"] * np.maximum(
            0.0, x * np.cos(theta) + y * np.sin(theta) - values["radial_clearance"]) ** 1.5
        hertz = np.array([load @ np.cos(theta), load @ np.sin(theta)])
        assert np.allclose(-reaction[2 * k:2 * k + 2], hertz, rtol=1e-6, atol=1e-6)
    assert hertz[0] == pytest.approx(values["radial_load"] / 2, rel=1e-6)


def test_a_bearing_nodes_orbit_is_its_own_states_and_its_bearings_orbit(tmp_path, cli):
    """At 3000 rpm with the unbalance: node 0's orbit is the states x, y bit for bit, node
    12's the right bearing's orbit (its station map) to 1e-12, with its clearance; the
    middle disk's differs; ``plot --orbit --node 6`` draws it; a node the model lacks is one
    line, exit 2."""
    run = tmp_path / "run.nc"
    simulate_to_file(MODEL, run, duration=0.003, transient=0.0, compiled=False)
    ds = load_dataset(run)
    left = node_orbit(ds, 0)
    assert np.array_equal(left.x, ds["x"].values) and np.array_equal(left.y, ds["y"].values)
    bearing = {o.name: o for o in orbits(ds)}["bearing right"]
    right = orbits(ds, node=12)[0]
    scale = np.abs(bearing.x).max()
    assert scale > 0
    assert np.abs(right.x - bearing.x).max() <= 1e-12 * scale
    assert np.abs(right.y - bearing.y).max() <= 1e-12 * scale
    assert right.clearance == bearing.clearance == pytest.approx(10e-6)
    assert right.mark_x.size == bearing.mark_x.size > 0
    disk = node_orbit(ds, 6)
    assert disk.clearance is None
    assert np.abs(disk.x - left.x).max() > 0.1 * np.abs(left.x).max()
    res = cli("plot", str(run), "--orbit", "--node", "6", "-o", str(tmp_path / "n6.png"))
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "n6.png").stat().st_size > 10_000
    res = cli("plot", str(run), "--orbit", "--node", "13", "-o", str(tmp_path / "n13.png"))
    assert res.returncode == 2 and not (tmp_path / "n13.png").exists()
    assert res.stderr.strip().count("\n") == 0
    assert "--node" in res.stderr and "0…12" in res.stderr and "13" in res.stderr


def test_node_on_a_rigid_model_or_a_missing_node_is_an_input_error():
    rigid = simulate("balanced-rotor", duration=0.001, transient=0.0, compiled=False)
    with pytest.raises(InputError, match=r"^node: only for a flexible"):
        node_orbit(rigid, 0)
    flexible = simulate(MODEL, duration=0.0002, transient=0.0, compiled=False)
    for bad in (-1, 13, 2.5):
        with pytest.raises(InputError, match=r"^node: a node of three-disk-rotor, 0…12"):
            node_orbit(flexible, bad)
    with pytest.raises(InputError, match=r"^node: draws"):
        orbits(flexible, "x", "y", node=3)
