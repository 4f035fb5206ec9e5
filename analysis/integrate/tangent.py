"""RK4 steps that carry derivatives, built once: states, tangents, parameter sensitivities.

Every fixed-step integration of the package is a chain of one model's ``rk4_step`` (the
runtime's classical RK4 step, ``rk4_step(t, z, p, h)``) on a carried vector
``s = [z; k; extras]``: the state z (SI units) after step k, whose time is ``t0 + k·h`` (s),
so the states are those of ``simulate`` bit for bit whichever blocks cover a run. What
rides along is described by ``Carry``:

- ``directions`` tangent vectors Q (n × r), moved by the exact derivative of the step
  (CasADi AD): ``jtimes`` (forward mode, the Jacobian never formed: Lyapunov exponents,
  the chart, the curves' bilinear forms) or ``jacobian`` (Q' = (∂z'/∂z)·Q: the flow map's
  monodromy matrix);
- ``parameters``: D = dz/dp (n × n_par) with the step's own dependence on p through the
  input ``g = dh/dp`` (1 × n_par): D' = A·D + ∂z'/∂p + ∂z'/∂h·g (flow maps);
- ``constants``: the subexpressions that depend on p, h and t0 only (cage speed, the cage
  rotations by ω_cage·h/2 and ω_cage·h, …) become an input ``c``, computed once per call by
  a second Function (``casadi.extract_parametric``): the same operations, so the same
  values, and a step that repeats none of them.

``tangent_step`` builds that SX step; ``block_tree`` chains it into blocks of ten calls of
the next smaller size (one step in the C code, however many a block runs), and
``chain_blocks`` covers any number of steps with such blocks;
``tangent_block`` renormalises r tangent vectors by QR every ``renorm_every`` steps
(``qr_logs``). Every builder is
memoised per process, so one model, structure and set of options yields one Function
object, hence one compiled library (``analysis.integrate.compiled``).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache
from typing import Any, NamedTuple

import casadi as ca

PRODUCTS = ("jtimes", "jacobian")


def model_tag(model: Any, structure: Sequence[int]) -> str:
    """``<model>_nb<balls>`` as a C identifier (``vakharia2015_nb8``, ``two_bearing_rotor_nb8_9``,
    ``duffing_nb0``): names the Functions of a model and its balls, so their libraries
    (``compiled.library_stem``)."""
    balls = "_".join(str(b) for b in structure) or "0"
    return re.sub(r"\W", "_", f"{model.name}_nb{balls}")


@dataclass(frozen=True)
class Carry:
    """What an RK4 step carries besides the state z and its step counter k."""

    directions: int = 0
    """Tangent vectors Q (n × directions), ``vec(Q)`` after ``[z; k]``."""
    product: str = "jtimes"
    """How Q moves: ``"jtimes"`` (forward AD, ``jtimes(z', z, Q)``) or ``"jacobian"``
    (``jacobian(z', z)·Q``)."""
    parameters: bool = False
    """Also ``vec(D)``, D = dz/dp (n × n_par), after Q; the step takes ``g = dh/dp``."""
    constants: bool = False
    """The parameter-only subexpressions as a last input ``c`` (see ``Step.constants``)."""
    angle_addition: bool = False
    """The forcing angles of the step's later stages by angle addition (``angle_addition``):
    two sin/cos pairs fewer per step for a rotor's shaft angle, the states changed by
    rounding. The chart's tangent (``analysis.sweeps.points``) takes it."""

    def __post_init__(self) -> None:
        if self.product not in PRODUCTS:
            raise ValueError(f"product: one of {', '.join(PRODUCTS)}, got {self.product!r}")


class Step(NamedTuple):
    """One RK4 step carrying derivatives: ``step(s, p, h, t0[, g][, c]) -> s'`` and, with
    ``Carry.constants``, ``constants(p, h, t0) -> c`` (else None)."""

    step: ca.Function
    constants: ca.Function | None


def _shifted(angle: ca.SX, t: ca.SX, h: ca.SX) -> bool:
    """Whether ``angle`` is ω·(t + c·h): it depends on t and h, its slope in t on neither,
    and it is 0 at t = h = 0 (a forcing angle at a later stage of an RK4 step)."""
    if not (ca.depends_on(angle, t) and ca.depends_on(angle, h)):
        return False
    slope = ca.jacobian(angle, t)
    if ca.depends_on(slope, t) or ca.depends_on(slope, h):
        return False
    return ca.substitute(ca.substitute(angle, t, ca.SX(0)), h, ca.SX(0)).is_zero()


@cache
def angle_addition(rk4_step: ca.Function) -> ca.Function:
    """``rk4_step(t, z, p, h)`` with the forcing angles of its later stages by angle
    addition: every sin or cos of an angle a = ω·(t + c·h) (``_shifted``: the shaft angle
    at t + h/2 and t + h) becomes that of a(t, 0), the angle at the step's start, rotated
    by a(0, h), as the generated runtime already reaches the cage angle. The rotations
    depend on p and h only, so ``Carry.constants`` computes them once per call and a step
    takes one sin/cos pair per forcing frequency instead of three. Every other operation is
    ``rk4_step``'s, in its order (the Function is read instruction by instruction); the
    result differs from ``rk4_step``'s by rounding (a few 1e-16 of a step's increment)."""
    fn = rk4_step
    inputs = [ca.SX.sym(fn.name_in(i), fn.sparsity_in(i)) for i in range(fn.n_in())]
    t, h = inputs[0], inputs[3]
    work: list[Any] = [None] * fn.sz_w()
    outputs = [ca.SX.zeros(fn.sparsity_out(i)) for i in range(fn.n_out())]
    for i in range(fn.n_instructions()):
        op, out, arg = fn.instruction_id(i), fn.instruction_output(i), fn.instruction_input(i)
        if op == ca.OP_INPUT:
            work[out[0]] = inputs[arg[0]].nz[arg[1]]
        elif op == ca.OP_OUTPUT:
            outputs[out[0]].nz[out[1]] = work[arg[0]]
        elif op == ca.OP_CONST:
            work[out[0]] = ca.SX(fn.instruction_constant(i))
        elif op in (ca.OP_SIN, ca.OP_COS) and _shifted(work[arg[0]], t, h):
            angle = work[arg[0]]
            start, turn = ca.substitute(angle, h, ca.SX(0)), ca.substitute(angle, t, ca.SX(0))
            c0, s0, ct, st = ca.cos(start), ca.sin(start), ca.cos(turn), ca.sin(turn)
            work[out[0]] = c0 * ct - s0 * st if op == ca.OP_COS else s0 * ct + c0 * st
        elif len(arg) == 1:
            work[out[0]] = ca.SX.unary(op, work[arg[0]])
        else:
            work[out[0]] = ca.SX.binary(op, work[arg[0]], work[arg[1]])
    return ca.Function(f"{fn.name()}_aa", inputs, [ca.cse(o) for o in outputs],
                       fn.name_in(), fn.name_out())


@cache
def tangent_step(rk4_step: ca.Function, carry: Carry, name: str,
                 constants_name: str | None = None,
                 names: tuple[tuple[str, ...], tuple[str, ...]] | None = None) -> Step:
    """The SX step of ``rk4_step`` (n states, n_par parameters) carrying ``carry``.

    ``s = [z; k; vec(Q); vec(D)]`` (the parts ``carry`` asks for): z after step k at time
    ``t0 + k·h`` (s), Q the tangent vectors, D = dz/dp; h the step (s). The Function is
    called ``name`` (its constants ``constants_name``), with input and output ``names``
    when given (they name the exported functions of a library). With
    ``carry.angle_addition`` the step is that of ``angle_addition(rk4_step)``."""
    if carry.angle_addition:
        rk4_step = angle_addition(rk4_step)
    n, n_par = rk4_step.size1_in(1), rk4_step.size1_in(2)
    z, k = ca.SX.sym("z", n), ca.SX.sym("k")
    p, h, t0 = ca.SX.sym("p", n_par), ca.SX.sym("h"), ca.SX.sym("t0")
    z_next = rk4_step(t0 + k * h, z, p, h)
    carried, moved, inputs = [z, k], [z_next, k + 1], [p, h, t0]
    a = None
    if carry.directions:
        q = ca.SX.sym("q", n, carry.directions)
        carried.append(ca.vec(q))
        if carry.product == "jtimes":
            moved.append(ca.vec(ca.jtimes(z_next, z, q)))
        else:
            a = ca.jacobian(z_next, z)
            moved.append(ca.vec(ca.mtimes(a, q)))
    if carry.parameters:
        d, g = ca.SX.sym("D", n, n_par), ca.SX.sym("g", 1, n_par)
        a = ca.jacobian(z_next, z) if a is None else a
        carried.append(ca.vec(d))
        moved.append(ca.vec(ca.mtimes(a, d) + ca.jacobian(z_next, p)
                            + ca.mtimes(ca.jacobian(z_next, h), g)))
        inputs.append(g)
    s, expr = ca.vertcat(*carried), ca.vertcat(*moved)
    extra = [] if names is None else list(names)
    if not carry.constants:
        return Step(ca.Function(name, [s, *inputs], [expr], *extra), None)
    step, extracted, values = ca.extract_parametric(expr, ca.vertcat(p, h, t0))
    c = ca.vertcat(*extracted)
    return Step(ca.Function(name, [s, *inputs, c], [step], *extra),
                ca.Function(constants_name or f"{name}_constants", [p, h, t0],
                            [ca.vertcat(*values)]))


def block_tree(step: ca.Function, sizes: Sequence[int], name: Callable[[int], str],
               keep_states: bool,
               names: tuple[tuple[str, ...], tuple[str, ...]] | None = None
               ) -> dict[int, ca.Function]:
    """Blocks of ``sizes`` calls of ``step`` (each size ten of the next smaller; the
    smallest is 1, ``step`` itself), as MX Functions ``name(size)`` of ``step``'s inputs.

    ``keep_states``: a block returns the carried vector after each of its steps (one column
    each), else only after its last. The first input is the carried vector, passed from one
    call to the next; the others are passed unchanged."""
    inner = {1: step}
    extra = [] if names is None else list(names)
    for size in sorted(sizes)[1:]:
        args = [ca.MX.sym(f"x{i}", step.sparsity_in(i)) for i in range(step.n_in())]
        parts, current = [], args[0]
        for _ in range(10):
            parts.append(inner[size // 10](current, *args[1:]))
            current = parts[-1][:, -1] if keep_states else parts[-1]
        inner[size] = ca.Function(name(size), args,
                                  [ca.horzcat(*parts) if keep_states else current], *extra)
    return {size: inner[size] for size in sizes}


def chain_blocks(blocks: dict[int, ca.Function], n_steps: int, first: ca.MX,
                 args: Sequence[ca.MX], keep_states: bool = False
                 ) -> tuple[ca.MX, list[ca.MX]]:
    """``n_steps`` steps of ``blocks`` (sizes largest first, each ten of the next; a
    block's first input is the carried vector, ``args`` the others) from ``first``: full
    blocks of the largest size, then the rest digit by digit, each run of equal blocks one
    CasADi loop (nothing unrolled).

    Returns the carried vector after the last step and, with ``keep_states``, the states of
    every run (blocks that return ``(last, states)``, chained by ``mapaccum``); without, the
    blocks return the carried vector alone, chained by ``fold``, and the list is empty."""
    current, left, kept = first, n_steps, []
    for size, fn in blocks.items():
        count, left = divmod(left, size)
        if count == 0:
            continue
        repeated = [ca.repmat(a, 1, count) for a in args]
        if keep_states:
            run = fn.mapaccum(count) if count > 1 else fn
            last, states = run(current, *repeated)
            kept.append(states)
            current = last[:, -1]
        else:
            run = fn.fold(count) if count > 1 else fn
            current = run(current, *repeated)
    return current, kept


@cache
def qr_logs(n: int, n_vectors: int) -> ca.Function:
    """Y (n × k) -> (Q with R's diagonal made positive, log|diag R|); SX, callable from MX:
    the renormalisation of Benettin's method."""
    y = ca.SX.sym("y", n, n_vectors)
    q, r = ca.qr(y)
    signs = ca.sign(ca.diag(r))  # keeps Q continuous from one block to the next
    return ca.Function("qr_logs", [y], [ca.mtimes(q, ca.diag(signs)),
                                        ca.log(ca.fabs(ca.diag(r)))])


def lyapunov_step(model: Any, structure: tuple[int, ...], n_vectors: int,
                  angle_addition: bool = False) -> Step:
    """``tangent_step`` of ``model`` with ``n_vectors`` tangent vectors moved by ``jtimes``
    and its parameter-only subexpressions as the input c:
    ``tangent_step(s, p, h, t0, c) -> s'`` with ``s = [z; k; vec(Q)]`` and
    ``tangent_constants(p, h, t0) -> c``; with ``angle_addition``, the step of
    ``Carry.angle_addition``."""
    return tangent_step(model.functions(structure).rk4_step,
                        Carry(directions=n_vectors, constants=True,
                              angle_addition=angle_addition), "tangent_step",
                        "tangent_constants")


def _renormalisation(model: Any, structure: tuple[int, ...], n_vectors: int,
                     renorm_every: int, with_states: bool,
                     angle_addition: bool = False) -> ca.Function:
    """``(s, p, h, t0, c) -> (s', log|diag R| (k), [Z])``: ``renorm_every`` steps of
    ``lyapunov_step``, then Q re-orthonormalised by QR; Z ((n + 1) × renorm_every) holds
    ``[z; k]`` after every step when ``with_states``."""
    step = lyapunov_step(model, structure, n_vectors, angle_addition).step
    n = model.n_state
    s, p, h, t0, c = (ca.MX.sym(name, step.sparsity_in(i))
                      for i, name in enumerate(("s", "p", "h", "t0", "c")))
    repeated = [ca.repmat(a, 1, renorm_every) for a in (p, h, t0, c)]
    if with_states:
        states = step.mapaccum(renorm_every)(s, *repeated)
        last, outputs = states[:, -1], [states[:n + 1, :]]
    else:
        last, outputs = step.fold(renorm_every)(s, *repeated), []
    q_new, logs = qr_logs(n, n_vectors)(ca.reshape(last[n + 1:], n, n_vectors))
    return ca.Function("renorm", [s, p, h, t0, c],
                       [ca.vertcat(last[:n + 1], ca.vec(q_new)), logs, *outputs])


@cache
def tangent_block(model: Any, structure: tuple[int, ...], n_vectors: int, renorm_every: int,
                  n_renorm: int, with_states: bool = False,
                  angle_addition: bool = False) -> ca.Function:
    """``(s, p, h, t0) -> (s', logs (k × n_renorm), [Z])``: ``n_renorm`` renormalisations
    of ``renorm_every`` steps each (see ``lyapunov_step`` for s, k = ``n_vectors``); Z
    ((n + 1) × renorm_every·n_renorm) holds ``[z; k]`` after every step when
    ``with_states``. The constants are computed once per call. ``angle_addition``: the
    step of ``Carry.angle_addition`` (the chart's)."""
    renorm = _renormalisation(model, structure, n_vectors, renorm_every, with_states,
                              angle_addition)
    constants = lyapunov_step(model, structure, n_vectors, angle_addition).constants
    s, p, h, t0 = (ca.MX.sym(name, renorm.sparsity_in(i))
                   for i, name in enumerate(("s", "p", "h", "t0")))
    args = [ca.repmat(a, 1, n_renorm) for a in (p, h, t0, constants(p, h, t0))]
    out = renorm.mapaccum(n_renorm)(s, *args)
    name = f"lyapunov_{model_tag(model, structure)}_k{n_vectors}_r{renorm_every}_n{n_renorm}"
    name += "_aa" if angle_addition else ""
    return ca.Function(name + ("_states" if with_states else ""), [s, p, h, t0],
                       [out[0][:, -1], *out[1:]])
