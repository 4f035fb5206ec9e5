"""``Schedule``: what every member of a ``run_members`` call runs and records (a transient of
whole RK4 steps, K sections, optional tangent for λ1, the extremes' steps), one value or one
per member. Its own module so that the kernel builds' self-tests (``builds``) and
``members`` both take it without importing each other.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from analysis.errors import InputError


@dataclass(frozen=True)
class Schedule:
    """What every member runs and records (steps are RK4 steps of the member's h). The four
    counts are whole numbers, one for every member or one per member (1-D sequences of
    length M: a chart's points differ in section period and record length)."""

    transient_steps: int | Sequence[int]
    """RK4 steps before the first recorded section interval (>= 0)."""
    steps_per_section: int | Sequence[int]
    """RK4 steps between recorded sections (>= 1); section j is the state after
    ``transient_steps + (j + 1)·steps_per_section`` steps."""
    n_sections: int | Sequence[int]
    """K sections recorded per member (>= 1)."""
    tangent: bool = False
    """Also carry one tangent vector (from e1 at the end of the transient), renormalised at
    each section."""
    lyapunov_skip: int | Sequence[int] = 0
    """Sections whose logs are not averaged into λ1 (< n_sections); the extremes are taken
    from the end of these sections on (the record)."""
    keep_sections: bool = True
    """False: only reduced results leave the device (no (M, K, n) sections)."""
    extremes_from: int | Sequence[int] | None = None
    """First step of the extremes (``low``, ``high``); None: ``transient_steps +
    lyapunov_skip · steps_per_section``."""
    extremes_to: int | Sequence[int] | None = None
    """Last step of the extremes; None: the last section's. A member runs on to it when it
    is later (a record that ends between sections)."""

    def __post_init__(self) -> None:
        for name, low in (("transient_steps", 0), ("steps_per_section", 1),
                          ("n_sections", 1), ("lyapunov_skip", 0)):
            self.counts(name, low)
        for name in ("extremes_from", "extremes_to"):
            if getattr(self, name) is not None:
                self.counts(name, 0)
        if np.any(self.counts("lyapunov_skip") >= self.counts("n_sections")):
            raise InputError(f"lyapunov_skip: fewer than n_sections ({self.n_sections}), got "
                             f"{self.lyapunov_skip}")

    def counts(self, name: str, low: int = 0) -> np.ndarray:
        """The field ``name`` as int64 (0-d or 1-d), checked: whole numbers >= ``low``."""
        value = getattr(self, name)
        arr = np.asarray(value)
        if arr.ndim > 1 or arr.size == 0 or arr.dtype == bool \
                or not np.issubdtype(arr.dtype, np.number) \
                or not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr)) \
                or np.any(arr < low):
            raise InputError(f"{name}: a whole number >= {low} (or one per member), got "
                             f"{value!r}")
        return arr.astype(np.int64)

    def per_member(self, m: int) -> list[np.ndarray]:
        """transient, steps per section, sections, skip, extremes from and to: (m,) int64
        each (``InputError`` when a per-member field's length is not m)."""
        out = []
        for name in ("transient_steps", "steps_per_section", "n_sections", "lyapunov_skip",
                     "extremes_from", "extremes_to"):
            if getattr(self, name) is None:
                tr, ev, ns, skip = out[:4]
                arr = tr + skip * ev if name == "extremes_from" else tr + ev * ns
            else:
                arr = self.counts(name)
            if arr.ndim == 1 and len(arr) != m:
                raise InputError(f"{name}: one number or one per member ({m}), got {len(arr)}")
            out.append(np.ascontiguousarray(np.broadcast_to(arr, (m,)), dtype=np.int64))
        return out

    @property
    def total_steps(self) -> int:
        """RK4 steps of the longest member that does not blow up."""
        last = self.counts("transient_steps") + self.counts("steps_per_section") \
            * self.counts("n_sections")
        if self.extremes_to is not None:
            last = np.maximum(last, self.counts("extremes_to"))
        return int(np.max(last))

    @property
    def max_sections(self) -> int:
        """K: the most sections of a member (the second axis of the results)."""
        return int(np.max(self.counts("n_sections")))
