"""The CUDA build of the member kernels (``analysis.integrate.kernels.cuda``) against the CPU
build: states to 1e-12 relative after a few thousand steps and λ1 on balanced-rotor and
vakharia2015 (skipped, with the reason, without CuPy or a visible GPU). Without a GPU the
CUDA text is still checked: it compiles as C++ with the CUDA keywords stubbed (g++), and,
where ``nvcc`` is installed, ptxas reports no register spills for the one-body shipped
models."""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

from analysis.integrate.kernels import Schedule, cuda_source, run_members
from analysis.integrate.kernels.cuda import NVRTC_OPTIONS
from analysis.integrate.kernels.devices import gpu_problem
from analysis.model import System, available_models
from tests.integrate.fake_cupy import STUB, FakeCupy, fake_gpu

CASES = {"balanced-rotor": dict(n_balls=8, speed_rpm=8000.0, radial_load=50.0),
         "vakharia2015": dict(n_balls=8, speed_rpm=5000.0, radial_load=50.0)}


def _system(name: str) -> System:
    return System.make(name, **CASES[name])


needs_gpu = pytest.mark.skipif(gpu_problem() is not None,
                               reason=f"CUDA build not testable here: {gpu_problem()}")


@needs_gpu
@pytest.mark.parametrize("name", list(CASES))
def test_cuda_states_and_lambda_match_the_cpu_build(name):
    system = _system(name)
    z0 = system.state * (1 + 0.05 * np.arange(64))[:, None]
    for tangent in (False, True):
        schedule = Schedule(500, 500, 8, tangent=tangent)
        cpu = run_members(system, z0, None, 1e-5, schedule, device="cpu")
        calls: list[int] = []
        gpu = run_members(system, z0, None, 1e-5, schedule, device="gpu",
                          progress=lambda done, total, seen=calls: seen.append(done))
        assert len(calls) > 3 and calls[-1] == 300  # streamed in blocks that fit
        assert gpu.device == "gpu" and np.array_equal(gpu.diverged_at, cpu.diverged_at)
        scale = np.abs(cpu.sections).max(axis=(0, 1))
        assert np.all(np.abs(gpu.sections - cpu.sections) <= 1e-12 * scale), name
        if tangent:
            np.testing.assert_allclose(gpu.lambda1, cpu.lambda1, rtol=1e-9, atol=1e-9)


@pytest.mark.skipif(shutil.which("g++") is None, reason="no g++ to check the CUDA text")
@pytest.mark.parametrize("tangent", [False, True])
def test_the_cuda_text_compiles_as_cpp_with_stubs(tmp_path, tangent):
    text = cuda_source(_system("vakharia2015"), tangent)
    assert "#ifdef __CUDACC__" in text and "BD_GLOBAL void bd_members_" in text
    source = tmp_path / "member.cpp"
    source.write_text(STUB + text.replace("#ifdef __CUDACC__", "#if 1", 1))
    done = subprocess.run(["g++", "-std=c++11", "-fsyntax-only", "-Wall", str(source)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]


SHIPPED = [(name, None) for name in available_models()] + [("vakharia2015", 12)]
"""Every shipped model with its own balls, and vakharia2015 with the chart's most (12)."""


@pytest.mark.skipif(shutil.which("nvcc") is None, reason="no nvcc: register check skipped")
@pytest.mark.parametrize(("name", "n_balls"), SHIPPED)
def test_ptxas_reports_no_spills_for_the_shipped_models(tmp_path, name, n_balls):
    """Both variants of every shipped model: ptxas (sm_90, the NVRTC options) spills no
    register (``benchmarks/ptxas_table.py`` prints the table)."""
    system = System.make(name, n_balls) if n_balls else System.make(name)
    for tangent in (False, True):
        source = tmp_path / f"member{int(tangent)}.cu"
        source.write_text(cuda_source(system, tangent=tangent))
        done = subprocess.run(["nvcc", "-arch=sm_90", "-cubin", "-Xptxas", "-v",
                               *(o for o in NVRTC_OPTIONS), "-x", "cu", "-o",
                               str(tmp_path / "member.cubin"), str(source)],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
        report = done.stdout + done.stderr
        spills = re.findall(r"(\d+) bytes spill stores, (\d+) bytes spill loads", report)
        assert spills and all(a == "0" and b == "0" for a, b in spills), (tangent, report)


@pytest.mark.parametrize("tangent", [False, True])
def test_the_gpu_path_with_a_cpu_twin_gives_the_cpu_results(monkeypatch, tangent):
    system = _system("vakharia2015")
    seen: list = []
    with fake_gpu(monkeypatch, FakeCupy(system, seen)):
        z0 = system.state * (1 + 0.05 * np.arange(300))[:, None]
        schedule = Schedule(100, 50, 6, tangent=tangent)
        cpu = run_members(system, z0, None, 1e-5, schedule, device="cpu")
        calls: list[int] = []
        gpu = run_members(system, z0, None, 1e-5, schedule, device="gpu",
                          progress=lambda done, total, seen=calls: seen.append(done))
        assert len(calls) > 3 and calls[-1] == 300  # streamed in blocks that fit
        assert gpu.device == "gpu" and seen and all(t == tangent for t in seen)
        assert np.array_equal(gpu.sections, cpu.sections)
        assert np.array_equal(gpu.final, cpu.final)
        if tangent:
            assert np.array_equal(gpu.lambda1, cpu.lambda1)


@pytest.mark.skipif(shutil.which("g++") is None, reason="no g++ to run the CUDA text")
@pytest.mark.parametrize(("name", "tangent"), [("balanced-rotor", True),
                                               ("two-bearing-rotor", False),
                                               ("two-bearing-rotor", True)])
def test_the_cuda_text_run_as_cpp_matches_the_cpu_build(monkeypatch, tmp_path, name, tangent):
    """The CUDA text itself (its loops not unrolled, the tangent's stages in a loop, and for
    two-bearing-rotor the steps stage by stage and the stage split in two) compiled as C++
    and run through the GPU path: states equal the CPU build's to 1e-12 relative after
    2000 steps of non-chaotic members, λ1 to 1e-9 (the two differ by rounding only; glibc's
    libm on both sides, so CUDA's libm is not checked here)."""
    system = System.make(name, speed_rpm=8000.0, radial_load=50.0) \
        if name == "balanced-rotor" else System.make(name)
    seen: list = []
    with fake_gpu(monkeypatch, FakeCupy(system, seen, tmp_path)):
        z0 = system.state * (1 + 0.02 * np.arange(4))[:, None]
        schedule = Schedule(400, 200, 8, tangent=tangent, lyapunov_skip=2 if tangent else 0)
        cpu = run_members(system, z0, None, 1e-5, schedule, device="cpu")
        gpu = run_members(system, z0, None, 1e-5, schedule, device="gpu")
        assert gpu.device == "gpu" and seen and all(t == tangent for t in seen)
        assert np.array_equal(gpu.diverged_at, cpu.diverged_at)
        scale = np.abs(cpu.sections).max(axis=(0, 1))
        assert np.all(np.abs(gpu.sections - cpu.sections) <= 1e-12 * scale), name
        if tangent:
            np.testing.assert_allclose(gpu.lambda1, cpu.lambda1, rtol=1e-9, atol=1e-9)
