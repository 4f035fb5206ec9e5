"""A stand-in for CuPy that runs the member kernels' GPU path on the CPU (shared by the
tests of ``analysis.integrate.kernels`` and of the ensemble API).

``FakeCupy`` offers the surface of CuPy that ``kernels.cuda`` uses, on NumPy; its
``RawModule`` runs the CPU build of the same model, or with ``twin_dir`` the CUDA text itself
compiled as C++ (``cuda_twin``: the CUDA keywords stubbed by ``STUB``). ``fake_gpu`` makes it
the visible GPU for the length of a ``with`` block (the kernel and self-test caches
cleared on entry and exit).
"""

from __future__ import annotations

import ctypes
import hashlib
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from analysis.integrate.kernels.cuda import NVRTC_OPTIONS
from analysis.model import System

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


class FakeCupy:
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
                    return cuda_twin(self.code, name, twin_dir)
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
    # the reductions of ``members.section_features`` on the device
    minimum, maximum = staticmethod(np.minimum), staticmethod(np.maximum)
    concatenate = staticmethod(np.concatenate)


def cuda_twin(code: str, name: str, folder: Path):
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


@contextmanager
def fake_gpu(monkeypatch: pytest.MonkeyPatch, fake: FakeCupy) -> Iterator[FakeCupy]:
    """``fake`` as the CuPy of ``kernels.cuda`` and ``kernels.devices`` (a GPU is then
    visible: ``devices.gpu_problem()`` is None) inside the block."""
    from analysis.integrate.kernels import cuda, members

    monkeypatch.setattr(cuda, "cupy_module", lambda: fake)
    monkeypatch.setattr("analysis.integrate.kernels.devices.cupy_module", lambda: fake)
    cuda.cuda_kernel.cache_clear()
    members._self_test_gpu.cache_clear()
    try:
        yield fake
    finally:
        cuda.cuda_kernel.cache_clear()
        members._self_test_gpu.cache_clear()
