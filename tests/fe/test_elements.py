"""The symbolic Timoshenko element against closed-form beam results (no ROSS needed).

A uniform simply supported shaft (x and y held at both ends, rotations free) has the mode
shapes sin(n pi z / L) whatever its cross-section terms, so each model has an exact
frequency to converge to:

* Euler–Bernoulli (no shear, no rotary inertia): omega_n = (n pi / L)^2 sqrt(E I / (rho A));
* Timoshenko (shear and rotary inertia), with k = n pi / L, the lower root of
  (rho I rho / (kappa G)) w^4 - (rho A + k^2 rho I (1 + E / (kappa G))) w^2 + E I k^4 = 0;
* Rayleigh with gyroscopics (rotary inertia, spinning at Omega): the forward and backward
  whirl roots of (rho A + rho I k^2) w^2 -/+ 2 rho I k^2 Omega w - E I k^4 = 0.

The convergence over element counts is computed: it falls as h^4 for Euler–Bernoulli and
Rayleigh shafts (cubic shape functions), as h^2 once shear enters (phi = 12 E I /
(kappa G A h^2) grows as the elements shorten).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as la

from modelgen.errors import SpecError
from modelgen.fe.assembly import assemble, dof
from modelgen.fe.elements import shaft_element_matrices, shear_coefficient
from modelgen.fe.schema import Shaft, parse_shaft

E, G_S, RHO = 211e9, 81.2e9, 7810.0
NU = E / (2 * G_S) - 1


def uniform_shaft(length: float, d: float, n: int, **flags) -> Shaft:
    return Shaft.model_validate({
        "materials": [{"name": "steel", "E": E, "G_s": G_S, "rho": RHO}],
        "elements": [{"L": length / n, "odl": d, "material": "steel", **flags}] * n})


def pinned(rotor) -> np.ndarray:
    """Indices of the free DOFs once x and y of both end nodes are held."""
    held = {dof(0, "x"), dof(0, "y"), dof(rotor.n_nodes - 1, "x"),
            dof(rotor.n_nodes - 1, "y")}
    return np.array([i for i in range(rotor.n_dof) if i not in held])


def planar_frequencies(shaft: Shaft, count: int) -> np.ndarray:
    """The first ``count`` distinct natural frequencies (rad/s) at rest (each appears
    twice: x and y)."""
    rotor = assemble(shaft)
    keep = pinned(rotor)
    w2 = la.eigh(rotor.K[np.ix_(keep, keep)], rotor.M[np.ix_(keep, keep)], eigvals_only=True)
    return np.sqrt(w2[::2][:count])


def spinning_frequencies(shaft: Shaft, speed: float) -> np.ndarray:
    """Damped natural frequencies (rad/s, > 0, ascending) at ``speed`` rad/s."""
    rotor = assemble(shaft)
    keep = pinned(rotor)
    sub = np.ix_(keep, keep)
    m, g, k = rotor.M[sub], speed * rotor.G[sub], rotor.K[sub]
    size = len(keep)
    a = np.block([[np.zeros((size, size)), np.eye(size)],
                  [-la.solve(m, k), -la.solve(m, g)]])
    lam = la.eigvals(a)
    return np.sort(lam.imag[lam.imag > 0])


def euler_bernoulli(length: float, d: float, n: int) -> float:
    area, inertia = math.pi * d**2 / 4, math.pi * d**4 / 64
    return (n * math.pi / length) ** 2 * math.sqrt(E * inertia / (RHO * area))


def timoshenko(length: float, d: float, n: int) -> float:
    area, inertia = math.pi * d**2 / 4, math.pi * d**4 / 64
    kappa = shear_coefficient(d, 0.0, NU, "cowper")
    k = n * math.pi / length
    a = RHO * inertia * RHO / (kappa * G_S)
    b = RHO * area + k**2 * RHO * inertia * (1 + E / (kappa * G_S))
    c = E * inertia * k**4
    return math.sqrt((b - math.sqrt(b * b - 4 * a * c)) / (2 * a))


def rayleigh_whirl(length: float, d: float, n: int, speed: float) -> tuple[float, float]:
    area, inertia = math.pi * d**2 / 4, math.pi * d**4 / 64
    k = n * math.pi / length
    a, b, c = RHO * area + RHO * inertia * k**2, 2 * RHO * inertia * k**2 * speed, \
        E * inertia * k**4
    root = math.sqrt(b * b + 4 * a * c)
    return (root - b) / (2 * a), (root + b) / (2 * a)  # backward, forward


COUNTS = (2, 4, 8, 16, 32)


def convergence(model, exact, **flags) -> np.ndarray:
    """Relative error of the first three frequencies (columns) per element count (rows)."""
    length, d = 1.0, 0.02 if model == "eb" else 0.2
    table = []
    for n in COUNTS:
        found = planar_frequencies(uniform_shaft(length, d, n, **flags), 3)
        table.append([found[i] / exact(length, d, i + 1) - 1 for i in range(3)])
    return np.abs(np.array(table))


def test_euler_bernoulli_shaft_converges_to_the_analytic_frequencies():
    table = convergence("eb", euler_bernoulli, shear_effects=False, rotary_inertia=False)
    # the table (relative error of modes 1-3 at 2, 4, 8, 16, 32 elements) goes to the docs
    assert np.all(table[COUNTS.index(16):] < 1e-3), table
    assert table[COUNTS.index(4), 0] < 1e-3 and np.all(table[-1] < 1e-5), table
    # fourth order: halving h divides the error by ~16 (>= 12 on the first mode)
    ratios = table[1:-1, 0] / table[2:, 0]
    assert np.all(ratios > 12), ratios
    assert np.all(np.diff(table[1:], axis=0) < 0), table


def test_timoshenko_shaft_converges_to_the_timoshenko_frequencies():
    table = convergence("timoshenko", timoshenko)  # L/d = 5: shear lowers mode 3 by ~25 %
    # the shear terms converge as h^2 (phi grows as 1/h^2 as the elements shorten)
    assert np.all(table[-1, :2] < 1e-3) and table[-1, 2] < 2e-3, table
    assert np.all(np.diff(table[1:], axis=0) < 0), table
    ratios = table[1:-1] / table[2:]
    assert np.all(ratios > 3.5), ratios
    eb = euler_bernoulli(1.0, 0.2, 3)
    assert timoshenko(1.0, 0.2, 3) < 0.85 * eb  # the test is not one of a negligible effect


def test_gyroscopic_matrix_splits_forward_and_backward_whirl_as_the_rayleigh_shaft():
    length, d, speed = 1.0, 0.1, 3000.0
    shaft = uniform_shaft(length, d, 24, shear_effects=False)
    found = spinning_frequencies(shaft, speed)[:2]
    backward, forward = rayleigh_whirl(length, d, 1, speed)
    assert found == pytest.approx([backward, forward], rel=1e-4)
    assert forward / backward > 1.01  # gyroscopic splitting well above the tolerance


def test_element_matrices_are_symmetric_and_skew_and_have_rigid_modes():
    m, k, g = shaft_element_matrices(0.3, 0.07, 0.02, E, G_S, RHO)
    assert np.allclose(m, m.T) and np.allclose(k, k.T) and np.allclose(g, -g.T)
    assert np.all(la.eigvalsh(m) > 0)
    # rigid translation and rigid tilt (x = z beta) carry no strain energy
    translate = np.array([1, 0, 0, 0, 1, 0, 0, 0.0])
    tilt = np.array([0, 0, 0, 1, 0.3, 0, 0, 1.0])
    for q in (translate, tilt):
        assert np.abs(k @ q).max() < 1e-6 * np.abs(k).max()
    # total mass of the element's translation: rho A L
    area = math.pi * (0.07**2 - 0.02**2) / 4
    assert translate @ m @ translate == pytest.approx(RHO * area * 0.3, rel=1e-12)


@pytest.mark.parametrize(("change", "message"), [
    ({"elements": [{"L": 0.0, "odl": 0.05, "material": "steel"}]},
     "shaft.elements[0].L: Input should be greater than 0"),
    ({"elements": [{"L": -0.1, "odl": 0.05, "material": "steel"}]},
     "shaft.elements[0].L: Input should be greater than 0"),
    ({"disks": [{"node": 7, "m": 1.0, "Id": 0.1, "Ip": 0.2}]},
     "shaft.disks[0].node: no node 7; the shaft's nodes are 0 to 2"),
    ({"bearings": [{"node": 3, "kxx": 1e6}]},
     "shaft.bearings[0].node: no node 3; the shaft's nodes are 0 to 2"),
    ({"elements": [{"L": 0.1, "odl": 0.05, "material": "iron"}] * 2},
     "shaft.elements[0].material: unknown material 'iron'; known: steel"),
    ({"bearings": [{"node": 0, "kxx": [1e6, 2e6]}]},
     "shaft.bearings[0]: kxx: a list needs speed_rpm"),
])
def test_bad_shafts_say_which_field(change, message):
    data = {"materials": [{"name": "steel", "E": E, "G_s": G_S, "rho": RHO}],
            "elements": [{"L": 0.1, "odl": 0.05, "material": "steel"}] * 2, **change}
    with pytest.raises(SpecError) as info:
        parse_shaft(data, "rotor.toml")
    assert message in str(info.value), str(info.value)


def test_tabulated_bearing_is_interpolated_over_rpm():
    shaft = Shaft.model_validate({
        "materials": [{"name": "steel", "E": E, "G_s": G_S, "rho": RHO}],
        "elements": [{"L": 0.1, "odl": 0.05, "material": "steel"}] * 2,
        "bearings": [{"node": 1, "speed_rpm": [0, 1000], "kxx": [1e6, 3e6], "kxy": 5e5,
                      "cxx": [10.0, 30.0]}]})
    kb, cb = assemble(shaft).bearing_matrices(500 * math.pi / 30)
    x, y = dof(1, "x"), dof(1, "y")
    assert kb[x, x] == pytest.approx(2e6) and kb[y, y] == pytest.approx(2e6)
    assert kb[x, y] == 5e5 and kb[y, x] == 0 and cb[y, y] == pytest.approx(20.0)
    assert assemble(shaft).bearing_matrices(1e4)[0][x, x] == pytest.approx(3e6)
