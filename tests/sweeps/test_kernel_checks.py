"""Member kernels judged before any work (``kernels.members.check_kernels`` through
``points.grid_device``): a chart or a brute-force diagram whose member kernel cannot be
written is one ``InputError`` naming the model and the reason on ``device="cpu"`` or
``"gpu"``, before the store or any point; ``auto`` keeps the chart's point-by-point
fallback.

No shipped or user spec yields an operation the kernel writer does not emit (specs give
+ - * / pow sqrt exp sin cos fabs fmin fmax and comparisons, all written), so the writer is
made to refuse one: ``ADD`` taken out of ``source.BINARY`` (every model adds). The CLI side
(``tests/cli/test_devices.py``) uses a real cause instead: no C compiler."""

from __future__ import annotations

from dataclasses import replace

import pytest

from analysis.errors import InputError
from analysis.integrate.kernels import cpu, devices, members, placement, source
from analysis.sweeps.chart import chart_device, stability_chart
from analysis.sweeps.diagram import bifurcation_diagram
from analysis.sweeps.grid import Axis, Setting
from analysis.sweeps.points import grid_balls

SETTING = Setting("vakharia2015", None, {}, transient=0.05, samples=10)
EIGHT = replace(SETTING, n_balls=8)  # a diagram over speed: the balls given
X, Y = Axis.parse("speed_rpm:4000:5000:2"), Axis.parse("n_balls:8:8")
WIDE = Axis.linear("speed_rpm", 4000.0, 5000.0, 4 * devices.AUTO_MIN_MEMBERS)
REFUSED = (r"^device {}: the member kernel of model 'vakharia2015' with N_b 8 cannot be "
           r"built: .*operation ADD is not written as member C$")


def _clear() -> None:
    cpu.cpu_library.cache_clear()
    members._self_test.cache_clear()
    members._self_test_gpu.cache_clear()


@pytest.fixture
def unwritable(monkeypatch):
    """The kernel writer without ``+``: no model's member kernel can be written."""
    monkeypatch.delitem(source.BINARY, "ADD")
    _clear()
    yield
    _clear()


def test_the_grid_balls_are_one_system_per_structure():
    systems = grid_balls(SETTING, [X, Axis.parse("n_balls:6:8")])
    assert [s.structure for s in systems] == [(6,), (7,), (8,)]
    assert len(grid_balls(SETTING, [WIDE])) == 1  # a parameter axis: its first value only


def test_a_chart_on_the_cores_is_refused_before_its_store(unwritable, tmp_path):
    with pytest.raises(InputError, match=REFUSED.format("cpu")):
        stability_chart(SETTING, X, Y, tmp_path / "c.nc", device="cpu")
    assert not any(tmp_path.iterdir())  # no file, no .parts folder


def test_a_brute_force_diagram_is_refused_before_its_store(unwritable, tmp_path):
    with pytest.raises(InputError, match=REFUSED.format("cpu")):
        bifurcation_diagram(EIGHT, X, tmp_path / "d.nc", follow=False, device="cpu")
    assert not any(tmp_path.iterdir())


def test_auto_keeps_the_charts_point_by_point_fallback(unwritable, tmp_path):
    ds = stability_chart(SETTING, X, Y, tmp_path / "c.nc", device="auto")
    assert ds.nature_code.shape == (1, 2) and (ds.nature_code.values > 0).all()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.nc"]


def test_a_gpu_that_cannot_build_is_refused_or_left_to_the_cores(unwritable, monkeypatch,
                                                                 tmp_path):
    """With a GPU (its check stubbed: the GPU self-test builds the CPU twin first, which
    the writer refuses), ``gpu`` is refused with the reason and a wide ``auto`` chart goes
    to the cores; a diagram, without a point-by-point path, refuses ``auto`` too."""
    monkeypatch.setattr(devices, "gpu_problem", lambda: None)
    setting = replace(SETTING, transient=1.0)  # wide and long: auto picks the GPU
    steps = round(setting.transient / setting.step())
    assert placement.resolve_device("auto", len(WIDE.values), steps) == "gpu"
    with pytest.raises(InputError, match=REFUSED.format("gpu")):
        chart_device(setting, WIDE, Y, "gpu")
    assert chart_device(setting, WIDE, Y, "auto") == "cpu"
    with pytest.raises(InputError, match=REFUSED.format("gpu")):
        bifurcation_diagram(replace(setting, n_balls=8), WIDE, tmp_path / "d.nc",
                            follow=False, device="auto")
    assert not any(tmp_path.iterdir())


def test_a_chart_without_lyapunov_builds_no_kernel(unwritable):
    setting = replace(SETTING, lyapunov=False)
    assert chart_device(setting, X, Y, "cpu") == "cpu"


@pytest.mark.skipif(devices.gpu_problem() is None, reason="a GPU is visible")
def test_gpu_without_one_says_what_is_missing_and_how_to_install_once():
    with pytest.raises(InputError) as refused:
        members.check_kernels(grid_balls(EIGHT, [X]), "gpu")
    text = str(refused.value)
    assert text.startswith(f"device gpu: {devices.gpu_problem()}; ")
    assert text.count("pip install") == 1 and "\n" not in text
