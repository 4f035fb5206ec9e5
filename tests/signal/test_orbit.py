"""Orbits: each body's centre and each bearing's relative displacement, checked against the
coordinates combined here by hand (rotor minus housing; the rotor's centre plus its tilt
times the bearing's station), the clearance from the run's attrs, the marks once per
revolution at t = k/X (and where a run-up's angle, integrated here, crosses 2πk); the
plot command's --orbit and --full-spectrum, and its one-line refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis import simulate
from analysis.errors import InputError
from analysis.signal.orbit import orbits


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("orbits")
    out = {}
    for name in ("vakharia2015", "rotor-housing", "two-bearing-rotor"):
        ds = simulate(name, duration=0.25, transient=0.2)
        ds.to_netcdf(folder / f"{name}.nc")
        out[name] = (ds, folder / f"{name}.nc")
    return out


def test_one_body_one_bearing_is_one_orbit_with_its_clearance(runs):
    ds, _ = runs["vakharia2015"]
    (orbit,) = orbits(ds)
    assert orbit.name == "bearing"
    assert np.array_equal(orbit.x, ds.x.values) and np.array_equal(orbit.y, ds.y.values)
    assert orbit.clearance == float(ds.attrs["radial_clearance"])
    period = 1 / float(ds.attrs["shaft_hz"])
    k = np.arange(math.ceil(float(ds.t[0]) / period - 1e-9),
                  math.floor(float(ds.t[-1]) / period + 1e-9) + 1)
    assert np.allclose(orbit.mark_t, k * period, rtol=0, atol=1e-12)
    # a mark is the state at k/X: between samples, close to the linear interpolation
    linear = np.interp(k * period, ds.t.values, ds.x.values)
    assert np.allclose(orbit.mark_x, linear, rtol=0, atol=2e-3 * float(np.ptp(ds.x.values)))


def test_a_bearing_between_two_bodies_is_their_relative_displacement(runs):
    ds, _ = runs["rotor-housing"]
    found = {o.name: o for o in orbits(ds)}
    assert set(found) == {"rotor", "housing", "bearing"}
    bearing = found["bearing"]
    assert np.allclose(bearing.x, ds.x_rotor - ds.x_housing, rtol=0, atol=1e-18)
    assert np.allclose(bearing.y, ds.y_rotor - ds.y_housing, rtol=0, atol=1e-18)
    assert np.array_equal(found["housing"].x, ds.x_housing.values)
    assert bearing.clearance == float(ds.attrs["radial_clearance"])
    assert found["rotor"].clearance is None


def test_a_tilting_rotor_has_an_orbit_at_each_bearing_station(runs):
    ds, _ = runs["two-bearing-rotor"]
    found = {o.name: o for o in orbits(ds)}
    assert set(found) == {"rotor", "bearing left", "bearing right"}
    for side in ("left", "right"):
        station = float(ds.attrs[f"station_{side}"])
        assert np.allclose(found[f"bearing {side}"].x, ds.x + station * ds.tx, rtol=0,
                           atol=1e-18)
        assert np.allclose(found[f"bearing {side}"].y, ds.y + station * ds.ty, rtol=0,
                           atol=1e-18)


def test_a_run_up_is_marked_where_its_integrated_angle_turns():
    from analysis.integrate.speed_profile import SpeedProfile

    ds = simulate("vakharia2015", speed_rpm=SpeedProfile.ramp(3000, 6000), duration=0.3,
                  transient=0.1)
    (orbit,) = orbits(ds)
    t = orbit.mark_t
    revolutions = (3000 * t + 0.5 * (6000 - 3000) / 0.3 * t**2) / 60  # ∫ n dt, by hand
    assert np.allclose(revolutions, np.round(revolutions), rtol=0, atol=1e-9)
    assert np.all(np.diff(np.round(revolutions)) == 1) and t.size >= 15


def test_a_pair_of_coordinates_and_refusals(runs):
    ds, _ = runs["rotor-housing"]
    (orbit,) = orbits(ds, "x_housing", "y_housing")
    assert np.array_equal(orbit.y, ds.y_housing.values)
    with pytest.raises(InputError, match="no state variable 'z_housing'"):
        orbits(ds, "x_housing", "z_housing")
    mathieu = simulate("mathieu", duration=2.0, transient=1.0)
    with pytest.raises(InputError, match="two coordinates"):
        orbits(mathieu)


def test_the_plot_command_draws_orbits_and_refuses_in_one_line(runs, tmp_path, cli):
    _, path = runs["rotor-housing"]
    out = tmp_path / "orbit.png"
    done = cli("plot", str(path), "--orbit", "-o", str(out))
    assert done.returncode == 0, done.stderr
    assert out.stat().st_size > 0
    bad = cli("plot", str(path), "--orbit", "--var", "x_rotor", "--var", "q", "-o",
              str(tmp_path / "bad.png"))
    assert bad.returncode == 2
    assert bad.stderr.strip().count("\n") == 0 and "'q'" in bad.stderr
    assert not (tmp_path / "bad.png").exists()
    both = cli("plot", str(path), "--orbit", "--bode", "-o", str(tmp_path / "b.png"))
    assert both.returncode == 2 and "give one of" in both.stderr


def test_the_plot_command_prints_the_full_spectrum_lines(runs, tmp_path, cli):
    _, path = runs["vakharia2015"]
    out = tmp_path / "full.png"
    done = cli("plot", str(path), "--full-spectrum", "-o", str(out))
    assert done.returncode == 0, done.stderr
    rows = [line.split() for line in done.stdout.splitlines()
            if line.split()[:1] in (["forward"], ["backward"])]
    assert rows, done.stdout
    for whirl, frequency, *_ in rows:
        assert (float(frequency) > 0) == (whirl == "forward")
