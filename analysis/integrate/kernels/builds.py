"""The member kernels' builders, one per device of ``placement.TABLE``: ``cpu_kernel`` (the
C/OpenMP build, ``cpu``) and ``gpu_kernel`` (the CUDA build, ``cuda``), each built (or loaded
from the cache) and self-tested once per process (``self_test``: the CPU build against
CasADi; ``self_test_gpu``: the CUDA build against the CPU build), the errors of a build that
fails (``cpu_errors``, ``gpu_errors``) and the one line that says so (``unbuildable``).
"""

from __future__ import annotations

from functools import cache

import numpy as np

from analysis.integrate.compiled import test_state
from analysis.integrate.kernels.cpu import cpu_library
from analysis.integrate.kernels.devices import DeviceError
from analysis.integrate.kernels.schedule import Schedule
from analysis.model import System

SELF_TEST_TOL = 1e-12
"""Relative agreement of the tangent variant with its stage RK4 in CasADi (self-test)."""
GPU_SELF_TEST_TOL = 1e-10
"""Relative agreement of the CUDA build with the CPU build over the self-test's steps (CUDA's
libm differs from glibc's in the last bits)."""


def cpu_kernel(system: System, tangent: bool):
    """The CPU build of ``system``'s member kernel (``cpu.CpuLibrary``), self-tested (the
    kernel builder of ``placement.TABLE["cpu"]``)."""
    self_test(system.model, system.structure, tangent)
    return cpu_library(system.model, system.structure, tangent)


def gpu_kernel(system: System, tangent: bool):
    """The CUDA build of ``system``'s member kernel (``cuda.CudaKernel``), self-tested
    against the CPU build (the kernel builder of ``placement.TABLE["gpu"]``)."""
    from analysis.integrate.kernels.cuda import cuda_kernel

    self_test_gpu(system.model, system.structure, tangent)
    return cuda_kernel(system.model, system.structure, tangent)


def cpu_errors() -> tuple[type[Exception], ...]:
    """The exceptions of a member kernel that cannot be written (``source.Unsupported``) or
    built, loaded or self-tested (``compiled.CompileError``) on the CPU."""
    from analysis.integrate.compiled import CompileError
    from analysis.integrate.kernels.source import Unsupported

    return (Unsupported, CompileError)


def gpu_errors() -> tuple[type[Exception], ...]:
    """``cpu_errors`` and NVRTC's refusal (CuPy's ``CompileException``) on a GPU."""
    try:
        from cupy.cuda.compiler import CompileException
    except ImportError:  # no CuPy, or its stand-in (tests/integrate/fake_cupy.py)
        return cpu_errors()
    return (*cpu_errors(), CompileException)


def reference_stage(model, structure: tuple[int, ...]):
    """``(t, z, p, v) -> (f, Jv)`` straight from the model's rhs (sin and cos at every
    stage's own time): the self-test's reference for the tangent variant's stages."""
    import casadi as ca

    rhs = model.functions(structure).rhs
    n, n_par = rhs.size1_in(1), rhs.size1_in(2)
    t, z, p, v = ca.SX.sym("t"), ca.SX.sym("z", n), ca.SX.sym("p", n_par), ca.SX.sym("v", n)
    f = rhs(t, z, p)
    return ca.Function("reference_stage", [t, z, p, v], [f, ca.jtimes(f, z, v)])


@cache
def self_test(model, structure: tuple[int, ...], tangent: bool) -> None:
    """Check the CPU build against CasADi on a few steps of two members (different states,
    counters, parameters, steps and start times): the state variant bit for bit against
    the step it is written from, the tangent variant to ``SELF_TEST_TOL`` against the
    stage RK4 of the model's rhs and ``jtimes`` evaluated by CasADi. ``CompileError`` when
    it disagrees. Once per process."""
    from analysis.integrate.compiled import CompileError
    from analysis.integrate.kernels.source import state_functions

    step, constants = state_functions(model, structure)
    n = model.n_state
    z0, k0s, p, hs, t0s, _ = self_test_inputs(model, n)
    sched = Schedule(1, 2, 2).per_member(2)
    outs = [np.empty((2, 2, n)), np.empty((2, 2)), np.empty((2, n)),
            np.empty(2, dtype=np.int64), np.empty((2, n)), np.empty((2, n))]
    lib = cpu_library(model, structure, tangent)
    lib.run(2, 1, [z0, k0s, p, hs, t0s, np.full(2, np.inf), *sched], 2, True, outs)
    stage = reference_stage(model, structure) if tangent else None
    for j in range(2):
        c = constants(p[j], hs[j], t0s[j])
        s = np.append(z0[j], k0s[j])
        s = np.asarray(step(s, p[j], hs[j], t0s[j], c)).ravel()  # the transient step
        want, logs = [], []
        if not tangent:
            for _ in range(4):
                s = np.asarray(step(s, p[j], hs[j], t0s[j], c)).ravel()
                want.append(s[:n])
            ok = np.array_equal(np.array(want[1::2]), outs[0][j])
        else:
            fn = stage
            z, k, v = s[:n], s[n], np.eye(n)[0]
            h, half = hs[j], hs[j] / 2
            for i in range(4):
                t = t0s[j] + k * h
                a = [np.asarray(x).ravel() for x in fn(t, z, p[j], v)]
                b = [np.asarray(x).ravel() for x in fn(t + half, z + half * a[0], p[j],
                                                       v + half * a[1])]
                c3 = [np.asarray(x).ravel() for x in fn(t + half, z + half * b[0], p[j],
                                                        v + half * b[1])]
                e = [np.asarray(x).ravel() for x in fn(t + h, z + h * c3[0], p[j],
                                                       v + h * c3[1])]
                z = z + h / 6 * (a[0] + 2 * b[0] + 2 * c3[0] + e[0])
                v = v + h / 6 * (a[1] + 2 * b[1] + 2 * c3[1] + e[1])
                k += 1
                if i % 2 == 1:
                    norm = np.linalg.norm(v)
                    logs.append(np.log(norm))
                    v = v / norm
                    want.append(z)
            scale = np.abs(np.array(want)).max(axis=0) + 1e-300
            ok = np.all(np.abs(np.array(want) - outs[0][j]) <= SELF_TEST_TOL * scale) \
                and np.allclose(logs, outs[1][j], rtol=SELF_TEST_TOL, atol=1e-14)
        if not ok:
            raise CompileError(f"the member kernel of {model.name} does not reproduce "
                               "CasADi (check BEARINGDYN_CFLAGS: no fast-math)")
    if lib.lanes and not lanes_agree(model, structure, tangent, lib.lanes):
        raise CompileError(f"the member kernel of {model.name} in lanes of {lib.lanes} "
                           "does not reproduce it member by member")


def lanes_agree(model, structure: tuple[int, ...], tangent: bool, lanes: int) -> bool:
    """Whether the blocks of ``lanes`` members of the variant (``cpu.cpu_library``
    symbol ``_lanes``) give what its members one by one give (``_single``), bit for bit:
    every output of three members (a spare lane) whose schedules differ, one of them
    blowing up."""
    n = model.n_state
    z0, k0s, p, hs, t0s, _ = self_test_inputs(model, n)
    z0, k0s, p, hs, t0s = (np.concatenate([a, a[:1]]) for a in (z0, k0s, p, hs, t0s))
    limit = np.array([np.inf, np.inf, 0.0])  # the third member blows up at its first step
    sched = [np.array([1, 2, 0]), np.array([2, 1, 3]), np.array([2, 3, 2]),
             np.zeros(3, dtype=np.int64), np.array([0, 2, 0]), np.array([5, 4, 9])]
    inputs = [np.ascontiguousarray(a) for a in (z0, k0s, p, hs, t0s, limit)] + \
        [np.ascontiguousarray(a, dtype=np.int64) for a in sched]
    results = []
    for symbol in ("_lanes", "_single"):  # NaN where a path writes nothing (logs of states)
        outs = [np.full((3, 3, n), np.nan), np.full((3, 3), np.nan), np.full((3, n), np.nan),
                np.full(3, -7), np.full((3, n), np.nan), np.full((3, n), np.nan)]
        cpu_library(model, structure, tangent, lanes, symbol).run(3, 1, inputs, 3, True,
                                                                   outs)
        results.append(outs)
    return all(np.array_equal(a, b, equal_nan=True) for a, b in zip(*results, strict=True))


def self_test_inputs(model, n: int) -> list[np.ndarray]:
    """The self-test's two members: z0, k0, p, h, t0, limit."""
    p0 = model.parameter_vector(model.defaults)
    h0 = float(model.simulation_defaults["dt"])
    return [np.stack([test_state(n) * (1 + 0.1 * j) for j in range(2)]),
            np.array([3.0, 4.0]), np.stack([p0 * (1 + 0.01 * j) for j in range(2)]),
            h0 * np.array([1.0, 1.05]), np.array([0.0, 0.1]), np.full(2, np.inf)]


@cache
def self_test_gpu(model, structure: tuple[int, ...], tangent: bool) -> None:
    """The CUDA build against the CPU build (itself checked against CasADi) on the
    self-test's members over 20 steps: sections and logs to ``GPU_SELF_TEST_TOL``.
    ``CompileError`` when they disagree. Once per process."""
    from analysis.integrate.compiled import CompileError
    from analysis.integrate.kernels.cuda import cuda_kernel

    self_test(model, structure, tangent)
    n = model.n_state
    inputs = [np.ascontiguousarray(a) for a in self_test_inputs(model, n)]
    inputs += Schedule(2, 6, 3).per_member(2)
    results = []
    for device in ("cpu", "gpu"):
        outs = [np.empty((2, 3, n)), np.empty((2, 3)), np.empty((2, n)),
                np.empty(2, dtype=np.int64), np.empty((2, n)), np.empty((2, n))]
        if device == "cpu":
            cpu_library(model, structure, tangent).run(2, 1, inputs, 3, True, outs)
        else:
            cuda_kernel(model, structure, tangent).run(2, inputs, 3, True, outs)
        results.append(outs)
    (cpu, gpu) = results
    scale = np.abs(cpu[0]).max(axis=(0, 1)) + 1e-300
    ok = np.all(np.abs(gpu[0] - cpu[0]) <= GPU_SELF_TEST_TOL * scale) \
        and np.array_equal(gpu[3], cpu[3])
    if tangent:
        ok = ok and np.allclose(gpu[1], cpu[1], rtol=GPU_SELF_TEST_TOL, atol=1e-12)
    if not ok:
        raise CompileError(f"the CUDA member kernel of {model.name} does not reproduce the "
                           "CPU build (NVRTC options: see kernels/cuda.py)")


def unbuildable(system: System, device: str, exc: Exception) -> DeviceError:
    """The one line of a member kernel of ``system`` that cannot be written or built on
    ``device`` (``exc``: why; a compiler's lines joined by ``;``)."""
    reason = "; ".join(line.strip() for line in str(exc).splitlines() if line.strip())
    balls = ", ".join(str(n) for n in system.structure)
    return DeviceError(str(device), f"the member kernel of model '{system.model.name}' with "
                                    f"N_b {balls} cannot be built: {reason}")
