"""The one writer of member C: CasADi SX Functions as device-neutral scalar C, and the
member loops (states; states and one tangent vector) built on them.

Every function is written instruction by instruction from the SX Function's algorithm, in
CasADi's order, one C statement each, with the IEEE operations CasADi's own C uses
(``casadi_sq`` is ``x*x``, ``casadi_sign``, libm for sin, cos, pow …): the CPU build of the
text (``cpu.py``, gcc without fast-math, ``-ffp-contract=off``) computes what the compiled
blocks of ``analysis.integrate.compiled`` compute, bit for bit. Functions are declared with
``BD_FN`` (``static inline`` for a C compiler; ``__device__ __forceinline__`` for NVRTC, see
``cuda.py``) and their pointers with ``BD_RESTRICT``; the member loop ``bd_member_*`` runs
one member from its index ``m``, so the OpenMP loop (``cpu.py``) and the CUDA kernel
(``cuda.py``, one member per thread) only wrap it.

Two variants:

- **states** (``model_source``): the RK4 step of the compiled blocks
  (``tangent.tangent_step(rk4_step, Carry(constants=True))``: ``rk4_steps1(s, p, h, t0, c)``
  with ``s = [z; k]``, step k from ``t0 + k·h``) and its parameter-only constants;
- **tangent** (``model_source(…, tangent=True)``): the same steps over the transient, then
  RK4 of the state and of the variational equation stage by stage:
  ``stage(t, z, p, v, c) -> (f(t, z),
  J(t, z)·v)`` (the model's ``rhs`` and its Jacobian–vector product, ``casadi.jtimes``), so
  v' is the exact derivative of the discrete RK4 map the member follows
  (v' = v + h/6 (V1 + 2 V2 + 2 V3 + V4), V_i = J(t_i, z_i)(v + a_i h V_{i−1})): a working
  set of one rhs and one product, not of the forward AD of a fused step (register-light on
  a GPU). After the transient the member's states are those of that stage RK4, equal to the
  state variant's to rounding (the runtime's fused step reaches the cage angle of its later
  stages by rotation). The tangent is renormalised at every section and the log of its
  growth kept. The stage takes the sin and cos of its forcing angles as inputs
  (``stage_functions``): the CPU build computes them once per step and turns them for the
  later stages (``bd_rotate``: one sin/cos pair per angle and step, 40 % faster than four);
  the CUDA build (``BD_STAGE_SINCOS``) computes them at each stage time (``bd_trig``), which
  keeps no rotation across the stages: fewer live registers, no spills up to vakharia2015
  N_b 12. The two differ by rounding.

Lanes (CPU build, ``lanes`` > 0): the same text also holds the step and the stage written on
``BD_LANES`` members at once (``lanes_c``: GCC vector extensions, one vector of doubles per
work value, blends for the selections, libm lane by lane) and a block loop (``_LANES_BLOCK``,
``_LANES_TANGENT``) that keeps each lane's bookkeeping as the member loop does: the same
operations in every lane, so the same results bit for bit, 1.9-2.5 times the tangent
steps per second of the member loop on AVX-512 or AVX2 (``benchmarks/bench_lanes.py``);
only for models with few libm calls (``lanes_pay``).

The blow-up predicate is written from ``simulate.bad_states`` (``blow_up_c``): a state not
finite, or a body's centre displacement (``hypot(x, y)``, ``|x|``) beyond the member's
limit (m), the rule of ``simulate.bad_states``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import casadi as ca

_OP = {getattr(ca, name): name[3:] for name in dir(ca) if name.startswith("OP_")}
UNARY = {
    "NEG": "(-{0})", "TWICE": "(2.0 * {0})", "SQ": "({0} * {0})", "INV": "(1.0 / {0})",
    "NOT": "((double)({0} == 0.0))", "SIGN": "bd_sign({0})",
    **{name: f"{name.lower()}({{0}})"
       for name in ("SQRT", "FABS", "SIN", "COS", "TAN", "EXP", "LOG", "TANH", "ASIN",
                    "ACOS", "ATAN", "SINH", "COSH", "FLOOR", "CEIL", "ERF", "LOG1P",
                    "EXPM1")},
}
"""C of the one-argument operations (CasADi's C: ``casadi_sq``, ``casadi_sign``, libm)."""
BINARY = {
    "ADD": "({0} + {1})", "SUB": "({0} - {1})", "MUL": "({0} * {1})", "DIV": "({0} / {1})",
    "LT": "((double)({0} < {1}))", "LE": "((double)({0} <= {1}))",
    "EQ": "((double)({0} == {1}))", "NE": "((double)({0} != {1}))",
    "AND": "((double)({0} != 0.0 && {1} != 0.0))",
    "OR": "((double)({0} != 0.0 || {1} != 0.0))",
    "IF_ELSE_ZERO": "({0} != 0.0 ? {1} : 0.0)",
    **{name: f"{fn}({{0}}, {{1}})"
       for name, fn in (("POW", "pow"), ("CONSTPOW", "pow"), ("ATAN2", "atan2"),
                        ("FMIN", "fmin"), ("FMAX", "fmax"), ("FMOD", "fmod"),
                        ("HYPOT", "hypot"), ("COPYSIGN", "copysign"))},
}
"""C of the two-argument operations; comparisons give 1.0 or 0.0 as in CasADi, and
``if_else_zero(c, x)`` is x where c is not 0 (NaN counts as true, as C's ``c ? x : 0``)."""

PRELUDE = """\
#ifdef __CUDACC__
#define BD_FN static __device__ __forceinline__
#define BD_RESTRICT __restrict__
#define BD_GLOBAL extern "C" __global__
typedef long long bd_long;
#define BD_ROLLED _Pragma("unroll 1")
#define BD_NOINLINE static __device__ __noinline__
#ifndef INFINITY
#define INFINITY __longlong_as_double(0x7ff0000000000000ULL)
#endif
#ifndef NAN
#define NAN __longlong_as_double(0x7ff8000000000000ULL)
#endif
#else
#include <math.h>
#include <string.h>
#define BD_FN static inline
#define BD_RESTRICT restrict
typedef long long bd_long;
#define BD_ROLLED
#define BD_NOINLINE static
#endif
BD_FN double bd_sign(double x) { return x < 0 ? -1 : x > 0 ? 1 : x; }
"""
"""Macros that make one text a C library (gcc) and a CUDA module (NVRTC defines
``__CUDACC__``; its math functions are device functions without an include)."""


class Unsupported(ValueError):
    """An operation ``scalar_c`` does not write, or a Function that is not SX."""


def function_head(fn: ca.Function, name: str, kind: str, qualifier: str = "BD_FN"
                  ) -> list[str]:
    """The first lines of the C of the SX Function ``fn`` as ``name``, on values of type
    ``kind`` (``double``; ``bd_vd``, the lanes): its signature and its work values
    (``Unsupported`` for a Function that is not SX)."""
    if not fn.is_a("SXFunction"):
        raise Unsupported(f"{fn.name()}: not an SX Function")
    inputs = ", ".join(f"const {kind} *BD_RESTRICT x{i}" for i in range(fn.n_in()))
    outputs = ", ".join(f"{kind} *BD_RESTRICT y{i}" for i in range(fn.n_out()))
    return [f"{qualifier} void {name}({inputs}, {outputs}) {{",
            f"  {kind} " + ", ".join(f"w{i}" for i in range(max(fn.sz_w(), 1))) + ";"]


def scalar_c(fn: ca.Function, name: str, qualifier: str = "BD_FN") -> str:
    """``BD_FN void name(const double *x0, …, double *y0, …)``: the SX Function ``fn`` on
    doubles, one C statement per instruction in CasADi's order (``Unsupported`` for an
    operation outside ``UNARY``/``BINARY``); ``qualifier`` replaces ``BD_FN``."""
    lines = function_head(fn, name, "double", qualifier)
    for i in range(fn.n_instructions()):
        op, out, arg = _OP[fn.instruction_id(i)], fn.instruction_output(i), \
            fn.instruction_input(i)
        if op == "INPUT":
            lines.append(f"  w{out[0]} = x{arg[0]}[{arg[1]}];")
        elif op == "OUTPUT":
            lines.append(f"  y{out[0]}[{out[1]}] = w{arg[0]};")
        elif op == "CONST":
            lines.append(f"  w{out[0]} = {_constant(float(fn.instruction_constant(i)))};")
        elif op in UNARY:
            lines.append(f"  w{out[0]} = {UNARY[op].format(f'w{arg[0]}')};")
        elif op in BINARY:
            lines.append(f"  w{out[0]} = {BINARY[op].format(f'w{arg[0]}', f'w{arg[1]}')};")
        else:
            raise Unsupported(f"{fn.name()}: operation {op} is not written as member C")
    lines.append("}")
    return "\n".join(lines)


def _constant(value: float) -> str:
    """A double literal that reads back exactly (inf and NaN by expression)."""
    if value != value:
        return "(0.0 / 0.0)"
    if value in (float("inf"), float("-inf")):
        return "(1.0 / 0.0)" if value > 0 else "(-1.0 / 0.0)"
    return repr(value)


VECTOR_PRELUDE = """\
typedef double bd_vd __attribute__((vector_size(8 * BD_LANES)));
typedef long long bd_vl __attribute__((vector_size(8 * BD_LANES)));
BD_FN bd_vd bd_vb(double x) {
  bd_vd r;
  for (int l = 0; l < BD_LANES; l++) r[l] = x;
  return r;
}
BD_FN bd_vd bd_vsel(bd_vl m, bd_vd a, bd_vd b) {
  return (bd_vd)((m & (bd_vl)a) | (~m & (bd_vl)b));
}
BD_FN bd_vd bd_vmask(bd_vl m) { return (bd_vd)(m & (bd_vl)bd_vb(1.0)); }
BD_FN bd_vd bd_vfabs(bd_vd a) { return (bd_vd)((bd_vl)a & ~(bd_vl)bd_vb(-0.0)); }
BD_FN bd_vd bd_vsign(bd_vd a) {
  return bd_vsel(a < 0.0, bd_vb(-1.0), bd_vsel(a > 0.0, bd_vb(1.0), a));
}
#define BD_VMAP1(fn, a) ({ bd_vd r_, a_ = (a); \\
  for (int l_ = 0; l_ < BD_LANES; l_++) r_[l_] = fn(a_[l_]); \\
  r_; })
#define BD_VMAP2(fn, a, b) ({ bd_vd r_, a_ = (a), b_ = (b); \\
  for (int l_ = 0; l_ < BD_LANES; l_++) r_[l_] = fn(a_[l_], b_[l_]); \\
  r_; })
"""
"""The lanes of the CPU build (GCC/clang vector extensions): ``bd_vd`` holds one double of
``BD_LANES`` members; a comparison gives a lane mask (all bits set or clear) and a selection
is a bitwise blend, so every lane computes what the scalar C computes, bit for bit (a NaN
condition counts as true in ``if_else_zero``, -0.0 and NaN keep their sign under
``sign``, as in ``bd_sign``); libm functions (and sqrt) run lane by lane."""
VUNARY = {"NEG": "(-{0})", "TWICE": "(2.0 * {0})", "SQ": "({0} * {0})",
          "INV": "(1.0 / {0})", "NOT": "bd_vmask({0} == 0.0)", "SIGN": "bd_vsign({0})",
          "FABS": "bd_vfabs({0})"}
"""``UNARY`` on lanes where it is not one libm call a lane."""
VBINARY = {"ADD": "({0} + {1})", "SUB": "({0} - {1})", "MUL": "({0} * {1})",
           "DIV": "({0} / {1})", "LT": "bd_vmask({0} < {1})", "LE": "bd_vmask({0} <= {1})",
           "EQ": "bd_vmask({0} == {1})", "NE": "bd_vmask({0} != {1})",
           "AND": "bd_vmask(({0} != 0.0) & ({1} != 0.0))",
           "OR": "bd_vmask(({0} != 0.0) | ({1} != 0.0))",
           "IF_ELSE_ZERO": "(bd_vd)((bd_vl){1} & ({0} != 0.0))"}
"""``BINARY`` on lanes where it is not one libm call a lane."""


def lanes_c(fn: ca.Function, name: str) -> str:
    """``BD_FN void name(const bd_vd *x0, …, bd_vd *y0, …)``: ``scalar_c`` of ``fn`` on
    ``BD_LANES`` members at once (``VECTOR_PRELUDE``; element i of an input or output is
    the vector of its lanes), the same operations in the same order in every lane."""
    lines = function_head(fn, name, "bd_vd")
    for i in range(fn.n_instructions()):
        op, out, arg = _OP[fn.instruction_id(i)], fn.instruction_output(i), \
            fn.instruction_input(i)
        w = [f"w{a}" for a in arg]
        if op == "INPUT":
            lines.append(f"  w{out[0]} = x{arg[0]}[{arg[1]}];")
        elif op == "OUTPUT":
            lines.append(f"  y{out[0]}[{out[1]}] = w{arg[0]};")
        elif op == "CONST":
            value = _constant(float(fn.instruction_constant(i)))
            lines.append(f"  w{out[0]} = bd_vb({value});")
        elif op in VUNARY:
            lines.append(f"  w{out[0]} = {VUNARY[op].format(*w)};")
        elif op in VBINARY:
            lines.append(f"  w{out[0]} = {VBINARY[op].format(*w)};")
        elif op in UNARY:
            lines.append(f"  w{out[0]} = BD_VMAP1({UNARY[op].split('(')[0]}, {w[0]});")
        elif op in BINARY:
            lines.append(f"  w{out[0]} = BD_VMAP2({BINARY[op].split('(')[0]}, {w[0]}, {w[1]});")
        else:
            raise Unsupported(f"{fn.name()}: operation {op} is not written as member C")
    lines.append("}")
    return "\n".join(lines)


LANE_CALLS_MAX = 8
"""Most libm calls lane by lane (``BD_VMAP1``/``BD_VMAP2``: all but sqrt, which is one
instruction) in a Function written on lanes for the lanes to pay: each call spills every
live vector. Measured on one thread, 16 members, AVX-512 (``benchmarks/bench_lanes.py``):
0-8 calls (sin and cos of the forcing angles) run in 0.3-0.9 times the scalar build's time,
20-128 (atan2, fmax, pow of the defect and roller models) in 1.1-3.7 times."""


def lane_calls(fn: ca.Function) -> int:
    """The libm calls lane by lane of ``lanes_c(fn)``."""
    plain = {*VUNARY, *VBINARY, "INPUT", "OUTPUT", "CONST", "SQRT"}
    return sum(_OP[fn.instruction_id(i)] not in plain for i in range(fn.n_instructions()))


def lanes_pay(model: object, structure: tuple[int, ...], tangent: bool) -> bool:
    """Whether the CPU build of this variant should run in blocks of lanes: every Function
    it writes on lanes (the step; the tangent's stage too) has at most ``LANE_CALLS_MAX``
    libm calls lane by lane."""
    functions = [state_functions(model, structure)[0]]
    if tangent:
        functions.append(stage_functions(model, structure).stage)
    return all(lane_calls(fn) <= LANE_CALLS_MAX for fn in functions)

def blow_up_c(n: int, pairs: Sequence[tuple[int, int | None]]) -> str:
    """``bd_bad(z, limit)``: 1 when a state is not finite (``z - z == 0`` fails for inf and
    NaN, needing no header on either build) or a centre displacement
    (``hypot`` of a body's (x, y), ``fabs`` of x for a body moving along x) is beyond
    ``limit`` (m); ``simulate.bad_states`` in C."""
    lines = ["BD_FN int bd_bad(const double *z, double limit) {",
             f"  for (int i = 0; i < {n}; i++) if (!(z[i] - z[i] == 0.0)) return 1;"]
    for i, j in pairs:
        shift = f"fabs(z[{i}])" if j is None else f"hypot(z[{i}], z[{j}])"
        lines.append(f"  if ({shift} > limit) return 1;")
    lines.append("  return 0;\n}")
    lines.append("BD_FN void bd_extend(double *lo, double *hi, const double *z) {\n"
                 f"  for (int i = 0; i < {n}; i++) {{ lo[i] = fmin(lo[i], z[i]); "
                 "hi[i] = fmax(hi[i], z[i]); }\n}")
    return "\n".join(lines)


_ARGS = """bd_long m, const double *z0, const double *k0, const double *p, const double *h,
    const double *t0, const double *limit, const bd_long *transient, const bd_long *every,
    const bd_long *n_sec, const bd_long *skip, const bd_long *ext_from,
    const bd_long *ext_to, bd_long kmax, int keep, double *sections, double *logs,
    double *final, bd_long *diverged, double *low, double *high"""
"""The arguments of every member function and wrapper: member index, then per member
(row-major, member first) the state z0 (n), step counter k0, parameters (n_par), step h
(s), start time t0 (s), blow-up limit (m) and schedule (transient steps, steps per section,
sections, skipped sections); the sections' stride kmax (>= every n_sec) and whether they
are kept; the outputs: sections (kmax × n), logs (kmax; tangent), final state (n), the
step of the blow-up (-1: none), and the extremes of every state over the steps ext_from …
ext_to (the run goes on to ext_to when it ends after the last section). Sections and logs
past a member's own are NaN."""

_CALL = ("m, z0, k0, p, h, t0, limit, transient, every, n_sec, skip, ext_from, ext_to, kmax, "
         "keep, sections, logs, final, diverged, low, high")

_MEMBER_HEAD = """
BD_FN void bd_member_{variant}({args}) {{
  double s[{ns}], nx[{ns}], c[{nc}];
  const double *pm = p + m * {npar};
  const double hm = h[m], t0m = t0[m], lim = limit[m];
#ifdef __CUDACC__
  double *lo = low + m * {n}, *hi = high + m * {n};  /* no registers for them on a GPU */
#else
  double lo[{n}], hi[{n}];  /* the member's own, written out at its end: no false sharing */
#endif
  BD_ROLLED for (int i = 0; i < {n}; i++) {{
    s[i] = z0[m * {n} + i]; lo[i] = INFINITY; hi[i] = -INFINITY;
  }}
  s[{n}] = k0[m];
  rk4_constants(pm, &hm, &t0m, c);{stage_setup}
  const bd_long tr = transient[m], ev = every[m], ns = n_sec[m];
  const bd_long total = tr + ev * ns, from = ext_from[m], upto = ext_to[m];
  const bd_long end = total > upto ? total : upto;
  bd_long step = 0, bad = -1, sec = 0;
  if (from <= 0 && upto >= 0) bd_extend(lo, hi, s);
  for (; step < tr; ) {{
{advance}
    step++;
    if (bd_bad(s, lim)) {{ bad = step; break; }}
    if (step >= from && step <= upto) bd_extend(lo, hi, s);
  }}
"""

_STATE_BODY = """
  for (bd_long left = ev; bad < 0 && step < end; ) {{
{advance}
    step++;
    if (bd_bad(s, lim)) {{ bad = step; break; }}
    if (step >= from && step <= upto) bd_extend(lo, hi, s);
    if (--left == 0) {{
      if (keep && sec < ns)
        BD_ROLLED for (int i = 0; i < {n}; i++) sections[(m * kmax + sec) * {n} + i] = s[i];
      sec++; left = ev;
    }}
  }}
"""

_TANGENT_TAIL = """
    step++;
    if (bd_bad(s, lim)) {{ bad = step; break; }}
    if (step >= from && step <= upto) bd_extend(lo, hi, s);
    if (--left == 0 && sec < ns) {{
      double norm = 0.0;
      BD_ROLLED for (int i = 0; i < {n}; i++) norm += v[i] * v[i];
      norm = sqrt(norm);
      BD_ROLLED for (int i = 0; i < {n}; i++) v[i] /= norm;
      logs[m * kmax + sec] = log(norm);
      if (keep) BD_ROLLED for (int i = 0; i < {n}; i++) sections[(m * kmax + sec) * {n} + i] = s[i];
      sec++; left = ev;
    }}
  }}
"""

_TANGENT_BODY = """
  double v[{n}], zs[{n}], vs[{n}], f[{n}], jv[{n}], az[{n}], av[{n}], d[{nd}];
  double ang[{na1}], rot[{nr}], cs0[{ncs}], cs[{ncs}];
  stage_constants(pm, d);
  stage_rotations(pm, &hm, rot);
  for (int i = 0; i < {n}; i++) v[i] = i == 0 ? 1.0 : 0.0;
  const double half = hm / 2.0, sixth = hm / 6.0;
  for (bd_long left = ev; bad < 0 && step < end; ) {{
    const double t = t0m + s[{n}] * hm, th = t + half, tf = t + hm;
    bd_trig(cs0, &t, pm, ang);
    stage(&t, s, pm, v, d, cs0, f, jv);
    for (int i = 0; i < {n}; i++) {{
      az[i] = f[i]; av[i] = jv[i];
      zs[i] = s[i] + half * f[i]; vs[i] = v[i] + half * jv[i];
    }}
    bd_rotate(cs, cs0, rot, 0);  /* the angles at t + h/2 */
    stage(&th, zs, pm, vs, d, cs, f, jv);
    for (int i = 0; i < {n}; i++) {{
      az[i] += 2.0 * f[i]; av[i] += 2.0 * jv[i];
      zs[i] = s[i] + half * f[i]; vs[i] = v[i] + half * jv[i];
    }}
    stage(&th, zs, pm, vs, d, cs, f, jv);
    for (int i = 0; i < {n}; i++) {{
      az[i] += 2.0 * f[i]; av[i] += 2.0 * jv[i];
      zs[i] = s[i] + hm * f[i]; vs[i] = v[i] + hm * jv[i];
    }}
    bd_rotate(cs, cs0, rot, 2);  /* the angles at t + h */
    stage(&tf, zs, pm, vs, d, cs, f, jv);
    for (int i = 0; i < {n}; i++) {{
      s[i] += sixth * (az[i] + f[i]); v[i] += sixth * (av[i] + jv[i]);
    }}
    s[{n}] += 1.0;
""" + _TANGENT_TAIL

_CUDA_TANGENT_BODY = """
  double v[{n}], vs[{n}], jv[{n}], av[{n}];
  BD_ROLLED for (int i = 0; i < {n}; i++) v[i] = i == 0 ? 1.0 : 0.0;
  for (bd_long left = ev; bad < 0 && step < end; ) {{
    bd_rk4_tangent(s, v, pm, hm, t0m, d, ang, cs, zs, vs, f, jv, az, av);
""" + _TANGENT_TAIL
"""The CUDA build's tangent loop: the stages of ``_TANGENT_BODY`` (the same operations)
in a loop that is not unrolled (``bd_rk4_tangent``), one inlined stage, each forcing angle's
sin and cos at the stage's own time."""

_CUDA_STAGED = """
BD_FN void bd_rk4(double *s, const double *p, double h, double t0, const double *d,
                  double *ang, double *cs, double *zs, double *f, double *az) {{
  /* one RK4 step of the states, stage by stage (stage_f), s = [z; k] */
  const double t = t0 + s[{n}] * h, half = h / 2.0, sixth = h / 6.0;
  BD_ROLLED for (int i = 0; i < {n}; i++) zs[i] = s[i];
  BD_ROLLED for (int q = 0; q < 4; q++) {{
    const double tq = q == 0 ? t : q < 3 ? t + half : t + h;
    bd_trig(cs, &tq, p, ang);
    stage_f(&tq, zs, p, zs, d, cs, f);
    if (q == 0) {{ BD_ROLLED for (int i = 0; i < {n}; i++) az[i] = f[i]; }}
    else if (q < 3) {{ BD_ROLLED for (int i = 0; i < {n}; i++) az[i] += 2.0 * f[i]; }}
    if (q < 3) {{
      const double a = q < 2 ? half : h;
      BD_ROLLED for (int i = 0; i < {n}; i++) zs[i] = s[i] + a * f[i];
    }} else {{
      BD_ROLLED for (int i = 0; i < {n}; i++) s[i] += sixth * (az[i] + f[i]);
    }}
  }}
  s[{n}] += 1.0;
}}
"""
"""The CUDA build's RK4 step stage by stage (rhs only): the steps of a model whose fused
step holds too many live values for the GPU's registers (``FUSED_WORK_MAX``)."""

_CUDA_TANGENT_STEP = """
BD_FN void bd_rk4_tangent(double *s, double *v, const double *p, double h, double t0,
                          const double *d, double *ang, double *cs, double *zs, double *vs,
                          double *f, double *jv, double *az, double *av) {{
  /* one RK4 step of the states and the tangent, stage by stage: _TANGENT_BODY's sums */
  const double t = t0 + s[{n}] * h, half = h / 2.0, sixth = h / 6.0;
  BD_ROLLED for (int i = 0; i < {n}; i++) {{ zs[i] = s[i]; vs[i] = v[i]; }}
  BD_ROLLED for (int q = 0; q < 4; q++) {{
    const double tq = q == 0 ? t : q < 3 ? t + half : t + h;
    bd_trig(cs, &tq, p, ang);
    {stage_call}
    if (q == 0) {{ BD_ROLLED for (int i = 0; i < {n}; i++) {{ az[i] = f[i]; av[i] = jv[i]; }} }}
    else if (q < 3) {{
      BD_ROLLED for (int i = 0; i < {n}; i++) {{ az[i] += 2.0 * f[i]; av[i] += 2.0 * jv[i]; }}
    }}
    if (q < 3) {{
      const double a = q < 2 ? half : h;
      BD_ROLLED for (int i = 0; i < {n}; i++) {{
        zs[i] = s[i] + a * f[i]; vs[i] = v[i] + a * jv[i];
      }}
    }} else {{
      BD_ROLLED for (int i = 0; i < {n}; i++) {{
        s[i] += sixth * (az[i] + f[i]); v[i] += sixth * (av[i] + jv[i]);
      }}
    }}
  }}
  s[{n}] += 1.0;
}}
"""
"""The CUDA build's step of the states and the tangent (``_CUDA_TANGENT_BODY``); the stage
is one call of ``stage``, or ``stage_f`` then ``stage_jv`` when the fused stage holds too
many live values (``STAGE_WORK_MAX``)."""

_ROTATE = """
BD_FN void bd_trig(double *cs, const double *t, const double *p, double *ang) {{
  /* [cos, sin] of every forcing angle a_k at time t */
  stage_angles(t, p, ang);
  for (int k = 0; k < {na}; k++) {{ cs[2 * k] = cos(ang[k]); cs[2 * k + 1] = sin(ang[k]); }}
}}
{rotate}"""


def _rotate_c(kind: str, name: str, what: str) -> str:
    """The C of ``name``: [cos, sin] of every forcing angle turned by a rotation, on values
    of type ``kind`` (``double``, or ``bd_vd``: the lanes), as a template of ``{{na}}``."""
    pad = " " * (len(kind) + 11)
    return (f"BD_FN void {name}({kind} *cs, const {kind} *cs0, const {kind} *rot, int j) {{{{\n"
            f"  /* {what} */\n"
            f"  for (int k = 0; k < {{na}}; k++) {{{{\n"
            f"    const {kind} c = cs0[2 * k], sn = cs0[2 * k + 1], rc = rot[4 * k + j],\n"
            f"{pad}rs = rot[4 * k + j + 1];\n"
            f"    cs[2 * k] = c * rc - sn * rs; cs[2 * k + 1] = sn * rc + c * rs;\n"
            f"  }}}}\n}}}}\n")


_ROTATE = _ROTATE.replace("{rotate}", _rotate_c(
    "double", "bd_rotate", "[cos, sin] of every forcing angle a_k turned by the rotation j "
    "(0: ω_k h/2, 2: ω_k h)"))

_MEMBER_TAIL = """
  diverged[m] = bad < 0 ? -1 : (bd_long)k0[m] + bad;
  for (bd_long q = sec < ns ? sec : ns; q < kmax; q++) {{
    if (keep) BD_ROLLED for (int i = 0; i < {n}; i++) sections[(m * kmax + q) * {n} + i] = NAN;
    {nan_log}
  }}
  BD_ROLLED for (int i = 0; i < {n}; i++) final[m * {n} + i] = s[i];
#ifndef __CUDACC__
  for (int i = 0; i < {n}; i++) {{ low[m * {n} + i] = lo[i]; high[m * {n} + i] = hi[i]; }}
#endif
}}
"""

_CPU_WRAPPER = """
void bd_members_{variant}(bd_long count, int threads, {args_nom}) {{
  if (threads <= 0) threads = 1;
  #pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (bd_long m = 0; m < count; m++) bd_member_{variant}({call});
}}
"""

_LANES_ROTATE = "\n" + _rotate_c("bd_vd", "bd_rotate_lanes", "bd_rotate on the lanes")

_LANES_BLOCK = """
typedef struct {{
  /* the members of a block of lanes: lane l is member m0 + l (spare lanes repeat the last
     member and write nothing) */
  double s[BD_LANES][{ns}], lo[BD_LANES][{n}], hi[BD_LANES][{n}], lim[BD_LANES];
  const double *p[BD_LANES];
  bd_long step[BD_LANES], bad[BD_LANES], sec[BD_LANES], left[BD_LANES], tr[BD_LANES],
          ev[BD_LANES], nsec[BD_LANES], from[BD_LANES], upto[BD_LANES], end[BD_LANES];
  int on[BD_LANES], lanes;
  bd_vd sv[{ns}], nx[{ns}], pv[{npar}], cv[{nc}], hv, t0v;
}} bd_block;

BD_FN void bd_block_start(bd_block *B, bd_long m0, bd_long count, {args_nom}) {{
  /* _MEMBER_HEAD's start of every lane */
  double c[{nc}] = {{0.0}};
  B->lanes = count - m0 < BD_LANES ? (int)(count - m0) : BD_LANES;
  for (int l = 0; l < BD_LANES; l++) {{
    const bd_long m = m0 + (l < B->lanes ? l : B->lanes - 1);
    const double *pm = p + m * {npar};
    const double hm = h[m], t0m = t0[m];
    double *sl = B->s[l];
    B->p[l] = pm; B->lim[l] = limit[m];
    for (int i = 0; i < {n}; i++) {{
      sl[i] = z0[m * {n} + i]; B->lo[l][i] = INFINITY; B->hi[l][i] = -INFINITY;
    }}
    sl[{n}] = k0[m];
    rk4_constants(pm, &hm, &t0m, c);
    B->tr[l] = transient[m]; B->ev[l] = every[m]; B->nsec[l] = n_sec[m];
    B->from[l] = ext_from[m]; B->upto[l] = ext_to[m];
    const bd_long total = B->tr[l] + B->ev[l] * B->nsec[l];
    B->end[l] = total > B->upto[l] ? total : B->upto[l];
    B->step[l] = 0; B->bad[l] = -1; B->sec[l] = 0; B->left[l] = B->ev[l];
    if (B->from[l] <= 0 && B->upto[l] >= 0) bd_extend(B->lo[l], B->hi[l], sl);
    for (int i = 0; i < {ns}; i++) B->sv[i][l] = sl[i];
    for (int i = 0; i < {npar}; i++) B->pv[i][l] = pm[i];
    for (int i = 0; i < {nc}; i++) B->cv[i][l] = c[i];
    B->hv[l] = hm; B->t0v[l] = t0m;
  }}
}}

BD_FN void bd_block_steps(bd_block *B, int transient_only, bd_long m0, bd_long kmax,
                          int keep, double *sections) {{
  /* the state steps of every lane at once (rk4_lanes), each lane's bookkeeping as the
     member loop's: its transient (transient_only: then stop), then its sections */
  for (int l = 0; l < BD_LANES; l++)
    B->on[l] = l < B->lanes && (transient_only ? B->tr[l] : B->end[l]) > 0;
  for (;;) {{
    int any = 0;
    for (int l = 0; l < BD_LANES; l++) any |= B->on[l];
    if (!any) break;
    rk4_lanes(B->sv, B->pv, &B->hv, &B->t0v, B->cv, B->nx);
    for (int i = 0; i < {ns}; i++) B->sv[i] = B->nx[i];
    for (int l = 0; l < BD_LANES; l++) {{
      if (!B->on[l]) continue;
      double *sl = B->s[l];
      const bd_long st = ++B->step[l];
      for (int i = 0; i < {ns}; i++) sl[i] = B->sv[i][l];
      if (bd_bad(sl, B->lim[l])) {{ B->bad[l] = st; B->on[l] = 0; continue; }}
      if (st >= B->from[l] && st <= B->upto[l]) bd_extend(B->lo[l], B->hi[l], sl);
      if (st > B->tr[l] && --B->left[l] == 0) {{
        if (keep && B->sec[l] < B->nsec[l])
          for (int i = 0; i < {n}; i++)
            sections[((m0 + l) * kmax + B->sec[l]) * {n} + i] = sl[i];
        B->sec[l]++; B->left[l] = B->ev[l];
      }}
      if (st >= (transient_only ? B->tr[l] : B->end[l])) B->on[l] = 0;
    }}
  }}
}}

BD_FN void bd_block_end(bd_block *B, bd_long m0, const double *k0, bd_long kmax, int keep,
                        double *sections, double *logs, double *final, bd_long *diverged,
                        double *low, double *high) {{
  /* _MEMBER_TAIL of every lane (logs: the tangent variant's, else NULL) */
  for (int l = 0; l < B->lanes; l++) {{
    const bd_long m = m0 + l;
    diverged[m] = B->bad[l] < 0 ? -1 : (bd_long)k0[m] + B->bad[l];
    for (bd_long q = B->sec[l] < B->nsec[l] ? B->sec[l] : B->nsec[l]; q < kmax; q++) {{
      if (keep) for (int i = 0; i < {n}; i++) sections[(m * kmax + q) * {n} + i] = NAN;
      if (logs) logs[m * kmax + q] = NAN;
    }}
    for (int i = 0; i < {n}; i++) {{
      final[m * {n} + i] = B->s[l][i]; low[m * {n} + i] = B->lo[l][i];
      high[m * {n} + i] = B->hi[l][i];
    }}
  }}
}}

BD_FN void bd_lanes_states(bd_long m0, bd_long count, {args_nom}) {{
  /* bd_member_states of the members m0 … m0 + BD_LANES - 1 below count */
  bd_block B;
  bd_block_start(&B, m0, count, {call_nom});
  bd_block_steps(&B, 0, m0, kmax, keep, sections);
  bd_block_end(&B, m0, k0, kmax, keep, sections, NULL, final, diverged, low, high);
}}
"""
"""The CPU build's member loop on ``BD_LANES`` members at once (``bd_block``): the state
steps of all the lanes in one call of the step written on lanes (``rk4_lanes``), each
lane's bookkeeping (blow-up, extremes, sections) as ``_MEMBER_HEAD``, ``_STATE_BODY`` and
``_MEMBER_TAIL`` do it; the same operations, so the same results bit for bit. A lane that
is done is still stepped (its values unused) until every lane is."""

_LANES_TANGENT = """
BD_FN void bd_lanes_tangent(bd_long m0, bd_long count, {args_nom}) {{
  /* bd_member_tangent of the members m0 … m0 + BD_LANES - 1 below count: the transients
     on lanes (bd_block_steps), then the tangent steps of _TANGENT_BODY on lanes
     (stage_lanes) */
  bd_block B;
  double d[{nd}] = {{0.0}}, rot[{nr}] = {{0.0}}, ang[{na1}], cs0[{ncs}] = {{0.0}};
  bd_vd z[{n}], v[{n}], zs[{n}], vs[{n}], f[{n}], jv[{n}], az[{n}], av[{n}];
  bd_vd dv[{nd}], rotv[{nr}], csv0[{ncs}], csv[{ncs}], kv;
  bd_block_start(&B, m0, count, {call_nom});
  bd_block_steps(&B, 1, m0, kmax, keep, sections);
  const bd_vd hv = B.hv, t0v = B.t0v, half = hv / 2.0, sixth = hv / 6.0;
  for (int l = 0; l < BD_LANES; l++) {{
    const double *sl = B.s[l];
    B.on[l] = l < B.lanes && B.bad[l] < 0 && B.step[l] < B.end[l];
    stage_constants(B.p[l], d);
    stage_rotations(B.p[l], &B.hv[l], rot);
    for (int i = 0; i < {n}; i++) {{ z[i][l] = sl[i]; v[i][l] = i == 0 ? 1.0 : 0.0; }}
    for (int i = 0; i < {nd}; i++) dv[i][l] = d[i];
    for (int i = 0; i < {nr}; i++) rotv[i][l] = rot[i];
    kv[l] = sl[{n}];
  }}
  for (;;) {{
    int any = 0;
    for (int l = 0; l < BD_LANES; l++) any |= B.on[l];
    if (!any) break;
    const bd_vd t = t0v + kv * hv, th = t + half, tf = t + hv;
    for (int l = 0; l < BD_LANES; l++) {{
      const double tl = t[l];
      bd_trig(cs0, &tl, B.p[l], ang);
      for (int k = 0; k < {ncs}; k++) csv0[k][l] = cs0[k];
    }}
    stage_lanes(&t, z, B.pv, v, dv, csv0, f, jv);
    for (int i = 0; i < {n}; i++) {{
      az[i] = f[i]; av[i] = jv[i];
      zs[i] = z[i] + half * f[i]; vs[i] = v[i] + half * jv[i];
    }}
    bd_rotate_lanes(csv, csv0, rotv, 0);  /* the angles at t + h/2 */
    stage_lanes(&th, zs, B.pv, vs, dv, csv, f, jv);
    for (int i = 0; i < {n}; i++) {{
      az[i] += 2.0 * f[i]; av[i] += 2.0 * jv[i];
      zs[i] = z[i] + half * f[i]; vs[i] = v[i] + half * jv[i];
    }}
    stage_lanes(&th, zs, B.pv, vs, dv, csv, f, jv);
    for (int i = 0; i < {n}; i++) {{
      az[i] += 2.0 * f[i]; av[i] += 2.0 * jv[i];
      zs[i] = z[i] + hv * f[i]; vs[i] = v[i] + hv * jv[i];
    }}
    bd_rotate_lanes(csv, csv0, rotv, 2);  /* the angles at t + h */
    stage_lanes(&tf, zs, B.pv, vs, dv, csv, f, jv);
    for (int i = 0; i < {n}; i++) {{
      z[i] += sixth * (az[i] + f[i]); v[i] += sixth * (av[i] + jv[i]);
    }}
    kv += 1.0;
    for (int l = 0; l < BD_LANES; l++) {{
      if (!B.on[l]) continue;
      const bd_long m = m0 + l;
      double *sl = B.s[l];
      for (int i = 0; i < {n}; i++) sl[i] = z[i][l];
      sl[{n}] = kv[l];
      const bd_long st = ++B.step[l];
      if (bd_bad(sl, B.lim[l])) {{ B.bad[l] = st; B.on[l] = 0; continue; }}
      if (st >= B.from[l] && st <= B.upto[l]) bd_extend(B.lo[l], B.hi[l], sl);
      if (--B.left[l] == 0 && B.sec[l] < B.nsec[l]) {{
        const bd_long q = B.sec[l];
        double norm = 0.0;
        for (int i = 0; i < {n}; i++) norm += v[i][l] * v[i][l];
        norm = sqrt(norm);
        for (int i = 0; i < {n}; i++) v[i][l] /= norm;
        logs[m * kmax + q] = log(norm);
        if (keep) for (int i = 0; i < {n}; i++) sections[(m * kmax + q) * {n} + i] = sl[i];
        B.sec[l]++; B.left[l] = B.ev[l];
      }}
      if (st >= B.end[l]) B.on[l] = 0;
    }}
  }}
  bd_block_end(&B, m0, k0, kmax, keep, sections, logs, final, diverged, low, high);
}}
"""
"""The CPU build's tangent variant on ``BD_LANES`` members at once: ``_TANGENT_BODY`` and
its bookkeeping lane by lane after the transients (``_LANES_BLOCK``), the same operations,
so the same results bit for bit."""

LANE_GAIN = 2
"""How many times faster a member's step runs in a block of lanes than alone, at least
(``benchmarks/bench_lanes.py``): the wrapper runs blocks
of lanes only when the busiest thread's blocks (of ``BD_LANES`` steps each, spare lanes
included) take at most ``LANE_GAIN`` times its members' steps; few members on many cores
run member by member."""

_LANES_WRAPPER = """
static void bd_lanes_run(int path, bd_long count, int threads, {args_nom}) {{
  /* path 0: blocks of lanes when they pay (LANE_GAIN), 1: blocks, 2: member by member */
  if (threads <= 0) threads = 1;
  const bd_long blocks = (count + BD_LANES - 1) / BD_LANES;
  const bd_long per = (count + threads - 1) / threads;
  const bd_long bper = (blocks + threads - 1) / threads;
  if (path == 1 || (path == 0 && bper * BD_LANES <= {gain} * per)) {{
    #pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (bd_long b = 0; b < blocks; b++) bd_lanes_{variant}(b * BD_LANES, count, {call_nom});
  }} else {{
    #pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (bd_long m = 0; m < count; m++) bd_member_{variant}({call});
  }}
}}
void bd_members_{variant}(bd_long count, int threads, {args_nom}) {{
  bd_lanes_run(0, count, threads, {call_nom});
}}
void bd_members_{variant}_lanes(bd_long count, int threads, {args_nom}) {{
  bd_lanes_run(1, count, threads, {call_nom});
}}
void bd_members_{variant}_single(bd_long count, int threads, {args_nom}) {{
  bd_lanes_run(2, count, threads, {call_nom});
}}
"""
"""The wrappers of a build with lanes: ``bd_members_<variant>`` chooses (the symbol every
build has), ``_lanes`` and ``_single`` force a path (self-test, tests)."""


_CUDA_WRAPPER = """
BD_GLOBAL void bd_members_{variant}(bd_long count, {args_nom}) {{
  bd_long m = (bd_long)blockIdx.x * blockDim.x + threadIdx.x;
  if (m < count) bd_member_{variant}({call});
}}
"""


def _args_without_m() -> str:
    return _ARGS.split(",", 1)[1].strip()


FUSED_WORK_MAX = 120
"""Most live work values (``Function.sz_w``) of the fused RK4 step that the CUDA build runs
as written; a model beyond it (the eight-state rotor-housing defects and two-bearing-rotor:
135-201) steps stage by stage on a GPU (``bd_rk4``): beyond it ptxas spills registers
(``benchmarks/ptxas_table.py``)."""
STAGE_WORK_MAX = 100
"""Most live work values of the tangent's fused stage (rhs and Jv) that the CUDA build calls
as one function; beyond it (two-bearing-rotor: 133, vakharia2015-two-contact: 274) it calls
``stage_f`` then ``stage_jv`` (a function call, not inlined: 40-86 each, the rhs computed
twice)."""


def member_source(step: ca.Function, constants: ca.Function, n: int,
                  pairs: Sequence[tuple[int, int | None]], stage: Stage | None = None, *,
                  target: str = "cpu", tangent: bool | None = None, lanes: int = 0) -> str:
    """The whole C text of one model and balls: the prelude, the written Functions
    (``rk4_steps1`` and ``rk4_constants``; with ``stage``, the tangent's ``stage``,
    ``stage_constants``, ``stage_angles`` and ``stage_rotations``), ``bd_bad``, the member
    function ``bd_member_states`` or ``bd_member_tangent`` (``tangent``; None: whether a
    ``stage`` is given) and its wrapper for ``target`` (``"cpu"``: an OpenMP loop
    ``bd_members_<variant>(count, threads, …)``; ``"cuda"``: a ``__global__`` kernel, one
    member per thread).

    The CUDA text computes what the CPU text computes with fewer live values (no spills,
    ``benchmarks/ptxas_table.py``): its loops over the states are not unrolled
    (``BD_ROLLED``: the member's arrays stay in local memory, read once per stage), the
    tangent's four stages run in a loop with one inlined stage (``bd_rk4_tangent``, the
    sin and cos at each stage time), and a model whose fused step or stage is too large
    (``FUSED_WORK_MAX``, ``STAGE_WORK_MAX``; needs ``stage``) steps stage by stage (its
    states then differ from the CPU build's by rounding).

    ``lanes`` > 0 (CPU only): the text also runs the steps of ``lanes`` members at once
    (``#define BD_LANES``, ``lanes_c``, ``_LANES_BLOCK``, ``_LANES_TANGENT``; vectors of
    that many doubles: 4 for AVX2, 8 for AVX-512, ``cpu.host_lanes``), with the same
    results bit for bit; ``bd_members_<variant>`` chooses blocks of lanes or single
    members (``LANE_GAIN``), ``bd_members_<variant>_lanes`` and ``_single`` force one."""
    tangent = stage is not None if tangent is None else tangent
    if lanes < 0 or (lanes and target != "cpu"):
        raise ValueError(f"lanes: 0, or > 0 for the CPU build, got {lanes}")
    if tangent and stage is None:
        raise ValueError("the tangent variant needs its stage")
    variant = "tangent" if tangent else "states"
    cuda = target == "cuda"
    ns, nc = step.size1_in(0), max(step.size1_in(4), 1)
    parts = [PRELUDE, *((f"#define BD_LANES {lanes}", VECTOR_PRELUDE) if lanes else ()),
             scalar_c(constants, "rk4_constants"), scalar_c(step, "rk4_steps1"),
             *((lanes_c(step, "rk4_lanes"),) if lanes else ()), blow_up_c(n, pairs)]
    npar = step.size1_in(1)
    staged = cuda and stage is not None and step.sz_w() > FUSED_WORK_MAX
    advance = ("    bd_rk4(s, pm, hm, t0m, d, ang, cs, zs, f, az);" if staged else
               f"    rk4_steps1(s, pm, &hm, &t0m, c, nx);\n"
               f"    BD_ROLLED for (int i = 0; i < {ns}; i++) s[i] = nx[i];")
    body, setup = _STATE_BODY.format(n=n, advance=advance), ""
    if stage is not None:
        na = stage.n_angles
        sizes = dict(n=n, nd=max(stage.stage.size1_in(4), 1), na=na, na1=max(na, 1),
                     nr=max(4 * na, 1), ncs=max(2 * na, 1))
        parts += [scalar_c(stage.constants, "stage_constants"),
                  scalar_c(stage.angles, "stage_angles"),
                  scalar_c(stage.rotations, "stage_rotations"), scalar_c(stage.stage, "stage")]
        parts.append(_ROTATE.format(na=na))  # after stage_angles: bd_trig calls it
        if lanes:
            parts += [lanes_c(stage.stage, "stage_lanes"), _LANES_ROTATE.format(na=na)]
        if cuda:
            split = stage.stage.sz_w() > STAGE_WORK_MAX
            parts += [scalar_c(stage.rhs, "stage_f"), _CUDA_STAGED.format(n=n)]
            if split:
                # not inlined: else the compiler merges its rhs with stage_f's (spills)
                parts.append(scalar_c(stage.product, "stage_jv", "BD_NOINLINE"))
            call = ("stage_f(&tq, zs, p, vs, d, cs, f); stage_jv(&tq, zs, p, vs, d, cs, jv);"
                    if split else "stage(&tq, zs, p, vs, d, cs, f, jv);")
            parts.append(_CUDA_TANGENT_STEP.format(n=n, stage_call=call))
            setup = ("\n  double d[{nd}], ang[{na1}], cs[{ncs}], zs[{n}], f[{n}], az[{n}];"
                     "\n  stage_constants(pm, d);").format(**sizes)
        if tangent:
            body = (_CUDA_TANGENT_BODY if cuda else _TANGENT_BODY).format(**sizes)
    parts.append(_MEMBER_HEAD.format(variant=variant, args=_ARGS, ns=ns, nc=nc, n=n,
                                     npar=npar, stage_setup=setup, advance=advance) + body
                 + _MEMBER_TAIL.format(n=n, nan_log="logs[m * kmax + q] = NAN;"
                                       if tangent else ""))
    wrapper = _CPU_WRAPPER if target == "cpu" else _CUDA_WRAPPER
    if lanes:
        block = dict(args_nom=_args_without_m(), call_nom=_CALL.split(", ", 1)[1], ns=ns,
                     nc=nc, npar=npar, n=n)
        parts.append(_LANES_BLOCK.format(**block))
        if tangent:
            parts.append(_LANES_TANGENT.format(**{**block, **sizes}))
        wrapper = _LANES_WRAPPER
    parts.append(wrapper.format(variant=variant, args_nom=_args_without_m(), call=_CALL,
                                call_nom=_CALL.split(", ", 1)[1], gain=LANE_GAIN))
    return "\n".join(parts)


def state_functions(model: object, structure: tuple[int, ...]) -> tuple[ca.Function,
                                                                         ca.Function]:
    """The RK4 step of the compiled blocks (``compiled.rk4_blocks``) and its constants:
    ``rk4_steps1(s, p, h, t0, c) -> s'`` with ``s = [z; k]``, ``rk4_constants(p, h, t0)``
    (the same memoised Functions, so the same operations)."""
    from analysis.integrate.tangent import Carry, tangent_step

    return tuple(tangent_step(model.functions(structure).rk4_step,  # type: ignore[attr-defined]
                              Carry(constants=True), "rk4_steps1", "rk4_constants"))


class Stage(NamedTuple):
    """The tangent variant's stage and its helpers (``stage_functions``)."""

    stage: ca.Function
    """``stage(t, z, p, v, d, cs) -> (f, Jv)``."""
    constants: ca.Function
    """``stage_constants(p) -> d``: the subexpressions of p alone."""
    angles: ca.Function
    """``stage_angles(t, p) -> a``: the forcing angles a_k = ω_k·t (rad)."""
    rotations: ca.Function
    """``stage_rotations(p, h) -> [cos ω_k h/2, sin ω_k h/2, cos ω_k h, sin ω_k h]_k``."""
    n_angles: int
    rhs: ca.Function | None = None
    """``stage_f(t, z, p, v, d, cs) -> f``: the stage's f alone (the same operations)."""
    product: ca.Function | None = None
    """``stage_jv(t, z, p, v, d, cs) -> Jv``: the stage's Jv alone."""


def _forcing_angle(angle: ca.SX, t: ca.SX, others: Sequence[ca.SX]) -> bool:
    """Whether ``angle`` is ω·t: it depends on t and on none of ``others``, its slope in t
    does not depend on t, and it is 0 at t = 0."""
    if not ca.depends_on(angle, t) or any(ca.depends_on(angle, x) for x in others):
        return False
    if ca.depends_on(ca.jacobian(angle, t), t):
        return False
    return ca.substitute(angle, t, ca.SX(0)).is_zero()


def stage_functions(model: object, structure: tuple[int, ...]) -> Stage:
    """The tangent variant's stage: the model's rhs f(t, z) (SI units per s) and its
    Jacobian–vector product J(t, z)·v (``casadi.jtimes``, the Jacobian never formed), with
    the subexpressions of p alone as the input d, and every sin and cos of a forcing angle
    a_k = ω_k·t (each bearing's cage angle, the shaft angle) as an input ``cs = [cos a_k,
    sin a_k]_k``: the member loop takes one sin/cos pair per angle and step and reaches the
    later stages' angles by rotation (as the runtime's ``rk4_step`` does for the cages), not
    four pairs per step. The derivative is taken before the substitution (exact); the
    substitution changes f and Jv by rounding only."""
    rhs = model.functions(structure).rhs  # type: ignore[attr-defined]
    n, n_par = rhs.size1_in(1), rhs.size1_in(2)
    t, z, p, v = ca.SX.sym("t"), ca.SX.sym("z", n), ca.SX.sym("p", n_par), ca.SX.sym("v", n)
    f = rhs(t, z, p)
    raw = ca.Function("raw", [t, z, p, v], [ca.cse(ca.vertcat(f, ca.jtimes(f, z, v)))])
    inputs = [t, z, p, v]
    work: list = [None] * raw.sz_w()
    out = ca.SX.zeros(raw.sparsity_out(0))
    angles: list[ca.SX] = []
    symbols: list[tuple[ca.SX, ca.SX]] = []
    keys: dict[str, int] = {}
    for i in range(raw.n_instructions()):
        op, o, arg = raw.instruction_id(i), raw.instruction_output(i), raw.instruction_input(i)
        if op == ca.OP_INPUT:
            work[o[0]] = inputs[arg[0]].nz[arg[1]]
        elif op == ca.OP_OUTPUT:
            out.nz[o[1]] = work[arg[0]]
        elif op == ca.OP_CONST:
            work[o[0]] = ca.SX(raw.instruction_constant(i))
        elif op in (ca.OP_SIN, ca.OP_COS) and _forcing_angle(work[arg[0]], t, (z, v)):
            key = str(work[arg[0]])
            if key not in keys:
                keys[key] = len(angles)
                angles.append(work[arg[0]])
                k = len(symbols)
                symbols.append((ca.SX.sym(f"c{k}"), ca.SX.sym(f"s{k}")))
            c, sn = symbols[keys[key]]
            work[o[0]] = c if op == ca.OP_COS else sn
        elif len(arg) == 1:
            work[o[0]] = ca.SX.unary(op, work[arg[0]])
        else:
            work[o[0]] = ca.SX.binary(op, work[arg[0]], work[arg[1]])
    cs = ca.vertcat(*(x for pair in symbols for x in pair)) if symbols else ca.SX(0, 1)
    fused, extracted, values = ca.extract_parametric(ca.cse(out), p)
    d = ca.vertcat(*extracted) if extracted else ca.SX(0, 1)
    stage = ca.Function("stage", [t, z, p, v, d, cs], [fused[:n], fused[n:]])
    h = ca.SX.sym("h")
    rotations = []
    for angle in angles:
        omega = ca.jacobian(angle, t)
        rotations += [ca.cos(omega * (h / 2)), ca.sin(omega * (h / 2)), ca.cos(omega * h),
                      ca.sin(omega * h)]
    return Stage(stage,
                 ca.Function("stage_constants", [p],
                             [ca.vertcat(*values) if values else ca.SX(0, 1)]),
                 ca.Function("stage_angles", [t, p],
                             [ca.vertcat(*angles) if angles else ca.SX(0, 1)]),
                 ca.Function("stage_rotations", [p, h],
                             [ca.vertcat(*rotations) if rotations else ca.SX(0, 1)]),
                 len(angles),
                 ca.Function("stage_f", [t, z, p, v, d, cs], [fused[:n]]),
                 ca.Function("stage_jv", [t, z, p, v, d, cs], [fused[n:]]))


def model_source(model: object, structure: tuple[int, ...], tangent: bool,
                 target: str = "cpu", lanes: int = 0) -> str:
    """The member C of ``model`` with these balls (``member_source``): the state variant,
    or with ``tangent`` the tangent variant, for ``target`` ``"cpu"`` or ``"cuda"`` (whose
    state variant takes the stage functions too when its fused step is large); ``lanes``:
    the CPU build's members per block of lanes (0: none)."""
    step, constants = state_functions(model, structure)
    staged = target == "cuda" and step.sz_w() > FUSED_WORK_MAX
    stage = stage_functions(model, structure) if tangent or staged else None
    return member_source(step, constants, model.n_state,  # type: ignore[attr-defined]
                         model.centre_indices(), stage, target=target,  # type: ignore
                         tangent=tangent, lanes=lanes)
