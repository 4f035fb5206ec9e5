"""A ``Placement``, judged once (``analysis.integrate.kernels.placement``): the table of
devices and ``devices.DEVICES`` agree, a refusal names the parameter ``device`` (and its
option, ``text("--device")``), a ``Placement`` given is kept, and a chart, a brute-force
sweep, a basin study and an ensemble judge their device exactly once (``placement.judge``
counted), a chart on a GPU (CuPy's stand-in) checks the GPU once."""

from __future__ import annotations

import pickle
from dataclasses import replace

import numpy as np
import pytest

from analysis.errors import InputError
from analysis.integrate.ensemble import ensemble
from analysis.integrate.kernels import devices, placement
from analysis.integrate.kernels.placement import TABLE, DeviceError, Placement, place
from analysis.model import System
from analysis.stability.attractors import Box, basin_fractions
from analysis.sweeps.chart import stability_chart
from analysis.sweeps.diagram import bifurcation_diagram
from analysis.sweeps.grid import Axis, Setting
from tests.integrate.fake_cupy import FakeCupy, fake_gpu

SETTING = Setting("vakharia2015", None, {}, transient=0.05, samples=10)  # as test_kernel_checks
X, Y = Axis.parse("speed_rpm:4000:5000:2"), Axis.parse("n_balls:8:8")


@pytest.fixture
def judged(monkeypatch) -> list[str]:
    """The device names ``placement.judge`` was called with (every judgement of a device
    goes through it: ``place`` calls it by its module attribute)."""
    calls: list[str] = []
    judge = placement.judge

    def counting(device, members, steps):
        calls.append(device)
        return judge(device, members, steps)

    monkeypatch.setattr(placement, "judge", counting)
    return calls


def test_the_table_is_the_device_names_but_auto():
    assert devices.DEVICES == (*TABLE, "auto")
    assert all(name == row.name for name, row in TABLE.items())
    assert [row.gpu for row in TABLE.values()] == [False, True]
    assert TABLE["cpu"].problem() is None and TABLE["gpu"].hint == devices.INSTALL_HINT


def test_a_refused_name_names_the_parameter_and_its_option():
    with pytest.raises(DeviceError) as refused:
        place("tpu", 10)
    err = refused.value
    assert isinstance(err, InputError) and err.field == "device"
    assert str(err) == "device: one of cpu, gpu, auto, got 'tpu'"
    assert err.text("--device") == "--device: one of cpu, gpu, auto, got 'tpu'"
    again = pickle.loads(pickle.dumps(err))  # as a worker process sends it back
    assert type(again) is DeviceError and str(again) == str(err)


def test_gpu_without_one_is_refused_once_with_the_way_out(monkeypatch):
    monkeypatch.setattr(devices, "gpu_problem", lambda: "no GPU is visible")
    with pytest.raises(DeviceError) as refused:
        place("gpu", 10)
    assert str(refused.value) == (f"device gpu: no GPU is visible; {devices.INSTALL_HINT}, "
                                  "or use device cpu")
    assert refused.value.text("--device").startswith("--device gpu: no GPU is visible; ")
    assert refused.value.text("--device").endswith(", or use --device cpu")


def test_the_auto_rule_is_the_thresholds_and_a_usable_gpu(monkeypatch):
    wide, long = devices.AUTO_MIN_MEMBERS, -(-devices.AUTO_MIN_STEPS // devices.AUTO_MIN_MEMBERS)
    monkeypatch.setattr(devices, "gpu_problem", lambda: None)
    assert place("auto", wide, steps=long).gpu
    assert not place("auto", wide - 1, steps=10 * long).gpu
    assert not place("auto", wide, steps=long - 1).gpu
    monkeypatch.setattr(devices, "gpu_problem", lambda: "no GPU is visible")
    assert place("auto", wide, steps=long).kind == "cpu"


def test_a_placement_is_its_name_where_names_were_used():
    placed = place("cpu", 3)
    assert placed == "cpu" and placed != "gpu" and str(placed) == "cpu"
    assert {"cpu": 32, "gpu": 1 << 15}[placed] == 32  # tables keyed by the name
    assert pickle.loads(pickle.dumps(placed)) == placed
    assert isinstance(placed, Placement) and placed.asked == "cpu" and placed.members == 3
    assert placed.variants == () and not placed.gpu


def test_a_placement_given_is_kept_and_builds_only_what_it_lacks(judged):
    system = System.make("balanced-rotor", n_balls=8, radial_load=50.0, speed_rpm=8000.0)
    placed = place("cpu", 4, system, "state")
    assert placed.variants == ("state",) and judged == ["cpu"]
    assert place(placed, 99, system, "state") is placed
    both = place(placed, 99, [system], ("state", "tangent"))
    assert both.variants == ("state", "tangent") and both.members == 4
    assert judged == ["cpu"]  # kept: not judged again
    with pytest.raises(InputError, match=r"^variant: one of state, tangent, got 'lanes'$"):
        place("cpu", 4, system, "lanes")


@pytest.mark.parametrize("device", ["cpu", "auto"])
def test_a_chart_judges_its_device_once(judged, device, tmp_path):
    ds = stability_chart(SETTING, X, Y, tmp_path / "c.nc", device=device)
    assert ds.nature_code.shape == (1, 2)
    assert judged == [device]


def test_a_chart_on_a_gpu_checks_it_once(judged, monkeypatch, tmp_path):
    """On CuPy's stand-in: the GPU's availability (``devices.gpu_problem``) is asked once,
    by the chart's one judgement; its points then run on the GPU path."""
    system = SETTING.system_at(speed_rpm=4000.0, n_balls=8)
    asked: list[bool] = []
    with fake_gpu(monkeypatch, FakeCupy(system, seen := [])):
        problem = devices.gpu_problem

        def counted():
            asked.append(True)
            return problem()

        monkeypatch.setattr(devices, "gpu_problem", counted)
        ds = stability_chart(SETTING, X, Y, tmp_path / "c.nc", device="gpu")
    assert ds.nature_code.shape == (1, 2) and seen and all(seen)  # the tangent variant
    assert judged == ["gpu"] and len(asked) == 1


def test_a_brute_force_sweep_judges_its_device_once(judged, tmp_path):
    ds = bifurcation_diagram(replace(SETTING, n_balls=8), X, tmp_path / "d.nc", follow=False,
                             device="cpu")
    assert len(ds.speed_rpm) == 2
    assert judged == ["cpu"]


def test_a_featurizing_study_judges_its_device_once(judged):
    rotor = System.make("balanced-rotor", n_balls=8, radial_load=50.0, speed_rpm=8000.0)
    box = Box.parse(["x:-20e-6:30e-6", "y:-20e-6:20e-6"])
    ds = basin_fractions(rotor, box, 40, seed=1, block=20, mapper="features", device="cpu")
    assert ds.attrs["device"] == "cpu" and ds.attrs["mapper"] == "features"
    assert judged == ["cpu"]


def test_an_ensemble_judges_its_device_once(judged):
    system = System.make("balanced-rotor", n_balls=8, radial_load=50.0, speed_rpm=8000.0)
    states = system.state + 1e-7 * np.arange(3)[:, None]
    ds = ensemble(system, states, 0.002, device="auto")
    assert ds.sizes["member"] == 3
    assert judged == ["auto"]


@pytest.mark.parametrize("args", [
    ["basins", "duffing", "--x", "x:-3:3:4", "--y", "vx:-3:3:4"],
    ["attractors", "duffing", "--samples", "8", "--box", "x:-3:3", "--box", "vx:-3:3"],
    ["attractors", "duffing", "--samples", "8", "--box", "x:-3:3", "--box", "vx:-3:3",
     "--param", "forcing_amplitude:7.4:7.5:2"],
], ids=["basins", "attractors", "global-continuation"])
def test_an_attractor_command_judges_its_device_once(judged, args, tmp_path):
    """The command's checks, its cost and its run share the placement judged first (they
    made the study three times, each judging the device)."""
    from typer.testing import CliRunner

    from analysis.cli import app

    done = CliRunner().invoke(app, [*args, "-o", str(tmp_path / "out.nc"), "--mapper",
                                    "features", "--device", "cpu", "--executor", "serial",
                                    "--transient-periods", "20", "--sections", "48"])
    assert done.exit_code == 0, done.output
    assert judged == ["cpu"]
