"""What devices the member kernels can run on, and which one a run takes.

``device_info()`` lists the CPU (cores this process may use) and, when CuPy is installed and
a GPU visible, each GPU (name, memory, CuPy and CUDA versions). ``resolve_device`` turns the
user's ``cpu | gpu | auto`` into ``cpu`` or ``gpu`` (``InputError`` naming ``--device`` for
anything else, or for ``gpu`` without CuPy or a GPU). ``members.check_kernels`` builds (or
loads from the cache) the member kernels a run will call, before any of its work: a model
whose kernel cannot be written or built is one ``InputError`` naming the model and the
reason.
"""

from __future__ import annotations

import platform
from dataclasses import dataclass

from analysis.errors import InputError
from analysis.integrate.kernels.cpu import cores
from analysis.integrate.kernels.cuda import CudaUnavailable, cupy_module

DEVICES = ("cpu", "gpu", "auto")
"""The values of ``device=`` and ``--device``."""
AUTO_MIN_MEMBERS = 4096
"""``auto`` takes the GPU from this many members on (fewer leave most of a GPU's thousands
of threads idle; on the H200 of issue 33, 2¹⁴ members already ran at 4.9·10⁹ steps/s, 73× the
16-core CPU build) …"""
AUTO_MIN_STEPS = 2 * 10**8
"""… and when members × steps is at least this (about 10 s of a 2-core CPU build at
2·10⁷ steps/s, beyond the GPU's one-off NVRTC compilation and start-up, a few seconds)."""
INSTALL_HINT = ("install the GPU extra with pip install bearingdyn[gpu] (CUDA 12; "
                "bearingdyn[gpu-cuda13] for CUDA 13) on a machine with an NVIDIA GPU")
"""How to get a usable GPU, said once after what is missing (``gpu_problem``)."""


@dataclass(frozen=True)
class DeviceInfo:
    """One device: ``kind`` ``"cpu"`` or ``"gpu"``."""

    kind: str
    name: str
    cores: int | None = None
    """CPU cores this process may use (``BEARINGDYN_THREADS`` or the affinity mask)."""
    memory_bytes: int | None = None
    """GPU memory, total (bytes)."""
    free_bytes: int | None = None
    """GPU memory free now (bytes)."""
    cupy_version: str | None = None
    cuda_version: str | None = None
    """The CUDA runtime's version, ``major.minor``."""


def gpu_problem() -> str | None:
    """Why no GPU can be used (a sentence naming what is missing), or None when one can."""
    try:
        cupy_module()
    except CudaUnavailable as exc:
        return str(exc)
    return None


def device_info() -> list[DeviceInfo]:
    """The CPU and every visible GPU (none without CuPy or a GPU)."""
    out = [DeviceInfo("cpu", platform.processor() or platform.machine(), cores=cores())]
    try:
        cupy = cupy_module()
    except CudaUnavailable:
        return out
    runtime = cupy.cuda.runtime
    version = runtime.runtimeGetVersion()
    for index in range(runtime.getDeviceCount()):
        with cupy.cuda.Device(index):
            props = runtime.getDeviceProperties(index)
            free, total = runtime.memGetInfo()
        name = props["name"]
        out.append(DeviceInfo("gpu", name.decode() if isinstance(name, bytes) else str(name),
                              memory_bytes=int(total), free_bytes=int(free),
                              cupy_version=cupy.__version__,
                              cuda_version=f"{version // 1000}.{version % 1000 // 10}"))
    return out


def resolve_device(device: str, members: int, steps: int) -> str:
    """``"cpu"`` or ``"gpu"`` for a run of ``members`` members of ``steps`` RK4 steps each.

    ``device``: ``"cpu"``; ``"gpu"`` (``InputError`` naming what is missing and
    ``pip install bearingdyn[gpu]`` without CuPy or a visible GPU); ``"auto"``: the GPU when
    one can be used, ``members >= AUTO_MIN_MEMBERS`` and ``members · steps >=
    AUTO_MIN_STEPS``, else the CPU (the rule of issue 33's measurements: a GPU pays for
    wide ensembles, few long trajectories belong on the cores)."""
    if device not in DEVICES:
        raise InputError(f"--device: one of {', '.join(DEVICES)}, got {device!r}")
    if device == "cpu":
        return "cpu"
    problem = gpu_problem()
    if device == "gpu":
        if problem is not None:
            raise no_gpu_error(problem)
        return "gpu"
    wide = members >= AUTO_MIN_MEMBERS and members * steps >= AUTO_MIN_STEPS
    return "gpu" if problem is None and wide else "cpu"


def no_gpu_error(problem: str) -> InputError:
    """The one line of ``--device gpu`` where no GPU can be used (``problem``: why)."""
    return InputError(f"--device gpu: {problem}; {INSTALL_HINT}, or use --device cpu")
