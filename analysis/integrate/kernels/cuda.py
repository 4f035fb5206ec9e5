"""The CUDA build of the member C: the same text through CuPy's ``RawModule`` (NVRTC).

``cupy`` is imported here only, lazily (``pip install bearingdyn[gpu]``; the extra names
``cupy-cuda12x``, CuPy's wheel for CUDA 12). The text is ``source.model_source(…,
target="cuda")``: the member function of the CPU build and a ``__global__`` wrapper, one
member per thread, the whole time loop inside the kernel, only the sections (or none, or
their reduction on the device: ``CudaKernel.run``'s ``reduce``), the logs, the final
state, the blow-up step and the extremes copied back.

NVRTC options (``NVRTC_OPTIONS``): ``-std=c++11``; ``--fmad=false`` so that a·b + c stays
two roundings as in the CPU build (``-ffp-contract=off``): the two builds then differ only
by the last bits of CUDA's libm (sin, cos, pow, sqrt are correctly rounded or within 1–2
ulp), and states agree to about 1e-12 relative after thousands of steps of a non-chaotic
member (``tests/integrate/test_kernels_gpu.py``).

``cuda_source(system, tangent)`` returns the text, for ``nvcc -Xptxas -v`` (registers and
spills; no GPU needed): ``nvcc -arch=sm_90 -cubin -Xptxas -v --fmad=false -std=c++11 -x cu
member.cu``; ``benchmarks/ptxas_table.py`` prints the table of every shipped model.
Measured with nvcc 13.0 for sm_90 (registers per thread, states | tangent), no spills for
any shipped model and variant (``tests/integrate/test_kernels_gpu.py``): balanced-rotor N_b 8
184 | 180, vakharia2015 N_b 6 160 | 160, N_b 12 210 | 202, rotor-housing 220 | 206,
two-bearing-rotor 200 | 214, the 6205 defect models 166-168 | 216-220, nu205-roller 248 |
228, vakharia2015-two-contact 208 | 210. Before the CUDA text's loops were rolled
(``source.member_source``), the eight-state models spilled up to 1864/2392 B
(two-bearing-rotor's tangent) and vakharia2015-two-contact's tangent 7280/10624 B.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np

NVRTC_OPTIONS = ("-std=c++11", "--fmad=false")
"""Options of the NVRTC compilation (see the module)."""
THREADS_PER_BLOCK = 128
"""CUDA threads per block of the member kernel (one member each)."""


class CudaUnavailable(RuntimeError):
    """CuPy is not installed, or no GPU is visible; the message says which (how to install
    the extra is added once by whoever reports it: ``devices.INSTALL_HINT``)."""


def cupy_module() -> Any:
    """The ``cupy`` module with a visible GPU, or ``CudaUnavailable`` saying what is
    missing."""
    try:
        import cupy
    except ImportError:
        raise CudaUnavailable("cupy is not installed") from None
    try:
        count = cupy.cuda.runtime.getDeviceCount()
    except Exception as exc:  # no driver, no device: CuPy raises its own runtime errors
        raise CudaUnavailable(f"no GPU visible to CuPy ({exc})") from None
    if count < 1:
        raise CudaUnavailable("no GPU visible to CuPy")
    return cupy


def cuda_source(system: Any, tangent: bool = False) -> str:
    """The CUDA text of ``system``'s model and balls (a ``System``): the state variant, or
    the tangent variant with ``tangent``. Compiles with ``nvcc -x cu`` or NVRTC."""
    from analysis.integrate.kernels.source import model_source

    return model_source(system.model, system.structure, tangent, "cuda")


def free_memory() -> tuple[int, int]:
    """(free, total) bytes of the current GPU."""
    cupy = cupy_module()
    return cupy.cuda.runtime.memGetInfo()


@dataclass
class CudaKernel:
    """A compiled member kernel: ``fn`` is the ``RawKernel`` ``bd_members_<variant>``."""

    fn: Any

    def run(self, count: int, inputs: list[np.ndarray], kmax: int, keep: bool,
            outputs: list[np.ndarray], reduce: Callable[[Any, Any], Any] | None = None) -> None:
        """One launch over ``count`` members (the arrays of ``cpu.CpuLibrary.run``, host
        NumPy: inputs copied to the GPU, outputs copied back into them). ``reduce(cupy,
        sections)`` (``members.section_features``): the sections (count, kmax, n) stay on
        the device and only ``reduce``'s array of them is copied back, into ``outputs[0]``
        (its shape, e.g. (count, 2n)); the device's sections are freed with the launch."""
        cupy = cupy_module()
        dev_in = [cupy.asarray(a) for a in inputs]
        shapes = [a.shape for a in outputs]
        if reduce is not None:
            shapes[0] = (count, kmax, outputs[2].shape[1])  # outputs[2]: final, (count, n)
        dev_out = [cupy.empty(shape, dtype=a.dtype) for shape, a in zip(shapes, outputs,
                                                                         strict=True)]
        grid = ((count + THREADS_PER_BLOCK - 1) // THREADS_PER_BLOCK,)
        self.fn(grid, (THREADS_PER_BLOCK,),
                (np.int64(count), *dev_in, np.int64(kmax), np.int32(int(keep)), *dev_out))
        if reduce is not None:
            dev_out[0] = reduce(cupy, dev_out[0])
        for host, dev in zip(outputs, dev_out, strict=True):
            host[...] = cupy.asnumpy(dev)


@cache
def cuda_kernel(model: Any, structure: tuple[int, ...], tangent: bool) -> CudaKernel:
    """The CUDA build of ``model``'s member C with these balls (NVRTC through
    ``cupy.RawModule``), memoised per process; ``CudaUnavailable`` without CuPy or a GPU,
    CuPy's compile error when NVRTC refuses the text."""
    from analysis.integrate.kernels.source import model_source

    cupy = cupy_module()
    variant = "tangent" if tangent else "states"
    module = cupy.RawModule(code=model_source(model, structure, tangent, "cuda"),
                            options=NVRTC_OPTIONS)
    return CudaKernel(module.get_function(f"bd_members_{variant}"))
