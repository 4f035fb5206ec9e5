"""The compiled RK4 path: same results as the VM, cached across loads, safe fallbacks."""

from __future__ import annotations

import shutil
import warnings

import casadi as ca
import numpy as np
import pytest

from analysis.integrate import compiled
from analysis.integrate.simulate import simulate
from analysis.model import load_model

MODEL, N_BALLS = "vakharia2015", 8
CALM = dict(damping=2000.0)
"""Non-chaotic setting: the rotor settles (see docs/numerics.md)."""


_COMPILER_VARIABLES = ("BEARINGDYN_CC", "BEARINGDYN_CFLAGS", "CC")


@pytest.fixture(scope="module")
def built_cache(tmp_path_factory):
    """A cache directory holding the compiled library of MODEL, N_BALLS."""
    if shutil.which(compiled.DEFAULT_CC) is None:
        pytest.skip(f"no C compiler ({compiled.DEFAULT_CC})")
    root = tmp_path_factory.mktemp("cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("BEARINGDYN_CACHE", str(root))
        for name in _COMPILER_VARIABLES:
            mp.delenv(name, raising=False)
        mp.setattr(compiled, "_REGISTRY", compiled._Registry())
        lib = compiled.library(load_model(MODEL), N_BALLS)
    assert lib.backend == "compiled" and lib.path.parent == root / "compiled"
    return root


@pytest.fixture
def fresh(tmp_path, monkeypatch):
    """An empty cache folder, the default compiler and a fresh in-process registry."""
    root = tmp_path / "cache"
    monkeypatch.setenv("BEARINGDYN_CACHE", str(root))
    for name in _COMPILER_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(compiled, "_REGISTRY", compiled._Registry())
    return root


@pytest.fixture
def cache(built_cache, fresh):
    """``fresh`` with a copy of the built cache in it."""
    shutil.copytree(built_cache, fresh)
    return fresh


def _library_file(root):
    (path,) = (root / "compiled").glob("*.so")
    return path


def _run(**kwargs):
    return simulate(MODEL, N_BALLS, duration=0.05, transient=0.0, save_every=7,
                    **CALM, **kwargs)


def test_compiled_and_vm_results_are_identical(cache):
    fast, vm = _run(), _run(compiled=False)
    assert compiled.library(load_model(MODEL), N_BALLS).backend == "compiled"
    for var in ("x", "y", "vx", "vy"):
        a, b = fast[var].values, vm[var].values
        assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()


def test_cached_library_is_reused_without_compiling(cache):
    path = _library_file(cache)
    mtime = path.stat().st_mtime_ns
    lib = compiled.library(load_model(MODEL), N_BALLS)
    assert lib.backend == "compiled" and lib.path == path
    assert compiled.compilations() == 0
    assert path.stat().st_mtime_ns == mtime
    assert compiled.library(load_model(MODEL), N_BALLS) is lib  # memoised in the process


@pytest.mark.skipif(shutil.which(compiled.DEFAULT_CC) is None, reason="no C compiler")
def test_compiled_libraries_land_in_the_compiled_folder_of_the_cache(fresh):
    """With BEARINGDYN_CACHE set, every library goes to <cache>/compiled/ (beside the
    generated code of user specs in <cache>/models/), not into the cache's root."""
    _run()
    x = ca.SX.sym("x")
    compiled.compiled_function(ca.Function("cache_root_probe", [x], [2 * x]), (1.5,))
    assert compiled.cache_dir() == fresh / "compiled"
    assert {p.name.split("_")[1] for p in (fresh / "compiled").glob("*.so")} >= {"fn", MODEL}
    assert sorted(p.relative_to(fresh).parts[0] for p in fresh.rglob("*.so")) == \
        ["compiled", "compiled"]


@pytest.mark.parametrize(("variable", "value", "reason"), [
    ("BEARINGDYN_CC", "/nonexistent/bin/cc", "'/nonexistent/bin/cc' not found"),
    pytest.param("BEARINGDYN_CACHE", "{tmp}/a-file/cache", "could not build",  # file in the way
                 marks=pytest.mark.skipif(shutil.which(compiled.DEFAULT_CC) is None,
                                          reason="no C compiler")),
])
def test_missing_compiler_falls_back_to_the_vm_with_one_warning(fresh, monkeypatch, tmp_path,
                                                                variable, value, reason):
    (tmp_path / "a-file").write_text("")
    monkeypatch.setenv(variable, value.format(tmp=tmp_path))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        first = _run()
        second = simulate(MODEL, 6, duration=0.01, transient=0.0)
    messages = [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]
    assert len(messages) == 1 and reason in messages[0]
    assert "virtual machine" in messages[0]
    assert compiled.compilations() == 0 and second.sizes["t"] == 1001
    np.testing.assert_array_equal(first.x.values, _run(compiled=False).x.values)


def test_corrupted_library_is_rebuilt(cache):
    path = _library_file(cache)
    path.write_bytes(b"\x7fELF but not really a shared library")
    lib = compiled.library(load_model(MODEL), N_BALLS)
    assert lib.backend == "compiled" and compiled.compilations() == 1
    assert path.stat().st_size > 1000
    np.testing.assert_array_equal(_run().x.values, _run(compiled=False).x.values)


def test_library_of_another_model_under_the_name_is_rebuilt(cache):
    """A library that loads but computes something else fails the self-test."""
    path = _library_file(cache)
    other = compiled.library(load_model("balanced-rotor"), N_BALLS)
    assert compiled.compilations() == 1
    shutil.copyfile(other.path, path)
    lib = compiled.library(load_model(MODEL), N_BALLS)
    assert lib.backend == "compiled" and compiled.compilations() == 2


def test_result_does_not_depend_on_how_the_run_is_cut_into_blocks(cache):
    """Time is t0 + n·h from the step counter: a longer run repeats a shorter one exactly."""
    short = simulate(MODEL, N_BALLS, duration=0.01234, transient=0.0, **CALM)
    long = simulate(MODEL, N_BALLS, duration=0.02, transient=0.0, **CALM)
    np.testing.assert_array_equal(short.x.values, long.x.values[:short.sizes["t"]])


def test_decimation_across_blocks_keeps_every_nth_step(cache):
    full = simulate(MODEL, N_BALLS, duration=0.12345, transient=0.0, **CALM)
    thin = simulate(MODEL, N_BALLS, duration=0.12345, transient=0.0, save_every=7, **CALM)
    np.testing.assert_array_equal(thin.vy.values, full.vy.values[::7])
    np.testing.assert_allclose(thin.t.values, full.t.values[::7], rtol=1e-15)


@pytest.mark.parametrize("n_steps", [0, 1, 9, 10, 11, 12345, 30_001])
def test_block_plan_covers_the_steps_in_few_calls(n_steps):
    plan = compiled.block_plan(n_steps)
    assert sum(plan) == n_steps and plan == sorted(plan, reverse=True)
    assert len(plan) - plan.count(compiled.BLOCK_SIZES[0]) <= 36


# The benchmark (analysis.reports.bench; benchmarks/bench_simulate.py runs it): its
# hand-written paths compute the same model.

@pytest.fixture(scope="module")
def bench():
    from analysis.reports import bench

    return bench


def test_benchmark_reference_matches_the_generated_model(bench):
    model = load_model(bench.MODEL)
    for values in (model.defaults, model.parameters(bench.CALM)):
        bench.check_reference(model, values, bench.N_BALLS)


def test_benchmark_rk4_paths_agree_with_the_compiled_one(bench):
    model = load_model(bench.MODEL)
    values = model.parameters(bench.CALM)
    ref = bench.Reference.from_parameters(values, bench.N_BALLS)
    z0 = np.array([1e-6, 1e-6, 0.0, 0.0])
    lib = compiled.library(model, bench.N_BALLS)
    want = compiled.run_rk4(lib, model.parameter_vector(values), z0, bench.DT, 300).T
    runs = [bench.numpy_rk4(ref, z0, bench.DT, 300)]
    if (kernel := bench.numba_rk4()) is not None:
        runs.append(kernel(ref, z0, bench.DT, 300))
    for got in runs:  # same formulas, different rounding: agreement to rounding
        assert np.all(np.abs(got - want) <= 1e-12 * np.abs(want).max(axis=0))


def test_bench_command_prints_the_table(cli):
    res = cli("bench", "--repeat", "1", "--duration", "0.002", "--memory-duration", "0.01")
    assert res.returncode == 0, res.stderr
    for text in ("| (a) bearingdyn RK4", "| (d) SciPy solve_ivp", "target (d)/(a) >= 300",
                 "target <= 1e-09 met", "peak memory of a 0.01 s run"):
        assert text in res.stdout
    bad = cli("bench", "--repeat", "0")
    assert bad.returncode == 2 and "--repeat" in bad.stderr


def test_bench_command_needs_nothing_outside_the_package(monkeypatch):
    """`bearingdyn bench` as from an installed package: it imports no module and opens no
    file of the source tree's benchmarks/ folder."""
    import builtins
    import importlib.util
    from pathlib import Path

    from typer.testing import CliRunner

    import analysis.cli

    outside = str(Path(analysis.cli.__file__).resolve().parents[2] / "benchmarks")
    touched: list[str] = []

    def guard(original):
        def checked(path, *args, **kwargs):
            if str(Path(str(path)).resolve()).startswith(outside):
                touched.append(str(path))
                raise OSError(f"read outside the package: {path}")
            return original(path, *args, **kwargs)
        return checked

    monkeypatch.setattr(builtins, "open", guard(builtins.open))
    monkeypatch.setattr(importlib.util, "spec_from_file_location",
                        guard(importlib.util.spec_from_file_location))
    monkeypatch.setattr("sys.path", [p for p in __import__("sys").path
                                     if not str(p).startswith(outside)])
    res = CliRunner().invoke(analysis.cli.app, ["bench", "--repeat", "1", "--duration", "0.002",
                                                "--memory-duration", "0"])
    assert res.exit_code == 0, res.output
    assert "| (a) bearingdyn RK4" in res.output and not touched
