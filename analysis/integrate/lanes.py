"""Several runs in lockstep: the RK4 tangent steps of a chart compiled for vector lanes.

A stability chart integrates the states and one tangent vector of many grid points of the
same model and balls; each point is the same sequence of operations on other numbers. This
module writes those operations once for ``LANES`` points side by side, as C with GCC's
vector extensions (``double`` vectors of ``LANES`` lanes: SSE2 on every x86-64, NEON on
ARM64, no ``-march`` needed), so one instruction advances every lane. The operations are
those of ``tangent.lyapunov_step`` and of its renormalisation (``tangent.qr_logs``),
read instruction by instruction from the CasADi SX Functions, in the same order: each lane
performs the IEEE operations the scalar compiled block performs, with the same libm for
sin, cos and the like (called lane by lane), so every lane's states, tangent and logs are
those of ``tangent.tangent_block`` bit for bit, whichever points share its call
(``tests/test_lanes.py``).

``kernel(model, structure, renorm_every)`` builds, compiles (the cache and compiler of
``analysis.integrate.compiled``) and loads the kernel, or returns None when it cannot: an
operation the writer does not know (listed in ``UNARY``/``BINARY``), no working compiler, or
a library that does not reproduce the CasADi block on a test state. Callers then use the
scalar blocks.

``state_kernel(model, structure)`` is the same for the state alone: the RK4 step of the
compiled blocks (``compiled.rk4_blocks``: ``tangent.tangent_step`` with
``Carry(constants=True)``) on ``LANES`` runs of their own parameters, step and start time,
in a C loop that keeps the state after every ``every`` steps (the stroboscopic maps and
ensembles of ``analysis.integrate.ensemble``): each lane is ``simulate``'s run bit for bit.
"""

from __future__ import annotations

import ctypes
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from analysis.integrate.compiled import (
    CompileError,
    cached_path,
    compile_library,
    compiler_command,
    library_stem,
    test_state,
)
from analysis.integrate.tangent import Carry, lyapunov_step, qr_logs, tangent_block, tangent_step

LANES = 2
"""Points per vector: two doubles fill the 128-bit registers every x86-64 and ARM64 CPU
has. Four (256-bit) would need ``-mavx``, which a cache shared by several CPUs cannot
assume, and GCC's generic lowering of four lanes without it is slower than two."""

_OP = {getattr(ca, name): name[3:] for name in dir(ca) if name.startswith("OP_")}
UNARY = {
    "NEG": "-{0}", "TWICE": "(splat(2.0) * {0})", "SQ": "({0} * {0})",
    "INV": "(splat(1.0) / {0})", "NOT": "flag({0} == splat(0.0))",
    **{name: f"lane1({name.lower()}, {{0}})"
       for name in ("SQRT", "FABS", "SIN", "COS", "TAN", "EXP", "LOG", "TANH", "ASIN",
                    "ACOS", "ATAN", "SINH", "COSH", "FLOOR", "CEIL", "ERF", "LOG1P",
                    "EXPM1")},
    "SIGN": "lane1(csign, {0})",
}
"""Templates of the one-argument operations (CasADi's C: ``casadi_sq``, ``casadi_sign``,
libm); ``lane1`` applies a scalar function to every lane."""
BINARY = {
    "ADD": "({0} + {1})", "SUB": "({0} - {1})", "MUL": "({0} * {1})", "DIV": "({0} / {1})",
    "LT": "flag({0} < {1})", "LE": "flag({0} <= {1})", "EQ": "flag({0} == {1})",
    "NE": "flag({0} != {1})",
    "AND": "flag(({0} != splat(0.0)) & ({1} != splat(0.0)))",
    "OR": "flag(({0} != splat(0.0)) | ({1} != splat(0.0)))",
    "IF_ELSE_ZERO": "select({0}, {1})",
    **{name: f"lane2({fn}, {{0}}, {{1}})"
       for name, fn in (("POW", "pow"), ("CONSTPOW", "pow"), ("ATAN2", "atan2"),
                        ("FMIN", "fmin"), ("FMAX", "fmax"), ("FMOD", "fmod"),
                        ("HYPOT", "hypot"), ("COPYSIGN", "copysign"))},
}
"""Templates of the two-argument operations; comparisons give 1.0 or 0.0 as in CasADi, and
``if_else_zero(c, x)`` is x where c is not 0 (NaN counts as true, as C's ``c ? x : 0``)."""

_HEADER = """\
#include <math.h>
#include <string.h>
#define L {lanes}
typedef double V __attribute__((vector_size(8 * L)));
typedef long long M __attribute__((vector_size(8 * L)));
static inline V splat(double a) {{ V r; for (int k = 0; k < L; k++) r[k] = a; return r; }}
static inline V flag(M m) {{ return (V)(m & (M)splat(1.0)); }}
static inline V select(V c, V x) {{ return (V)((c != splat(0.0)) & (M)x); }}
static inline double csign(double x) {{ return x < 0 ? -1 : x > 0 ? 1 : x; }}
#define lane1(f, a) ({{ V a_ = (a), r_; for (int k = 0; k < L; k++) r_[k] = f(a_[k]); r_; }})
#define lane2(f, a, b) ({{ V a_ = (a), b_ = (b), r_; \\
    for (int k = 0; k < L; k++) r_[k] = f(a_[k], b_[k]); r_; }})
"""

_RUN = """
/* s: [z; k; v] per lane, lane fastest (s[i * L + k]); p: parameters per lane; h, t0: one
   per lane. n_renorm renormalisations of `every` steps; logs[r * L + k]; states[(k * steps
   + j) * (N + 1) + i] is [z; k] of lane k after step j of the call (each lane's rows in one
   piece). */
void bd_lanes_run(double *s_, const double *p_, const double *h_, const double *t0_,
                  int n_renorm, int every, double *logs, double *states) {{
  V s[{ns}], out[{ns}], p[{np}], h[1], t0[1], c[{nc}], y[{n}], q[{n}], lg[1];
  memcpy(s, s_, sizeof s); memcpy(p, p_, sizeof p); memcpy(h, h_, sizeof h);
  memcpy(t0, t0_, sizeof t0);
  constants(p, h, t0, c);
  long j = 0, steps = (long)n_renorm * every;
  for (int r = 0; r < n_renorm; r++) {{
    for (int i = 0; i < every; i++, j++) {{
      step(s, p, h, t0, c, out);
      memcpy(s, out, sizeof s);
      for (int k = 0; k < L; k++)
        for (int m = 0; m < {n1}; m++) states[(k * steps + j) * {n1} + m] = s[m][k];
    }}
    memcpy(y, s + {n1}, sizeof y);
    renorm(y, q, lg);
    memcpy(s + {n1}, q, sizeof q);
    memcpy(logs + r * L, lg, sizeof(V));
  }}
  memcpy(s_, s, sizeof s);
}}
"""


_STATE_RUN = """
/* s: [z; k] per lane, lane fastest (s[i * L + k]); p: parameters per lane; h, t0: one per
   lane. n_out times `every` steps; out[(k * n_out + j) * N + i] is z_i of lane k after
   (j + 1) * every steps of the call (each lane's rows in one piece). */
void bd_state_lanes_run(double *s_, const double *p_, const double *h_, const double *t0_,
                        long n_out, long every, double *out) {{
  V s[{ns}], next[{ns}], p[{np}], h[1], t0[1], c[{nc}];
  memcpy(s, s_, sizeof s); memcpy(p, p_, sizeof p); memcpy(h, h_, sizeof h);
  memcpy(t0, t0_, sizeof t0);
  constants(p, h, t0, c);
  for (long j = 0; j < n_out; j++) {{
    for (long i = 0; i < every; i++) {{ step(s, p, h, t0, c, next); memcpy(s, next, sizeof s); }}
    for (int k = 0; k < L; k++)
      for (int m = 0; m < {n}; m++) out[(k * n_out + j) * {n} + m] = s[m][k];
  }}
  memcpy(s_, s, sizeof s);
}}
"""


class Unsupported(ValueError):
    """An operation ``vector_c`` does not write."""


def vector_c(fn: ca.Function, name: str) -> str:
    """``static inline void name(const V *x0, …, V *y0, …)``: the SX Function ``fn`` on
    ``LANES`` lanes, one C statement per instruction in CasADi's order."""
    if not fn.is_a("SXFunction"):
        raise Unsupported(f"{fn.name()}: not an SX Function")
    inputs = ", ".join(f"const V *restrict x{i}" for i in range(fn.n_in()))
    outputs = ", ".join(f"V *restrict y{i}" for i in range(fn.n_out()))
    lines = [f"static inline void {name}({inputs}, {outputs}) {{",
             "  V " + ", ".join(f"w{i}" for i in range(max(fn.sz_w(), 1))) + ";"]
    for i in range(fn.n_instructions()):
        op, out, arg = _OP[fn.instruction_id(i)], fn.instruction_output(i), \
            fn.instruction_input(i)
        if op == "INPUT":
            lines.append(f"  w{out[0]} = x{arg[0]}[{arg[1]}];")
        elif op == "OUTPUT":
            lines.append(f"  y{out[0]}[{out[1]}] = w{arg[0]};")
        elif op == "CONST":
            lines.append(f"  w{out[0]} = splat({float(fn.instruction_constant(i))!r});")
        elif op in UNARY:
            lines.append(f"  w{out[0]} = {UNARY[op].format(f'w{arg[0]}')};")
        elif op in BINARY:
            lines.append(f"  w{out[0]} = {BINARY[op].format(f'w{arg[0]}', f'w{arg[1]}')};")
        else:
            raise Unsupported(f"{fn.name()}: operation {op} is not written for lanes")
    lines.append("}")
    return "\n".join(lines)


def kernel_source(step: ca.Function, constants: ca.Function, renorm: ca.Function) -> str:
    """C of the lane kernel: ``step(s, p, h, t0, c) -> s'``, ``constants(p, h, t0) -> c``
    and ``renorm(Y) -> (Q, log|R|)`` (``tangent.qr_logs``) for one tangent vector."""
    n = renorm.size1_in(0)
    return "\n".join([
        _HEADER.format(lanes=LANES), vector_c(constants, "constants"),
        vector_c(step, "step"), vector_c(renorm, "renorm"),
        _RUN.format(ns=step.size1_in(0), np=step.size1_in(1), nc=step.size1_in(4), n=n,
                    n1=n + 1)])


def state_kernel_source(step: ca.Function, constants: ca.Function) -> str:
    """C of the state-only lane kernel: ``step(s, p, h, t0, c) -> s'`` (s = ``[z; k]``) and
    ``constants(p, h, t0) -> c``, run by ``bd_state_lanes_run``."""
    return "\n".join([
        _HEADER.format(lanes=LANES), vector_c(constants, "constants"), vector_c(step, "step"),
        _STATE_RUN.format(ns=step.size1_in(0), np=step.size1_in(1), nc=step.size1_in(4),
                          n=step.size1_in(0) - 1)])


def _pointer(a: np.ndarray) -> ctypes.c_void_p:
    return a.ctypes.data_as(ctypes.c_void_p)


def _lane_arrays(s: np.ndarray, p: np.ndarray, h: np.ndarray,
                 t0: np.ndarray) -> list[ctypes.c_void_p]:
    """Pointers to ``s`` (checked: changed in place) and contiguous float copies of the
    per-lane ``p``, ``h`` and ``t0``, in the order every run function takes them."""
    if not s.flags.c_contiguous or s.dtype != np.float64:
        raise ValueError("s: a C-contiguous float64 array")
    arrays = [np.ascontiguousarray(a, dtype=float) for a in (p, h, t0)]
    return [_pointer(s), *(_pointer(a) for a in arrays)]


@dataclass
class LaneLibrary:
    """A loaded lane library of one model and balls: its run function ``_fn``."""

    n: int
    """The model's state size."""
    n_par: int
    path: Path
    _fn: Any


@dataclass
class Kernel(LaneLibrary):
    """One model's lane kernel: ``run`` advances ``LANES`` points together."""

    def run(self, s: np.ndarray, p: np.ndarray, h: np.ndarray, t0: np.ndarray,
            n_renorm: int, every: int) -> tuple[np.ndarray, np.ndarray]:
        """Advance ``s`` ((2n + 1) × LANES: ``[z; k; v]`` per lane, changed in place) by
        ``n_renorm`` renormalisations of ``every`` steps; returns the logs (n_renorm ×
        LANES) and the states (LANES × (n_renorm·every) × (n + 1): lane k's ``[z; k]`` after
        every step, one contiguous block per lane). ``p`` (n_par × LANES), ``h`` and ``t0``
        (LANES) in SI units."""
        logs = np.empty((n_renorm, LANES))
        states = np.empty((LANES, n_renorm * every, self.n + 1))
        self._fn(*_lane_arrays(s, p, h, t0), ctypes.c_int(n_renorm), ctypes.c_int(every),
                 _pointer(logs), _pointer(states))
        return logs, states


@dataclass
class StateKernel(LaneLibrary):
    """One model's state-only lane kernel: ``run`` advances ``LANES`` runs together."""

    def run(self, s: np.ndarray, p: np.ndarray, h: np.ndarray, t0: np.ndarray,
            n_out: int, every: int) -> np.ndarray:
        """Advance ``s`` ((n + 1) × LANES: ``[z; k]`` per lane, z in SI units after step k,
        whose time is ``t0 + k·h``; changed in place) by ``n_out · every`` RK4 steps;
        returns the states (LANES × n_out × n: lane k's z after every ``every`` steps).
        ``p`` (n_par × LANES), ``h`` and ``t0`` (LANES, s)."""
        states = np.empty((LANES, n_out, self.n))
        self._fn(*_lane_arrays(s, p, h, t0), ctypes.c_long(n_out), ctypes.c_long(every),
                 _pointer(states))
        return states


@cache
def kernel(model: Any, structure: tuple[int, ...], renorm_every: int,
           angle_addition: bool = False) -> Kernel | None:
    """The lane kernel of ``model`` with these balls (with ``angle_addition``: the step of
    ``tangent.Carry.angle_addition``, the chart's), compiled and self-tested against
    ``tangent.tangent_block`` of the same step (bit for bit over one renormalisation), or
    None (see the module). Memoised per process."""
    step, constants = lyapunov_step(model, structure, 1, angle_addition)
    n = model.n_state
    try:
        source = kernel_source(step, constants, qr_logs(n, 1))
    except Unsupported:
        return None
    stem = "bd_lanes_aa" if angle_addition else "bd_lanes"
    loaded = _load(source, library_stem(stem, model, structure), "bd_lanes_run")
    if loaded is None:
        return None
    built = Kernel(n, len(model.parameter_names), *loaded)
    block = tangent_block(model, structure, 1, renorm_every, 1, angle_addition=angle_addition)
    return built if _agrees(built, block, model, renorm_every) else None


@contextmanager
def _compiling(path: Path) -> Iterator[None]:
    """Holds an exclusive lock on ``<path>.lock`` (POSIX ``flock``; nothing elsewhere):
    workers of one chart that first meet a model and balls at the same moment compile its
    kernel once, the others wait and load it."""
    try:
        import fcntl
    except ImportError:  # no flock: each process may compile (renamed atomically anyway)
        yield
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path.with_suffix(".lock"), "w") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def _load(source: str, stem: str, symbol: str) -> tuple[Path, Any] | None:
    """The library of ``source`` from the cache of ``analysis.integrate.compiled`` (built
    there once, by one process at a time) and its function ``symbol``, or None when it
    cannot be built or loaded."""
    command = compiler_command()
    path = cached_path(stem, source, command)
    try:
        if not path.exists():
            with _compiling(path):  # a second process waits, then loads the first's build
                if not path.exists():
                    compile_library(source, path, command)
        fn = getattr(ctypes.CDLL(str(path)), symbol)
    except (CompileError, OSError, AttributeError):
        return None
    fn.restype = None
    return path, fn


def rk4_state_step(model: Any, structure: tuple[int, ...]) -> tuple[ca.Function, ca.Function]:
    """The RK4 step of the compiled blocks (``compiled.rk4_blocks``) and its constants:
    ``rk4_steps1(s, p, h, t0, c) -> s'`` with ``s = [z; k]``, ``rk4_constants(p, h, t0)``
    (the same memoised Functions, so the same operations)."""
    return tuple(tangent_step(model.functions(structure).rk4_step, Carry(constants=True),
                              "rk4_steps1", "rk4_constants"))


@cache
def state_kernel(model: Any, structure: tuple[int, ...]) -> StateKernel | None:
    """The state-only lane kernel of ``model`` with these balls, compiled and self-tested
    against the CasADi step it is written from (bit for bit over ``SELF_TEST_STEPS`` steps
    from different states, counters, parameters and steps), or None (see the module).
    Memoised per process."""
    step, constants = rk4_state_step(model, structure)
    try:
        source = state_kernel_source(step, constants)
    except Unsupported:
        return None
    loaded = _load(source, library_stem("bd_state_lanes", model, structure),
                   "bd_state_lanes_run")
    if loaded is None:
        return None
    built = StateKernel(model.n_state, len(model.parameter_names), *loaded)
    return built if _state_agrees(built, step, constants, model) else None


SELF_TEST_STEPS = 6
"""Steps of the state kernel's self-test, kept after every 2nd (so both loops run)."""


def _state_agrees(built: StateKernel, step: ca.Function, constants: ca.Function,
                  model: Any) -> bool:
    """Every lane's states equal the CasADi step's (the VM), bit for bit."""
    n = built.n
    p = model.parameter_vector(model.defaults)
    h = float(model.simulation_defaults["dt"])
    lanes = [np.append(test_state(n) * (1 + 0.1 * k), 3.0 + k) for k in range(LANES)]
    ps = [p * (1 + 0.01 * k) for k in range(LANES)]
    hs, t0s = h * (1 + 0.05 * np.arange(LANES)), 0.1 * np.arange(LANES)
    s = np.ascontiguousarray(np.stack(lanes, axis=1))
    got = built.run(s, np.stack(ps, axis=1), hs, t0s, SELF_TEST_STEPS // 2, 2)
    for k, start in enumerate(lanes):
        c = constants(ps[k], hs[k], t0s[k])
        want = [start]
        for _ in range(SELF_TEST_STEPS):
            want.append(np.asarray(step(want[-1], ps[k], hs[k], t0s[k], c)).ravel())
        if not (np.array_equal(np.array(want[2::2])[:, :n], got[k])
                and np.array_equal(want[-1], s[:, k])):
            return False
    return True


def _agrees(built: Kernel, block: ca.Function, model: Any, renorm_every: int) -> bool:
    """One renormalisation of every lane equals the CasADi block's, bit for bit."""
    n = built.n
    p = model.parameter_vector(model.defaults)
    h = float(model.simulation_defaults["dt"])
    lanes = [np.concatenate([test_state(n) * (1 + 0.1 * k), [3.0 + k], np.eye(n)[:, 0]])
             for k in range(LANES)]
    s = np.ascontiguousarray(np.stack(lanes, axis=1))
    logs, _ = built.run(s, np.repeat(p[:, None], LANES, axis=1), np.full(LANES, h),
                        np.full(LANES, 0.1), 1, renorm_every)
    for k, start in enumerate(lanes):
        want_s, want_logs = (np.asarray(x).ravel() for x in block(start, p, h, 0.1)[:2])
        if not (np.array_equal(want_s, s[:, k]) and np.array_equal(want_logs, logs[:, k])):
            return False
    return True
