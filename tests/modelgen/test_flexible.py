"""Flexible rotors in the symbolic pipeline: a spec with ``[shaft]`` generates a reduced
model like any other (``modelgen/fe/reduction.py``, ``modelgen/fe/nonlinear.py``).

Checked against what does not share the code under test: the rigid rotor on one ball
bearing (``balanced-rotor``) for a very stiff shaft on two; the full, unreduced finite-
element model (``modelgen.fe.assembly``, numpy eigenvalues) for the reduction's stated
error and for the generated model's linear part; the CLI for bad input.
"""

from __future__ import annotations

import copy
import json
import tomllib
from pathlib import Path

import numpy as np
import pytest
import tomli_w
import xarray as xr

from analysis.integrate.simulate import simulate
from analysis.model import load_model
from analysis.stability.lyapunov import lyapunov
from modelgen.errors import SpecError
from modelgen.fe.assembly import assemble as assemble_shaft
from modelgen.fe.assembly import unbalance_force_amplitudes
from modelgen.fe.nonlinear import reduced_rotor
from modelgen.fe.reduction import (
    ERROR_STIFFNESSES,
    OSCILLATING,
    damped_frequencies,
    frequency_differences,
    quantized,
    reduce_rotor,
)
from modelgen.spec import load_spec, parse_spec
from tests.conftest import SPECS

STIFF_ROTOR = """
[model]
name = "stiff-rotor"
title = "A very stiff shaft with one disk between two ball bearings (the rigid limit)"

[[bearings]]
name = "left"
inner = "shaft"
node = 0
n_balls = 8

[[bearings]]
name = "right"
inner = "shaft"
node = 2
n_balls = 8

[shaft]
materials = [{ name = "stiff", E = 1e13, nu = 0.3, rho = 7810.0 }]
elements = [{ L = 0.05, odl = 0.02, material = "stiff" },
            { L = 0.05, odl = 0.02, material = "stiff" }]
# shaft 0.24536 kg + disk = 1.2 kg: twice balanced-rotor's 0.6 kg on two bearings
disks = [{ node = 1, m = 0.95464162, Id = 1e-3, Ip = 2e-3 }]

[reduction]
modes = 0

[simulation]
dt = 1e-5
duration = 0.2
transient = 0.1

[parameters]
speed_rpm = { value = 5000.0, unit = "rpm", source = "as balanced-rotor" }
contact_stiffness = { value = 7.055e9, unit = "N/m^1.5", source = "as balanced-rotor" }
damping = { value = 200.0, unit = "N*s/m", source = "as balanced-rotor, per bearing" }
radial_clearance = { value = 2e-6, unit = "m", source = "a periodic point of balanced-rotor" }
radial_load = { value = 12.0, unit = "N", source = "twice balanced-rotor's: half per bearing" }
inner_race_diameter = { value = 18.738e-3, unit = "m", source = "as balanced-rotor" }
outer_race_diameter = { value = 28.262e-3, unit = "m", source = "as balanced-rotor" }

[[terms]]
kind = "hertz_contact"
bearing = "left"

[[terms]]
kind = "hertz_contact"
bearing = "right"

[[terms]]
kind = "viscous_damping"
bearing = "left"

[[terms]]
kind = "viscous_damping"
bearing = "right"

[[terms]]
kind = "radial_load"
body = "node1"
"""
"""Balanced-rotor's bearing, load and damping carried twice by a stiff shaft (E = 1e13 Pa,
bending stiffness 4e12 N/m against the bearings' 1e8): its translation is the rigid rotor's.
The clearance is 2 µm, where balanced-rotor's orbit is periodic (λ1 ≈ -166 1/s; at its
default 10 µm it is chaotic, and no two models stay within 1e-3 for long)."""


def _write(folder: Path, text_or_data, name: str) -> Path:
    path = folder / f"{name}.toml"
    text = text_or_data if isinstance(text_or_data, str) else tomli_w.dumps(text_or_data)
    path.write_text(text)
    return path


def _rigid_start(model, displacement: float) -> np.ndarray:
    """The reduced state with every node at (displacement, displacement), at rest (from the
    generated NODE_MAP, by least squares: exact for a shaft that stays straight)."""
    n = model.n_state // 2
    rows = []
    for node_rows in model.module.NODE_MAP:
        for axis in (1, 2):
            row = np.zeros(n)
            for j, *coefficients in node_rows:
                row[j] += coefficients[axis - 1]
            rows.append(row)
    q = np.linalg.lstsq(np.array(rows), np.full(len(rows), displacement), rcond=None)[0]
    return np.concatenate([q, np.zeros(n)])


def test_a_stiff_shaft_on_two_ball_bearings_is_the_rigid_rotor(user_cache):
    path = _write(user_cache, STIFF_ROTOR, "stiff-rotor")
    model = load_model(str(path))
    mass = assemble_shaft(load_spec(path)[0].shaft)
    ones = np.zeros(mass.n_dof)
    ones[0::4] = 1.0
    assert ones @ mass.M @ ones == pytest.approx(1.2, rel=1e-8)  # twice balanced-rotor's
    z0 = _rigid_start(model, 1e-6)  # balanced-rotor starts at x = y = 1e-6 m
    flexible = simulate(model, duration=0.1, transient=0.05, initial_state=z0,
                        radial_clearance=2e-6, compiled=False)
    rigid = simulate("balanced-rotor", duration=0.1, transient=0.05, radial_clearance=2e-6,
                     compiled=False)
    for name in ("x", "y"):  # the left bearing's node; the right one's is its mirror
        size = np.ptp(rigid[name].values)
        assert size > 1e-8
        assert np.max(np.abs(flexible[name].values - rigid[name].values)) < 1e-3 * size
    lam_f = lyapunov(model, duration=0.2, transient=0.2, n_exponents=1, initial_state=z0,
                     radial_clearance=2e-6, compiled=False)
    lam_r = lyapunov("balanced-rotor", duration=0.2, transient=0.2, n_exponents=1,
                     radial_clearance=2e-6, compiled=False)
    f, r = float(lam_f.exponents[0]), float(lam_r.exponents[0])
    assert f < 0 and r < 0 and abs(f - r) < 0.1 * abs(r), (f, r)  # both periodic


@pytest.fixture(scope="module")
def three_disk():
    spec, _ = load_spec("three-disk-rotor")
    rotor = assemble_shaft(spec.shaft)
    k_b, c_b = rotor.bearing_matrices(0.0)
    full = (rotor.M, rotor.K + k_b, rotor.C + c_b, rotor.G)
    return spec, full, reduced_rotor(spec)


def test_the_stated_reduction_error_bounds_the_true_difference(three_disk):
    """Between the speeds and bearing stiffnesses it was measured at, the reduced rotor's
    damped natural frequencies differ from the full rotor's by no more than stated."""
    _, full, stated = three_disk
    assert 0 < stated.error < 1e-2 and stated.modes_compared >= 4
    assert f"Reduction error: {stated.error_text}" in \
        (SPECS.parent.parent / "generated/three_disk_rotor/MODEL.md").read_text()
    worst = 0.0
    for speed in (777.0, 3333.0, 6789.0, 9999.0):
        for stiffness in (3e6, 2e7, 5e8, 3e9):
            error, count = frequency_differences(full, stated.reduced, speed, stiffness,
                                                 stated.limit_hz)
            assert count >= 4
            worst = max(worst, error)
    assert 0 < worst <= stated.error
    # the statement is not slack: it is reached at the corners it was measured at
    corner = max(frequency_differences(full, stated.reduced, s, k, stated.limit_hz)[0]
                 for s in (0.0, 10000.0) for k in ERROR_STIFFNESSES)
    assert corner > 0.5 * stated.error


def test_fewer_modes_give_a_larger_error_and_the_basis_is_exact_at_the_interface(three_disk):
    _, full, stated = three_disk
    m, k, c, g = full
    few = reduce_rotor(m, k, c, g, (0, 12), "craig_bampton", 1, 0)
    errors = [frequency_differences(full, few, 10000.0, kb, stated.limit_hz)[0]
              for kb in ERROR_STIFFNESSES]
    assert max(errors) > 10 * stated.error
    # Craig-Bampton: a static load at the bearing nodes deflects the reduced shaft exactly
    # (as the matrices it was reduced from: rounded to 12 digits, INPUT_DIGITS)
    k = quantized(k)
    red = stated.reduced
    load = np.zeros(m.shape[0])
    load[4 * 12] = 1.0  # 1 N at the right bearing node, x
    held = np.zeros_like(k)
    for node in (0, 12):
        held[4 * node, 4 * node] = held[4 * node + 1, 4 * node + 1] = 1e8
    exact = np.linalg.solve(k + held, load)
    t = red.transform
    reduced = t @ np.linalg.solve(red.stiffness + t.T @ held @ t, t.T @ load)
    assert np.max(np.abs(reduced - exact)) < 1e-9 * np.max(np.abs(exact))


def test_the_reduction_is_the_same_bits_for_inputs_that_differ_in_the_last_bit(three_disk):
    """What generated code bakes in does not depend on the machine's last bits (CI
    compares generated files byte for byte)."""
    _, (m, k, c, g), _ = three_disk
    a = reduce_rotor(m, k, c, g, (0, 12), "craig_bampton", 2, 0)
    nudged = [x * (1 + 2e-16) for x in (m, k, c, g)]
    b = reduce_rotor(*nudged, (0, 12), "craig_bampton", 2, 0)
    for name in ("transform", "mass", "stiffness", "damping", "gyroscopic"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


LINEAR_ROTOR = """
[model]
name = "linear-rotor"
title = "A short rotor on linear bearings, unreduced"

[shaft]
materials = [{ name = "steel", E = 211e9, nu = 0.3, rho = 7810.0 }]
elements = [{ L = 0.1, odl = 0.03, material = "steel" },
            { L = 0.1, odl = 0.03, material = "steel" },
            { L = 0.1, odl = 0.03, material = "steel", beta = 2e-5 }]
disks = [{ node = 2, m = 4.0, Id = 0.01, Ip = 0.02 }]
unbalances = [{ node = 2, magnitude = 2e-5, phase = 0.7 }]
bearings = [{ node = 0, kxx = 1e7, kyy = 2e7, kxy = 1e6, cxx = 300.0 },
            { node = 3, kxx = 3e7, cxx = 200.0, cyy = 500.0 }]

[reduction]
method = "none"
node = 2

[parameters]
speed_rpm = { value = 6000.0, unit = "rpm", source = "test" }
radial_load = { value = 10.0, unit = "N", source = "test" }

[[terms]]
kind = "radial_load"
"""


def test_the_generated_model_is_the_finite_element_model(user_cache):
    """Unreduced, the generated rhs is M q'' + (C + Ω G) q' + K q = f(t) of the assembly:
    the same damped natural frequencies at speed, the same unbalance and load forces."""
    path = _write(user_cache, LINEAR_ROTOR, "linear-rotor")
    model = load_model(str(path))
    assert model.state_names[:4] == ("x", "y", "x_q1", "y_q1")
    spec = load_spec(path)[0]
    rotor = assemble_shaft(spec.shaft)
    k_b, c_b = rotor.bearing_matrices(0.0)
    omega = 6000 * np.pi / 30
    funcs = model.functions(())
    p = np.asarray(model.parameter_vector(model.defaults), dtype=float)
    n = model.n_state
    lam = np.linalg.eigvals(np.array(funcs.jac(0.0, np.zeros(n), p)))
    ours = np.sort(lam.imag[(lam.imag > 0) & (-lam.real <= OSCILLATING * np.abs(lam))])
    theirs = damped_frequencies(rotor.M, rotor.C + c_b + omega * rotor.G, rotor.K + k_b)
    assert ours.size == theirs.size >= 10
    assert np.allclose(ours / (2 * np.pi), theirs, rtol=1e-8)
    # forces at rest: T^T f(t) / m, f the unbalance (ROSS's convention) and the radial load
    t = 0.0123
    accel = np.array(funcs.rhs(t, np.zeros(n), p)).ravel()[n // 2:]
    force = np.real(unbalance_force_amplitudes(rotor.n_dof, spec.shaft.unbalances, omega)
                    * np.exp(1j * omega * t))
    force[4 * 2] += 10.0  # the radial load at the model's body, node 2, +x
    mass = np.array([float(m) for m in model.module.mass(p)])
    transform = np.zeros((rotor.n_dof, n // 2))
    for node, rows in enumerate(model.module.NODE_MAP):
        for j, a, b in rows:
            transform[4 * node, j], transform[4 * node + 1, j] = a, b
    expected = transform.T @ force
    assert np.allclose(accel * mass, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())


def test_the_shipped_rotor_is_its_reduced_matrices_with_the_balls_off(three_disk):
    """The generated three-disk rotor (its damping written as β K_r q', the elements' ROSS
    proportional damping) linearised with the balls out of contact is
    diag(m) q'' = -K_r q - (C_r + Ω G_r + c Σ_b T_b^T T_b) q', C_r projected separately."""
    _, _, stated = three_disk
    red = stated.reduced
    model = load_model("three-disk-rotor")
    values = {**model.defaults, "radial_clearance": 1e-3, "speed_rpm": 7000.0}
    p = np.asarray(model.parameter_vector(values), dtype=float)
    n = model.n_state
    jac = np.array(model.functions(None).jac(0.0, np.zeros(n), p))
    bearings = sum(np.outer(row, row) for node in (0, 12) for row in red.node_rows(node))
    omega = 7000 * np.pi / 30
    expected = -np.hstack([red.stiffness, red.damping + omega * red.gyroscopic
                           + values["damping"] * bearings]) / red.mass[:, None]
    found = jac[n // 2:]
    assert np.allclose(found, expected, rtol=0, atol=1e-8 * np.abs(expected).max())
    assert np.array_equal(jac[: n // 2], np.hstack([np.zeros((n // 2, n // 2)),
                                                    np.eye(n // 2)]))


def test_modal_truncation_keeps_the_lowest_modes_of_a_shaft_on_linear_bearings():
    spec = parse_spec(tomllib.loads(LINEAR_ROTOR))
    rotor = assemble_shaft(spec.shaft)
    k_b, c_b = rotor.bearing_matrices(0.0)
    full = (rotor.M, rotor.K + k_b, rotor.C + c_b, rotor.G)
    red = reduce_rotor(*full, (), "modal", 3, 2)
    assert red.names == ("x", "y", "x_q1", "y_q1", "x_q2", "y_q2")
    assert "modal truncation: the 3 lowest modes per bending plane" in red.kept()
    x_row, y_row = red.node_rows(2)
    assert list(x_row) == [1.0, 0, 0, 0, 0, 0] and list(y_row) == [0, 1.0, 0, 0, 0, 0]
    for speed in (0.0, 6000.0, 12000.0):
        error, count = frequency_differences(full, red, speed, 0.0, 800.0)
        assert count >= 3 and error < 1e-3, (speed, error)


def _bad_specs() -> dict[str, tuple[dict, str]]:
    base = tomllib.loads((SPECS / "three-disk-rotor.toml").read_text())
    cases = {}

    def case(name, edit, message):
        data = copy.deepcopy(base)
        edit(data)
        cases[name] = (data, message)

    case("zero length", lambda d: d["shaft"]["elements"][2].update(L=0.0),
         "shaft.elements[2].L: must be in (0, 100], got 0.0")
    case("negative length", lambda d: d["shaft"]["elements"][0].update(L=-0.075),
         "shaft.elements[0].L: must be in (0, 100], got -0.075")
    case("disk at no node", lambda d: d["shaft"]["disks"][1].update(node=13),
         "shaft.disks[1].node: no node 13; the shaft's nodes are 0 to 12")
    case("bearing at no node", lambda d: d["bearings"][1].update(node=20),
         "bearings[1].node: no node 20; the shaft's nodes are 0 to 12")
    case("unbalance at no node", lambda d: d["shaft"]["unbalances"][0].update(node=14),
         "shaft.unbalances[0].node: no node 14")
    case("more modes than DOFs", lambda d: d["reduction"].update(modes=25),
         "reduction.modes: must be in [0, 24]")
    case("free shaft", lambda d: d["bearings"][1].update(node=0),
         "shaft: the shaft moves freely with its ball-bearing nodes held")
    return cases


@pytest.mark.parametrize("name", list(_bad_specs()))
def test_bad_shaft_input_is_one_problem_naming_its_field(name, tmp_path):
    data, message = _bad_specs()[name]
    with pytest.raises(SpecError) as error:
        parse_spec(data)
    assert error.value.problems == [error.value.problems[0]]
    assert message in error.value.problems[0]


def test_bad_shaft_input_is_one_line_and_exit_2_on_the_command_line(tmp_path, cli):
    """The issue's cases: an element of zero or negative length, a disk or bearing at a node
    that does not exist, a reduction keeping more modes than there are DOFs."""
    for name in ("zero length", "negative length", "disk at no node", "bearing at no node",
                 "more modes than DOFs"):
        data, message = _bad_specs()[name]
        folder = tmp_path / name.replace(" ", "-")
        folder.mkdir()
        out = folder / "out"
        res = cli("generate", str(_write(folder, data, "three-disk-rotor")), "--out", str(out))
        assert res.returncode == 2, res.stderr
        lines = res.stderr.strip().splitlines()
        assert len(lines) == 1 and message in lines[0], res.stderr
        assert not out.exists()


STUDY = "## A study no other tool makes"
"""The section of docs/flexible-rotors.md whose commands ``study_commands`` runs."""


def study_commands(tmp_path: Path) -> list[list[str]]:
    """The commands of the docs page's study, at a reduced size: 2 × 2 points, short
    transient and record, files in ``tmp_path``."""
    page = (SPECS.parent.parent / "docs" / "flexible-rotors.md").read_text()
    section = page.split(STUDY)[1].split("\n## ")[0]
    block = section.split("```bash\n")[1].split("```")[0]
    commands = []
    for line in block.replace("\\\n", " ").splitlines():
        words = line.split()[1:]  # without "bearingdyn"
        for option, small in (("--x", 2), ("--y", 2)):
            if option in words:
                i = words.index(option) + 1
                words[i] = ":".join([*words[i].split(":")[:3], str(small)])
        for option, small in (("--transient", "0.01"), ("--revolutions", "10")):
            if option in words:
                words[words.index(option) + 1] = small
        out = words.index("-o") + 1
        words[out] = str(tmp_path / Path(words[out]).name)
        words = [str(tmp_path / w) if w.endswith(".nc") and "/" not in w else w
                 for w in words]
        commands.append(words)
    return commands


def test_simulate_plot_lyapunov_and_chart_run_on_flexible_models(tmp_path, cli):
    """The commands take a flexible model unchanged (short runs): the shipped three-disk
    rotor's run and its orbits at both bearings (what ``plot --orbit`` draws); Lyapunov
    exponents of the stiff rotor (8 states: its full spectrum compiles quickly); the docs
    page's study (a chart of the three-disk rotor and its figure) at 2 × 2 points."""
    run = tmp_path / "run.nc"
    res = cli("simulate", "three-disk-rotor", "-o", str(run), "--duration", "0.003",
              "--transient", "0", "--no-compile")
    assert res.returncode == 0, res.stderr
    from analysis.provenance import load_dataset
    from analysis.signal.orbit import orbits

    drawn = orbits(load_dataset(run))
    assert [o.name for o in drawn] == ["bearing left", "bearing right"]
    assert all(o.clearance == pytest.approx(10e-6) for o in drawn)
    stiff = _write(tmp_path, STIFF_ROTOR, "stiff-rotor")
    res = cli("lyapunov", str(stiff), "--duration", "0.01", "--transient", "0.01", "--json",
              env={"BEARINGDYN_CACHE": str(tmp_path / "cache")})
    assert res.returncode == 0, res.stderr
    assert len(json.loads(res.stdout)["exponents"]) == 8
    commands = study_commands(tmp_path)
    assert [c[0] for c in commands] == ["chart", "plot"] and "three-disk-rotor" in commands[0]
    for command in commands:
        res = cli(*command, "--quiet") if command[0] == "chart" else cli(*command)
        assert res.returncode == 0, (command, res.stderr)
    chart = next(tmp_path / w for w in commands[0] if w.endswith(".nc"))
    with xr.open_dataset(chart) as ds:
        assert ds.sizes["speed_rpm"] == ds.sizes["radial_clearance"] == 2
        assert np.all(np.isfinite(ds["lyapunov"].values))
    assert Path(commands[1][commands[1].index("-o") + 1]).stat().st_size > 10_000
