"""Stroboscopic Poincaré sections against analytic periodic signals."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from analysis.signal.poincare import SECTIONS, poincare_section, section_period

X = 83.3333  # shaft frequency, Hz: its period is not a multiple of dt
CAGE = 33.2234
VC = 6 * CAGE
DT = 1e-5
ATTRS = {"shaft_hz": X, "cage_hz": CAGE, "vc_hz": VC, "n_balls": 6, "model": "synthetic"}


def _dataset(components, t0: float = 1.0, duration: float = 0.5, attrs=ATTRS) -> xr.Dataset:
    """x = Σ A cos(2π f t + φ), y = Σ A sin(2π f t + φ) and their exact derivatives."""
    t = t0 + DT * np.arange(round(duration / DT) + 1)
    x, y, vx, vy = _analytic(components, t)
    return xr.Dataset(
        {"x": ("t", x, {"units": "m"}), "y": ("t", y, {"units": "m"}),
         "vx": ("t", vx, {"units": "m/s"}), "vy": ("t", vy, {"units": "m/s"})},
        coords={"t": ("t", t, {"units": "s"})},
        attrs=dict(attrs),
    )


def _analytic(components, t):
    t = np.asarray(t, dtype=float)
    x, y, vx, vy = (np.zeros_like(t) for _ in range(4))
    for amplitude, frequency, phi in components:
        w = 2 * np.pi * frequency
        x += amplitude * np.cos(w * t + phi)
        y += amplitude * np.sin(w * t + phi)
        vx -= amplitude * w * np.sin(w * t + phi)
        vy += amplitude * w * np.cos(w * t + phi)
    return x, y, vx, vy


def test_section_periods():
    ds = _dataset([(1e-6, X, 0.0)], duration=0.01)
    assert SECTIONS == ("shaft", "cage", "vc")
    assert section_period(ds, "shaft") == pytest.approx(1 / X, rel=1e-15)
    assert section_period(ds, "cage") == pytest.approx(1 / CAGE, rel=1e-15)
    assert section_period(ds, "vc") == pytest.approx(1 / VC, rel=1e-15)


@pytest.mark.parametrize("bad", ["rotor", "Shaft", ""])
def test_bad_section_name(bad):
    ds = _dataset([(1e-6, X, 0.0)], duration=0.01)
    with pytest.raises(ValueError, match="section") as info:
        poincare_section(ds, bad)
    assert all(name in str(info.value) for name in SECTIONS)
    with pytest.raises(ValueError, match="section"):
        section_period(ds, bad)


@pytest.mark.parametrize("phase", [0.0, 0.3])
def test_period_one_signal_gives_one_point(phase):
    amplitude, phi = 2e-6, 0.7
    ds = _dataset([(amplitude, X, phi)])
    section = poincare_section(ds, "shaft", phase=phase)
    # t_k = (phase + k)/X for k = 84 .. 124 inside [1.0, 1.5] s.
    assert section["k"].values.tolist() == list(range(84, 125))
    np.testing.assert_allclose(section["t"].values, (phase + section["k"].values) / X,
                               rtol=1e-15)
    # No t_k falls on a sample (1/X = 1200.00048 dt): every point is interpolated.
    offset = (section["t"].values - 1.0) / DT
    assert np.abs(offset - np.round(offset)).min() > 0.01
    w = 2 * np.pi * X
    angle = 2 * np.pi * phase + phi
    expected = {"x": amplitude * np.cos(angle), "y": amplitude * np.sin(angle),
                "vx": -amplitude * w * np.sin(angle), "vy": amplitude * w * np.cos(angle)}
    # x, y: Hermite error ~ (ω dt)⁴/384 ≈ 2e-12. vx, vy are interpolated with derivatives
    # from second-order numpy.gradient: error up to ≈ 0.016 (ω dt)³ ≈ 2.3e-9, hence 1e-8.
    for name, value in expected.items():
        velocity = name.startswith("v")
        scale = amplitude * (w if velocity else 1.0)
        np.testing.assert_allclose(section[name].values, value, rtol=0,
                                   atol=(1e-8 if velocity else 1e-9) * scale)
    for name in ("x", "y"):
        spread = np.ptp(section[name].values)
        assert spread < 1e-11 * amplitude  # one point


def test_output_layout_and_attrs():
    ds = _dataset([(2e-6, X, 0.0)], duration=0.1)
    section = poincare_section(ds, "cage", phase=0.25)
    assert section["x"].dims == ("k",)
    assert section["t"].dims == ("k",)
    assert section["t"].attrs["units"] == "s"
    assert {name: section[name].attrs["units"] for name in ("x", "y", "vx", "vy")} == {
        "x": "m", "y": "m", "vx": "m/s", "vy": "m/s"}
    assert section.attrs["model"] == "synthetic"
    assert section.attrs["section"] == "cage"
    assert section.attrs["section_period_s"] == pytest.approx(1 / CAGE)
    assert section.attrs["phase"] == 0.25
    # (0.25 + k)/CAGE in [1.0, 1.1] s: k = 33 (1.0008 s) .. 36 (1.0911 s).
    assert section["k"].values.tolist() == [33, 34, 35, 36]
    np.testing.assert_allclose(section["t"].values, (0.25 + np.arange(33, 37)) / CAGE,
                               rtol=1e-15)


def test_subharmonic_gives_two_points():
    amplitude = 2e-6
    ds = _dataset([(amplitude, X, 0.3), (0.5 * amplitude, X / 2, 1.1)])
    section = poincare_section(ds, "shaft")
    points = np.column_stack([section[name].values for name in ("x", "y")])
    assert len(points) >= 40
    first, second = points[0], points[1]
    assert np.linalg.norm(first - second) > 0.5 * amplitude
    tolerance = 1e-9 * amplitude
    is_first = np.linalg.norm(points - first, axis=1) < tolerance
    is_second = np.linalg.norm(points - second, axis=1) < tolerance
    assert np.all(is_first ^ is_second)
    assert np.array_equal(is_first, section["k"].values % 2 == section["k"].values[0] % 2)


def test_hermite_interpolation_error_off_grid():
    components = [(3e-6, X, 0.2), (1e-6, VC - X, 1.3), (4e-7, 2 * X, -0.4)]
    ds = _dataset(components, duration=0.5)
    section = poincare_section(ds, "vc", phase=0.37)
    t = section["t"].values
    offset = (t - 1.0) / DT
    off_grid = np.abs(offset - np.round(offset)) > 0.05
    assert off_grid.sum() >= 0.8 * t.size and t.size >= 90
    expected = _analytic(components, t)
    for name, value in zip(("x", "y", "vx", "vy"), expected, strict=True):
        scale = np.abs(ds[name].values).max()
        error = np.abs(section[name].values - value).max()
        assert error < 1e-8 * scale, (name, error / scale)


def test_section_time_on_a_sample_uses_the_sample_exactly():
    attrs = {**ATTRS, "shaft_hz": 100.0}  # period 0.01 s = 1000 samples
    rng = np.random.default_rng(1)
    t = 1.0 + DT * np.arange(5001)
    ds = xr.Dataset({name: ("t", rng.normal(size=t.size)) for name in ("x", "y", "vx", "vy")},
                    coords={"t": t}, attrs=attrs)
    section = poincare_section(ds, "shaft")
    assert section["k"].values.tolist() == [100, 101, 102, 103, 104, 105]
    for name in ("x", "y", "vx", "vy"):
        assert np.array_equal(section[name].values, ds[name].values[::1000])
    # Half a sample later the values are interpolated, hence different.
    shifted = poincare_section(ds, "shaft", phase=0.0005)
    assert not np.array_equal(shifted["x"].values, ds["x"].values[:-1:1000])


def test_bad_phase():
    ds = _dataset([(1e-6, X, 0.0)], duration=0.01)
    for phase in (-0.1, 1.0):
        with pytest.raises(ValueError, match="phase"):
            poincare_section(ds, phase=phase)


def test_sections_of_several_bearings_and_of_a_parameter():
    """vc[b], cage[b] read the bearing's own attrs; vc and cage mean the first bearing;
    param:NAME the parameter's value in s."""
    attrs = {"shaft_hz": X, "cage_hz_left": CAGE, "vc_hz_left": 7 * CAGE,
             "cage_hz_right": 0.9 * CAGE, "vc_hz_right": 11 * 0.9 * CAGE,
             "n_balls_left": 7, "n_balls_right": 11, "forcing_period": 0.02}
    ds = _dataset([(1e-6, X, 0.0)], duration=0.01, attrs=attrs)
    assert section_period(ds, "vc[right]") == pytest.approx(1 / (11 * 0.9 * CAGE), rel=1e-15)
    assert section_period(ds, "cage[right]") == pytest.approx(1 / (0.9 * CAGE), rel=1e-15)
    assert section_period(ds, "vc") == section_period(ds, "vc[left]")
    assert section_period(ds, "param:forcing_period") == 0.02
    for bad in ("vc[middle]", "shaft[left]", "param:nothing", "vc[left"):
        with pytest.raises(ValueError):
            section_period(ds, bad)


def test_any_state_variables_are_kept_and_interpolated():
    """A state x, tx, vx, vtx (a tilt with its rate) on the section: tx with its rate as
    derivative, exactly as x with vx; order and attrs of the run kept."""
    t = 1.0 + DT * np.arange(20001)
    w = 2 * np.pi * X
    data = {"x": np.cos(w * t), "tx": 2 * np.sin(w * t),
            "vx": -w * np.sin(w * t), "vtx": 2 * w * np.cos(w * t)}
    ds = xr.Dataset({k: ("t", v, {"units": "rad" if "t" in k[1:] or k == "tx" else "m"})
                     for k, v in data.items()}, coords={"t": t},
                    attrs={**ATTRS, "state_names": "x tx vx vtx"})
    section = poincare_section(ds, "vc", phase=0.37)
    assert list(section.data_vars) == ["x", "tx", "vx", "vtx"]
    tk = section.t.values
    np.testing.assert_allclose(section.tx.values, 2 * np.sin(w * tk), atol=1e-9)
    np.testing.assert_allclose(section.vtx.values, 2 * w * np.cos(w * tk), rtol=0,
                               atol=1e-6 * 2 * w)
    assert section.tx.attrs["units"] == "rad"
