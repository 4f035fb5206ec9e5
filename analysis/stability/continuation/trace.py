"""The one engine: a branch of any family traced by guarded predictor–corrector steps.

``trace(problem, first, stop, options, hooks=…)`` steps from ``first`` (its tangent pointing
the way to go, its ``ds`` the first step) with ``step.step``; the step grows by 1.5 after a
corrector of at most three iterations and shrinks by 1.5 otherwise (within [ds_min,
ds_max]); a refused step is retried at half the step. It stops when the parameter leaves
the range between the first point and ``stop``, after ``max_points`` points, when even
``ds_min`` is refused, or when the ``accept`` hook refuses a converged point. The family
plugs in through ``Hooks``:

* ``accept(point) -> reason | None``: a point the family will not keep stops the branch
  (a circle's Fourier tail);
* ``found_between(prev, point) -> list | reason``: the special points located between two
  ends (default ``detect.special_between``: LP, PD, BP, NS; a curve's codimension-two
  points), or why the step is refused;
* ``after_accept(point)``: what follows an accepted point (a curve's borders);
* ``past_end(prev, point, found) -> (found, point)``: what is kept of the last step, which
  left the range (a curve solves its end on the bound).

The result is a ``Trace``: the points, the status (one of ``STATUS``'s texts), how it ended,
the steps refused by a guard and the predictor of the last step that failed; a family's
stop report is built from these fields (``stop_report``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from analysis.stability.continuation.detect import special_between
from analysis.stability.continuation.options import ContinuationOptions
from analysis.stability.continuation.problem import BranchProblem
from analysis.stability.continuation.step import NO_CONVERGENCE, step

Progress = Callable[[str], None] | None
"""Where progress lines go (None: nowhere)."""

STATUS = {
    "end": "reached the end of the range",
    "max_points": "stopped after max_points = {max_points}",
    "no_convergence": "step fell below ds_min = {ds_min:g} from {param} = {value:.8g} "
                      "(no convergence)",
    "refused": "refused every step down to ds_min = {ds_min:g} from {param} = {value:.8g} "
               "({reason}): possibly a jump to another branch",
    "accept": "stopped at {param} = {value:.8g}: {reason}",
}
"""The one set of status texts, by how a trace ended."""


@dataclass(frozen=True)
class Hooks:
    """The family's plug-ins of ``trace`` (each optional; see the module)."""

    accept: Callable[[Any], str | None] | None = None
    found_between: Callable[[Any, Any], list | str] | None = None
    after_accept: Callable[[Any], None] | None = None
    past_end: Callable[[Any, Any, list], tuple[list, Any]] | None = None


@dataclass
class Trace:
    """A traced branch: its ``points``, how it ended (``ended``: a key of ``STATUS``) and
    its ``status`` text, the ``reason`` of the last refusal, the steps ``refused`` by a
    guard (failed correctors not counted) and ``last_tried``, the scaled predictor of the
    last step that failed or was refused (None when none did)."""

    points: list
    ended: str = "end"
    status: str = STATUS["end"]
    reason: str = ""
    refused: int = 0
    last_tried: np.ndarray | None = field(default=None, repr=False)

    @property
    def failed(self) -> bool:
        """Whether it ended on a step refused or failed down to ds_min."""
        return self.ended in ("no_convergence", "refused")


def trace(problem: BranchProblem, first: Any, stop: float, options: ContinuationOptions, *,
          hooks: Hooks | None = None, progress: Progress = None) -> Trace:
    """Continue ``problem`` from ``first`` towards ``stop`` (``problem.value``'s unit) with
    ``options``; ``hooks``: the family's plug-ins (None: none); ``progress``: a line every ten
    points."""
    hooks = hooks or Hooks()
    found_between = hooks.found_between or (
        lambda a, b: special_between(problem, a, b, options.tol, options.guards))
    out = Trace([first])
    points, ds = out.points, first.ds
    lo, hi = sorted((problem.value(first), stop))
    while len(points) < options.max_points:
        prev = points[-1]
        result = step(problem, prev, ds, options, found_between)
        if isinstance(result, str):
            out.refused += result != NO_CONVERGENCE
            out.reason, out.last_tried = result, problem.unknowns(prev) + ds * prev.tangent
            ds /= 2
            if ds < options.ds_min:
                _end(out, problem, prev, options,
                     "no_convergence" if result == NO_CONVERGENCE else "refused")
                break
            continue
        found, point = result
        reason = hooks.accept(point) if hooks.accept else None
        if reason:
            out.reason = reason
            _end(out, problem, point, options, "accept")
            break
        inside = lo <= problem.value(point) <= hi
        if not inside and hooks.past_end:
            found, point = hooks.past_end(prev, point, found)
        points.extend(found)
        points.append(point)
        ds = min(ds * 1.5, options.ds_max) if point.newton_iterations <= 3 else \
            max(ds / 1.5, options.ds_min)
        point.ds = ds
        if progress and len(points) % 10 == 0:
            progress(f"{len(points)} points, {problem.describe(point)}")
        if not inside:
            break
        if hooks.after_accept:
            hooks.after_accept(point)
    else:
        _end(out, problem, points[-1], options, "max_points")
    return out


def _end(out: Trace, problem: BranchProblem, at: Any, options: ContinuationOptions,
         ended: str) -> None:
    """Mark ``out`` as ended ``ended`` at point ``at``, with its status text."""
    out.ended = ended
    out.status = STATUS[ended].format(max_points=options.max_points, ds_min=options.ds_min,
                                      param=problem.param_name, value=problem.value(at),
                                      reason=out.reason)


def stop_report(out: Trace, problem: BranchProblem, noun: str, unit: str,
                measures: list[str], why: str = "") -> str:
    """Where and why a branch stopped, in one paragraph of numbers: the status, the last
    converged ``noun`` (torus, circle …) and its parameter value (``unit``), the family's
    ``measures`` (texts joined by '; ') and, when a step failed at the end, ``why``."""
    first, last = out.points[0], out.points[-1]
    text = (f"{out.status}. Last converged {noun} at {problem.param_name} = "
            f"{problem.value(last):.8g} {unit} ({len(out.points)} points from "
            f"{problem.value(first):.8g})")
    text += "".join(f"{'. ' if i == 0 else '; '}{m}" for i, m in enumerate(measures))
    if out.failed and why:
        text += f". Why: {why}"
    return text + "."
