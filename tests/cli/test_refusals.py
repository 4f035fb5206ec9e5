"""A refused command leaves no trace and never blocks the corrected one.

Every command that stores state between runs (``sweep`` and ``chart``: ``OUT.parts``;
``reproduce``: its report folder and the sensitivity charts' parts; ``generate``: a model
folder) is refused once, then run corrected: the refusal leaves the folder as it was, and
the corrected command runs to its end.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from analysis.errors import InputError
from analysis.io import open_result
from analysis.sweeps.grid import Axis, Setting
from analysis.sweeps.store import PointStore
from tests.cli.test_bad_inputs import _listing
from tests.conftest import SPECS, run_cli

SWEEP = ("sweep", "vakharia2015", "--n-balls", "8", "--param", "speed_rpm", "--from", "4000",
         "--to", "4500", "--num", "2", "--transient", "0.02", "--samples", "5", "--executor",
         "serial", "--quiet", "-o", "d.nc")
CHART = ("chart", "vakharia2015", "--x", "speed_rpm:4000:4500:2", "--y", "n_balls:7:8",
         "--transient", "0.02", "--revolutions", "5", "--no-lyapunov", "--executor", "serial",
         "--quiet", "-o", "c.nc")
TINY = Setting("vakharia2015", 8, {}, transient=0.02, samples=5, lyapunov=False)


def _refused_then_corrected(folder: Path, refused: tuple[str, ...],
                            corrected: tuple[str, ...], output: str) -> None:
    before = _listing(folder)
    res = run_cli(*refused, cwd=folder)
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    assert _listing(folder) == before, "a refused command leaves the folder as it was"
    res = run_cli(*corrected, cwd=folder)
    assert res.returncode == 0, res.stderr
    assert open_result(folder / output) is not None
    assert not (folder / f"{output}.parts").exists()


@pytest.mark.parametrize("command", [SWEEP, CHART], ids=["sweep", "chart"])
def test_a_sweep_refused_for_its_step_leaves_nothing_and_blocks_nothing(command, tmp_path):
    _refused_then_corrected(tmp_path, (*command, "--dt", "0.002"), command, command[-1])


@pytest.mark.parametrize("command", [SWEEP, CHART], ids=["sweep", "chart"])
def test_a_parts_folder_without_points_does_not_block_another_definition(command, tmp_path):
    """What a refusal of an older bearingdyn left: a definition and no stored point."""
    PointStore(tmp_path / command[-1], {"kind": "refused earlier"}, lock=True).close()
    res = run_cli(*command, cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert not (tmp_path / f"{command[-1]}.parts").exists()


def test_a_point_refused_by_its_worker_leaves_no_parts(tmp_path, monkeypatch):
    """A refusal that comes only when a point runs (after the store was made): the store's
    folder goes again, and the corrected sweep runs."""
    from analysis.sweeps import chart, diagram

    def refuse(*args, **kwargs):
        raise InputError("dt: refused at this point")

    for module, name in ((diagram, "diagram_point"), (chart, "chart_points"),
                         (chart, "chart_grid_points")):  # a group planned as arrays or by Systems
        monkeypatch.setattr(module, name, refuse)
    axis = Axis.linear("speed_rpm", 4000.0, 4500.0, 2)
    with pytest.raises(InputError, match="refused at this point"):
        diagram.bifurcation_diagram(TINY, axis, tmp_path / "d.nc")
    with pytest.raises(InputError, match="refused at this point"):
        chart.stability_chart(TINY, axis, Axis.parse("radial_load:6:50:2"),
                              tmp_path / "c.nc")
    assert list(tmp_path.iterdir()) == []
    monkeypatch.undo()
    assert diagram.bifurcation_diagram(TINY, axis, tmp_path / "d.nc").sizes["speed_rpm"] == 2
    assert list(tmp_path.iterdir()) == [tmp_path / "d.nc"]


def test_a_resumed_sweep_keeps_its_points_when_a_later_point_fails(tmp_path):
    """``discard`` removes only a folder the failed run made itself, and never points."""
    store = PointStore(tmp_path / "d.nc", {"kind": "a"}, lock=True)
    store.save("up-00000", {"x": [1.0]})
    store.discard()
    again = PointStore(tmp_path / "d.nc", {"kind": "a"}, lock=True)
    assert again.done() == {"up-00000"}
    again.discard()
    assert (tmp_path / "d.nc.parts" / "up-00000.npz").exists()
    with pytest.raises(InputError, match="different definition"):
        PointStore(tmp_path / "d.nc", {"kind": "b"}, lock=True)


def test_reproduce_refused_leaves_no_folder_then_runs(tmp_path):
    """An unknown model, a run or a chart that would be refused, a run too short for its
    verdict: refused before the report folder is made; the corrected reproduction writes
    its runs and charts."""
    from analysis.reports.reproduce import reproduce

    res = run_cli("reproduce", "vakharia", "--quick", "-o", "rep", cwd=tmp_path)
    assert res.returncode == 2 and "no model named 'vakharia'" in res.stderr
    small = dict(n_balls=(8,), duration=0.6, transient=0.1, revolutions=10)
    for bad in ({"model": "vakharia"}, {"duration": 0.05}, {"duration": 0.3},
                {"sensitivity": {"dampign": (1.0, 2.0)}}):
        with pytest.raises(InputError):
            reproduce(tmp_path / "rep", **{"model": "vakharia2015", **small,
                                           "sensitivity": {"damping": (200.0, 400.0)},
                                           **bad})
    assert list(tmp_path.iterdir()) == []
    rep = reproduce(tmp_path / "rep", **small, sensitivity={"damping": (200.0, 400.0)})
    assert [row.n_balls for row in rep.rows] == [8]
    runs = sorted(p.name for p in (tmp_path / "rep" / "runs").iterdir())
    assert runs == ["nb8.nc", "sensitivity-damping.nc"]


def test_generate_refused_then_corrected(tmp_path):
    text = (SPECS / "duffing.toml").read_text()
    (tmp_path / "duffing.toml").write_text(text.replace('kind = "', 'kind = "x', 1))
    res = run_cli("generate", "duffing.toml", "--out", "gen", cwd=tmp_path)
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["duffing.toml"]
    (tmp_path / "duffing.toml").write_text(text)
    res = run_cli("generate", "duffing.toml", "--out", "gen", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    res = run_cli("simulate", "gen", "-o", "r.nc", "--duration", "0.5", "--transient", "0",
                  "--no-compile", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
