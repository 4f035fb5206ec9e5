"""Member kernels: one C text of a model's members, built for every CPU core and the GPU.

``run_members(system, states, parameters, h, schedule, device=…)`` runs M members (each its
own initial state, parameters, step and start) by one ``Schedule`` (transient, sections,
optional tangent for λ1) and returns a ``MemberResult``. ``source`` writes the C from the
CasADi SX Functions (the one writer of compiled member code), ``cpu`` builds it with gcc
and OpenMP, ``cuda`` with NVRTC through CuPy (imported lazily, only there), ``devices``
says what is visible, and ``placement`` judges once which device a run takes (``place``:
the table of devices, the ``auto`` rule, the kernels' builds) as a ``Placement`` that
every ensemble takes.
"""

from analysis.integrate.kernels.cuda import cuda_source
from analysis.integrate.kernels.devices import DeviceError, DeviceInfo, device_info
from analysis.integrate.kernels.members import (
    MemberResult,
    Schedule,
    blow_up_error,
    check_fits,
    run_members,
    section_step,
)
from analysis.integrate.kernels.placement import Placement, place, resolve_device
from analysis.integrate.kernels.source import Unsupported

__all__ = ["DeviceError", "DeviceInfo", "MemberResult", "Placement", "Schedule", "Unsupported",
           "blow_up_error", "check_fits", "cuda_source", "device_info", "place",
           "resolve_device", "run_members", "section_step"]
