"""What devices the member kernels can run on, and which one a run takes.

``device_info()`` lists the CPU (cores this process may use) and, when CuPy is installed and
a GPU visible, each GPU (name, memory, CuPy and CUDA versions); ``gpu_problem`` says why no GPU
can be used. Which device a run takes is judged once, by ``placement.place`` (the table of
devices, the ``auto`` rule, the kernels' builds; ``placement.resolve_device`` is its
name-only form).
A refused device is a ``DeviceError``: an ``InputError`` naming the parameter ``device``
(``field``), whose ``text("--device")`` is the same line naming a command's option.
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


class DeviceError(InputError):
    """An ``InputError`` about the parameter ``device``: ``value`` the device named (None
    when the name itself is refused), ``reason`` why, ``instead`` the device to use instead
    (or None). Its message names the parameter (``device gpu: …, or use device cpu``);
    ``text("--device")`` is the same line naming a command's option."""

    field = "device"
    """The parameter the error is about."""

    def __init__(self, value: str | None, reason: str, instead: str | None = None):
        self.value, self.reason, self.instead = value, reason, instead
        super().__init__(self.text(self.field))

    def text(self, name: str) -> str:
        """The message with the parameter called ``name`` (``device``, ``--device``)."""
        head = name if self.value is None else f"{name} {self.value}"
        tail = "" if self.instead is None else f", or use {name} {self.instead}"
        return f"{head}: {self.reason}{tail}"

    def __reduce__(self):  # pickled across worker processes: rebuilt from its parts
        return type(self), (self.value, self.reason, self.instead)

    def renamed(self, name: str) -> InputError:
        """The same line naming ``name`` (a command's option, ``--device``) throughout."""
        return InputError(self.text(name))


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
