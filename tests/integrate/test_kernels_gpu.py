"""The CUDA build of the member kernels (``analysis.integrate.kernels.cuda``) against the CPU
build: states to 1e-12 relative after a few thousand steps and λ1 on balanced-rotor and
vakharia2015 (skipped, with the reason, without CuPy or a visible GPU). Without a GPU the
CUDA text is still checked: it compiles as C++ with the CUDA keywords stubbed (g++), and,
where ``nvcc`` is installed, ptxas reports no register spills for the one-body shipped
models."""

from __future__ import annotations

import ctypes
import hashlib
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from analysis.integrate.kernels import Schedule, cuda_source, run_members
from analysis.integrate.kernels.cuda import NVRTC_OPTIONS
from analysis.integrate.kernels.devices import gpu_problem
from analysis.model import System, available_models

CASES = {"balanced-rotor": dict(n_balls=8, speed_rpm=8000.0, radial_load=50.0),
         "vakharia2015": dict(n_balls=8, speed_rpm=5000.0, radial_load=50.0)}
STUB = """\
#include <cmath>
#define __device__
#define __forceinline__ inline
#define __noinline__ __attribute__((noinline))
#define __global__
#define __restrict__
struct bd_dim { unsigned x; };
static bd_dim blockIdx, blockDim, threadIdx;
static inline double __longlong_as_double(unsigned long long v) {
  double d; __builtin_memcpy(&d, &v, 8); return d; }
"""


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


class _FakeCupy:
    """CuPy's surface that ``kernels.cuda`` uses, on NumPy, whose ``RawModule`` runs the
    CPU build of the same model: the GPU path's marshalling, blocks and device choice,
    tested by its CPU twin."""

    __version__ = "fake"

    def __init__(self, system: System, tangent_seen: list, twin_dir: Path | None = None):
        from analysis.integrate.kernels.cpu import cpu_library

        class Runtime:
            @staticmethod
            def getDeviceCount():
                return 1

            @staticmethod
            def memGetInfo():
                return (1 << 16, 1 << 30)  # 64 KiB free: blocks of ~50 members

        class Cuda:
            runtime = Runtime

        class RawModule:
            def __init__(self, code: str, options: tuple):
                assert options == NVRTC_OPTIONS and "BD_GLOBAL" in code
                self.tangent, self.code = "bd_members_tangent" in code, code

            def get_function(self, name: str):
                tangent_seen.append(self.tangent)
                if twin_dir is not None:  # the CUDA text itself, as C++ on the CPU
                    return _cuda_twin(self.code, name, twin_dir)
                lib = cpu_library(system.model, system.structure, self.tangent)

                def launch(grid, block, args):
                    count, rest = int(args[0]), list(args[1:])
                    assert grid[0] * block[0] >= count
                    lib.run(count, 1, rest[:12], int(rest[12]), bool(rest[13]), rest[14:])
                return launch

        self.cuda, self.RawModule = Cuda, RawModule

    asarray = staticmethod(lambda a: np.ascontiguousarray(np.array(a)))
    empty = staticmethod(lambda shape, dtype: np.empty(shape, dtype=dtype))
    asnumpy = staticmethod(lambda a: np.asarray(a))


@pytest.mark.parametrize("tangent", [False, True])
def test_the_gpu_path_with_a_cpu_twin_gives_the_cpu_results(monkeypatch, tangent):
    from analysis.integrate.kernels import cuda, members

    system = _system("vakharia2015")
    seen: list = []
    monkeypatch.setattr(cuda, "cupy_module", lambda: _FakeCupy(system, seen))
    monkeypatch.setattr("analysis.integrate.kernels.devices.cupy_module",
                        lambda: _FakeCupy(system, seen))
    cuda.cuda_kernel.cache_clear()
    members._self_test_gpu.cache_clear()
    try:
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
    finally:
        cuda.cuda_kernel.cache_clear()
        members._self_test_gpu.cache_clear()


def _cuda_twin(code: str, name: str, folder: Path):
    """The CUDA text ``code`` compiled as C++ (g++, the CUDA keywords stubbed, no
    contraction as ``--fmad=false``) and its kernel ``name`` as a launch function: each
    member one call with ``blockIdx.x`` set to it, as one thread of the GPU runs it."""
    digest = hashlib.sha256(code.encode()).hexdigest()[:16]
    library = folder / f"twin-{digest}.so"
    if not library.exists():
        source = folder / f"twin-{digest}.cpp"
        source.write_text("#define __CUDACC__ 1\n" + STUB + code
                          + "\nextern \"C\" void bd_twin_at(unsigned m) { blockIdx.x = m; "
                            "blockDim.x = 1; threadIdx.x = 0; }\n")
        done = subprocess.run(["g++", "-std=c++11", "-O2", "-ffp-contract=off", "-fPIC",
                               "-shared", "-w", "-o", str(library), str(source)],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
    lib = ctypes.CDLL(str(library))
    kernel, at = getattr(lib, name), lib.bd_twin_at
    kernel.restype = at.restype = None

    def launch(grid, block, args):
        count, rest = int(args[0]), list(args[1:])
        assert grid[0] * block[0] >= count
        ptrs = [a.ctypes.data_as(ctypes.c_void_p) for a in rest[:12]]
        outs = [a.ctypes.data_as(ctypes.c_void_p) for a in rest[14:]]
        for m in range(count):
            at(ctypes.c_uint(m))
            kernel(ctypes.c_longlong(count), *ptrs, ctypes.c_longlong(int(rest[12])),
                   ctypes.c_int(int(rest[13])), *outs)
    return launch


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
    from analysis.integrate.kernels import cuda, members

    system = System.make(name, speed_rpm=8000.0, radial_load=50.0) \
        if name == "balanced-rotor" else System.make(name)
    seen: list = []
    fake = _FakeCupy(system, seen, tmp_path)
    monkeypatch.setattr(cuda, "cupy_module", lambda: fake)
    monkeypatch.setattr("analysis.integrate.kernels.devices.cupy_module", lambda: fake)
    cuda.cuda_kernel.cache_clear()
    members._self_test_gpu.cache_clear()
    try:
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
    finally:
        cuda.cuda_kernel.cache_clear()
        members._self_test_gpu.cache_clear()
