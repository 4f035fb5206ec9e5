"""Where a run's members go, judged once: a ``Placement``, made by ``place``.

``place(device, members, systems, variant, steps)`` does, once per chart, sweep, basin or
attractor study, everything a device name asks: the name checked against ``TABLE`` (one
``Device`` row per device the member kernels are built for, plus the ``auto`` rule,
``auto_row``), the device's availability (a GPU and CuPy: the row's ``problem``), the
choice of ``auto`` (``AUTO_MIN_MEMBERS`` members and ``AUTO_MIN_STEPS`` member-steps), and
the kernels of ``systems`` built, or loaded from the cache and self-tested, on that device
(the ``state`` and/or ``tangent`` variant). It returns one frozen value that every
ensemble takes (``members.run_members``, ``ensemble``, ``sweeps.points``, the featurizing
mapper) instead of a name that each would judge again.

A refused device is a ``devices.DeviceError`` (an ``InputError`` naming the parameter
``device``). A ``Placement`` compares equal to, and hashes as, its row's name (``"cpu"``,
``"gpu"``), so tables keyed by that name (``GROUP_POINTS[placement]``) and callers that
still compare names take it as they took the name; code here asks ``placement.gpu``.

Adding a device is a row of ``TABLE`` (its name, whether it is a GPU, its availability
check, its install hint, its kernel builder and the errors of a failed build, both in
``builds``) and its name in ``devices.DEVICES`` (``tests/integrate/test_placement.py``
checks they agree). A row with ``gpu=False`` runs through the CPU build's call
(``kernel.run(count, threads, …)``), one with ``gpu=True`` through the CUDA build's
(``kernel.run(count, …)``, blocks sized by ``cuda.free_memory``): ``members.run_members``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from typing import Any

from analysis.errors import InputError
from analysis.integrate.kernels import devices
from analysis.integrate.kernels.builds import (
    cpu_errors,
    cpu_kernel,
    gpu_errors,
    gpu_kernel,
    unbuildable,
)
from analysis.integrate.kernels.devices import (
    AUTO_MIN_MEMBERS,
    AUTO_MIN_STEPS,
    DEVICES,
    INSTALL_HINT,
    DeviceError,
)
from analysis.model import System

VARIANTS = ("state", "tangent")
"""The member kernel's variants: the states alone, or with one tangent vector (λ1)."""


@dataclass(frozen=True)
class Device:
    """One row of ``TABLE``: a device the member kernels are built for."""

    name: str
    """The value of ``device=`` (and ``--device``) that names it."""
    gpu: bool
    """Whether it is a GPU: blocks bounded by its free memory, no CPU threads per call."""
    problem: Callable[[], str | None] = field(repr=False)
    """Why it cannot be used here and now (a sentence naming what is missing), None when it
    can."""
    hint: str = field(repr=False)
    """How to get it (said once after ``problem``); empty where nothing is to install."""
    kernel: Callable[[System, bool], Any] = field(repr=False)
    """``kernel(system, tangent)``: the member kernel of ``system``'s model and balls,
    built (or loaded from the cache) and self-tested: a ``cpu.CpuLibrary`` or a
    ``cuda.CudaKernel``."""
    build_errors: Callable[[], tuple[type[Exception], ...]] = field(repr=False)
    """The exceptions of a kernel that cannot be written or built on it."""


def _always() -> None:
    return None


def _gpu_problem() -> str | None:
    return devices.gpu_problem()  # looked up at each call (tests stand a GPU in)


TABLE: dict[str, Device] = {
    "cpu": Device("cpu", False, _always, "", cpu_kernel, cpu_errors),
    "gpu": Device("gpu", True, _gpu_problem, INSTALL_HINT, gpu_kernel, gpu_errors),
}
"""The devices the member kernels run on, by name (``devices.DEVICES`` lists these names
and ``auto``)."""


def auto_row(members: int, steps: int) -> Device:
    """The row ``auto`` takes for ``members`` members of ``steps`` RK4 steps each: the GPU
    when ``members >= AUTO_MIN_MEMBERS``, ``members · steps >= AUTO_MIN_STEPS`` and a GPU
    can be used, else the CPU (issue 33's measurements: a GPU pays for wide ensembles, few
    long trajectories belong on the cores)."""
    wide = members >= AUTO_MIN_MEMBERS and members * steps >= AUTO_MIN_STEPS
    gpu = TABLE["gpu"]
    return gpu if wide and gpu.problem() is None else TABLE["cpu"]


def judge(device: str, members: int, steps: int) -> Device:
    """The row of ``device`` (a name of ``devices.DEVICES``) for ``members`` members of
    ``steps`` RK4 steps each: checked against ``TABLE``, its availability checked
    (``DeviceError`` naming what is missing and how to install it), ``auto`` by
    ``auto_row``. ``place`` calls it once per run."""
    if device == "auto":
        return auto_row(members, steps)
    row = TABLE.get(device) if isinstance(device, str) else None
    if row is None:
        raise DeviceError(None, f"one of {', '.join(DEVICES)}, got {device!r}")
    problem = row.problem()
    if problem is not None:
        hint = f"; {row.hint}" if row.hint else ""
        raise DeviceError(row.name, f"{problem}{hint}", instead="cpu")
    return row


def resolve_device(device: str, members: int, steps: int) -> str:
    """``"cpu"`` or ``"gpu"`` for a run of ``members`` members of ``steps`` RK4 steps each:
    the name of the row ``judge`` takes (``DeviceError`` for another name, or for ``gpu``
    without CuPy or a visible GPU). A run judges its device once with ``place``; this is
    its name-only form."""
    return judge(device, members, steps).name


@dataclass(frozen=True, eq=False)
class Placement:
    """Where a run's members go: made once by ``place``, taken by every ensemble."""

    row: Device
    """The device (a row of ``TABLE``)."""
    asked: str
    """The name given: ``cpu``, ``gpu`` or ``auto``."""
    members: int
    """Members the choice was made for (``auto``'s rule)."""
    steps: int
    """RK4 steps per member the choice was made for."""
    variants: tuple[str, ...] = ()
    """The kernel variants (``VARIANTS``) built and self-tested for the run's systems."""
    threads: int | None = None
    """CPU threads of a call on the CPU (None: ``cpu.cores()``, every core)."""

    @property
    def kind(self) -> str:
        """The device's name, ``"cpu"`` or ``"gpu"``."""
        return self.row.name

    @property
    def gpu(self) -> bool:
        """Whether the members run on a GPU."""
        return self.row.gpu

    def on_cpu(self) -> Placement:
        """The same run on the CPU (no kernel built there yet)."""
        return replace(self, row=TABLE["cpu"], variants=())

    def __str__(self) -> str:
        return self.kind

    def __eq__(self, other: object) -> bool:
        if isinstance(other, str):
            return self.kind == other
        if isinstance(other, Placement):
            return (self.row, self.asked, self.members, self.steps, self.variants,
                    self.threads) == (other.row, other.asked, other.members, other.steps,
                                      other.variants, other.threads)
        return NotImplemented

    def __hash__(self) -> int:
        return hash(self.kind)


CPU = Placement(TABLE["cpu"], "cpu", 1, 1)
"""The cores, for a run that names no device (the default of ``StroboscopicMap``): they are
always there, so nothing is judged."""


def on_gpu(device: str | Placement) -> bool:
    """Whether ``device`` (a ``Placement``, or a resolved name) is a GPU."""
    return device.gpu if isinstance(device, Placement) else device == "gpu"


def _variants(variant: str | Iterable[str]) -> tuple[str, ...]:
    out = (variant,) if isinstance(variant, str) else tuple(variant)
    for v in out:
        if v not in VARIANTS:
            raise InputError(f"variant: one of {', '.join(VARIANTS)}, got {v!r}")
    return out


def _systems(systems: System | Iterable[System] | Callable[[], Iterable[System]] | None
             ) -> list[System]:
    if systems is None:
        return []
    if isinstance(systems, System):
        return [systems]
    return list(systems() if callable(systems) else systems)


def build(row: Device, systems: Iterable[System], variants: Iterable[str]) -> None:
    """Build, or load from the cache, and self-test the member kernel of every ``variants``
    of each model and balls among ``systems`` on ``row``'s device, before a run's work (what
    the run then calls is loaded at once). ``DeviceError``, one line naming the device, the
    model and its balls and the reason, when a kernel cannot be written
    (``source.Unsupported``) or built or loaded (``compiled.CompileError``: no compiler, a
    failed compilation, a self-test; NVRTC's ``CompileException`` on a GPU)."""
    errors = row.build_errors()
    seen = set()
    for system in systems:
        key = (id(system.model), system.structure)
        if key in seen:
            continue
        seen.add(key)
        for variant in variants:
            try:
                row.kernel(system, variant == "tangent")
            except errors as exc:
                raise unbuildable(system, row.name, exc) from None


def place(device: str | Placement, members: int,
          systems: System | Iterable[System] | Callable[[], Iterable[System]] | None = None,
          variant: str | Iterable[str] = (), steps: int = 1, *, fallback: bool = False,
          threads: int | None = None) -> Placement:
    """The ``Placement`` of a run of ``members`` members of ``steps`` RK4 steps each on
    ``device`` (``cpu``, ``gpu`` or ``auto``: ``judge``, the one judgement of the name, the
    availability and the ``auto`` rule), with the kernels of ``systems`` (a ``System``, an
    iterable, or a callable giving them, called only when kernels are built; None: none)
    in ``variant`` (``state``, ``tangent`` or both) built and self-tested (``build``).

    ``device`` may be a ``Placement`` already: it is kept as it is (not judged again), and
    only the variants it has not built yet are built. ``fallback`` (a chart, whose points
    run one by one where the cores have no build): ``auto`` is never refused, a GPU that
    cannot build the kernels leaves the run to the cores, whose builds are not judged here.
    ``threads``: CPU threads of a call (None: every core). Errors: ``DeviceError`` (an
    ``InputError`` naming ``device``); ``InputError`` for an unknown variant."""
    variants = _variants(variant)
    if isinstance(device, Placement):
        missing = tuple(v for v in variants if v not in device.variants)
        if not missing or (fallback and device.asked == "auto" and not device.gpu):
            return device  # (auto on the cores with fallback: their builds not judged)
        found = _systems(systems)
        if not found:
            return device
        build(device.row, found, missing)
        return replace(device, variants=device.variants + missing)
    placed = Placement(judge(device, members, steps), device, members, steps, (), threads)
    if not variants or systems is None or (fallback and device == "auto" and not placed.gpu):
        return placed
    try:
        build(placed.row, _systems(systems), variants)
    except InputError:
        if fallback and device == "auto":  # the GPU could not build them: the cores
            return placed.on_cpu()
        raise
    return replace(placed, variants=variants)


__all__ = ["CPU", "TABLE", "VARIANTS", "Device", "DeviceError", "Placement", "auto_row", "build",
           "judge", "on_gpu", "place", "resolve_device"]
