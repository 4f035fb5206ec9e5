"""Speed profiles: runs at a shaft speed that changes with time (run-ups, coast-downs).

A profile is a piecewise-linear speed n(t) in rpm: a ramp from A at t = 0 to B at the end of
the run (``SpeedProfile.ramp``), or a table of (t, rpm) rows (``SpeedProfile.table``, read
from a CSV file by ``read_table``). Between rows the speed is linear, so the shaft angle is
the exact integral of the speed, piecewise quadratic in closed form:

    φ(t) = (π/30)·N(t),   N(t) = ∫₀ᵗ n(s) ds = n₀ t + s₀ t²/2 + Σⱼ Δsⱼ·max(0, t − tⱼ)²/2

(n₀ the speed at t = 0, s₀ the first slope in rpm/s, Δsⱼ the change of slope at row j).

How the generated equations follow it (an exact substitution, no regenerated code): a
generated model's right-hand side f(t, z, p) depends on the time only through angles
a + K·t whose rates K are proportional to the speed parameter n (the shaft angle
π/30·n·t of the unbalance, each bearing's cage angle ω_cage·t, the ball-spin and defect
angles); every other speed-dependent term (centrifugal force, a speed-dependent unbalance)
reads n itself. ``time_dependence`` checks exactly that on the model's CasADi rhs before a
profile is accepted. Then, with n(t) and N(t) of the profile and τ(t) = N(t)/n(t),

    f_profile(t, z, p) = f(τ(t), z, p with n = n(t)),

in which every angle K·τ = (K/n)·n(t)·τ(t) = (K/n)·N(t) is the integral of its rate and
every speed-dependent term sees the speed at that instant: the equations of the spec with
φ(t) = ∫ω dt in place of ω·t. The RK4 step is the classical one on f_profile (its stages at
t, t + h/2, t + h), compiled like every other (``analysis.integrate.compiled``). The
speed must stay > 0 (τ divides by it). A constant profile is not a profile: ``simulate``
runs it as today's constant-speed run, bit for bit.

What it does not add: forces that only exist while the speed changes and that the spec
does not write (the tangential m·e·dω/dt of an unbalance given as m·e·ω²; the shaft's
speed is imposed, not computed from a torque).

Table files (CSV, read as text, never executed): a header line ``t_s,speed_rpm`` then one
row per line; ``#`` starts a comment; times in s strictly increasing from 0, speeds in rpm
> 0; the last time must reach the end of the run.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from analysis.errors import InputError

MAX_ROWS = 257
"""Most rows of a profile table (256 segments): each row beyond two adds a few operations
to every RK4 stage."""
TABLE_HEADER = ("t_s", "speed_rpm")


@dataclass(frozen=True)
class SpeedProfile:
    """A shaft speed n(t) (rpm) over a run, piecewise linear in t (s).

    ``kind`` is ``"ramp"`` (``rpm = (A, B)``: A at t = 0, B at the end of the run, whatever
    its duration) or ``"table"`` (rows ``times`` (s) and ``rpm``). ``source``: the table's
    file, for the record. Make one with ``ramp``, ``table`` or ``read_table``."""

    kind: str
    rpm: tuple[float, ...]
    times: tuple[float, ...] | None = None
    source: str = ""

    @classmethod
    def ramp(cls, start_rpm: float, end_rpm: float) -> SpeedProfile:
        """A linear ramp from ``start_rpm`` at t = 0 to ``end_rpm`` at the end of the run
        (rpm, both > 0): a run-up, or a coast-down when ``end_rpm`` is lower."""
        for what, value in (("start", start_rpm), ("end", end_rpm)):
            if not _positive(value):
                raise InputError(f"speed_rpm: the ramp's {what} speed must be a finite "
                                 f"number > 0 rpm, got {value!r}", field="speed_rpm")
        return cls("ramp", (float(start_rpm), float(end_rpm)))

    @classmethod
    def table(cls, times: Sequence[float], rpm: Sequence[float],
              source: str = "") -> SpeedProfile:
        """A table of speeds ``rpm`` (> 0) at ``times`` (s, strictly increasing from 0;
        2 … ``MAX_ROWS`` rows), linear in between."""
        where = f"speed table '{source}'" if source else "speed table"
        try:
            times, rpm = [float(t) for t in times], [float(v) for v in rpm]
        except (TypeError, ValueError):
            raise InputError(f"{where}: times and speeds must be numbers") from None
        if len(times) != len(rpm):
            raise InputError(f"{where}: {len(times)} times and {len(rpm)} speeds")
        if not 2 <= len(times) <= MAX_ROWS:
            raise InputError(f"{where}: must have 2 to {MAX_ROWS} rows, got {len(times)}")
        if times[0] != 0.0:
            raise InputError(f"{where}: row 1: t_s must be 0 (the run starts at t = 0), "
                             f"got {times[0]!r}")
        for row, (t, v) in enumerate(zip(times, rpm, strict=True), start=1):
            if not math.isfinite(t):
                raise InputError(f"{where}: row {row}: t_s must be a finite number, got {t!r}")
            if row > 1 and not t > times[row - 2]:
                raise InputError(f"{where}: row {row}: t_s must increase, got {t:g} after "
                                 f"{times[row - 2]:g} (rows out of order)")
            if not _positive(v):
                raise InputError(f"{where}: row {row}: speed_rpm must be a finite number "
                                 f"> 0 rpm, got {v!r}")
        return cls("table", tuple(rpm), tuple(times), source)

    @classmethod
    def read(cls, path: str | Path) -> SpeedProfile:
        """The table of a CSV file (``read_table``)."""
        return read_table(path)

    @property
    def start_rpm(self) -> float:
        return self.rpm[0]

    @property
    def is_constant(self) -> bool:
        """Every speed equal: a constant-speed run (run as one, bit for bit)."""
        return all(v == self.rpm[0] for v in self.rpm)

    def knots(self, duration: float) -> tuple[np.ndarray, np.ndarray]:
        """(times in s, speeds in rpm) of the rows, the ramp's at 0 and ``duration``."""
        times = (0.0, float(duration)) if self.kind == "ramp" else self.times
        return np.asarray(times, dtype=float), np.asarray(self.rpm, dtype=float)

    def speed(self, t: Any, duration: float) -> np.ndarray:
        """n(t) in rpm (piecewise linear; the last slope continued beyond the last row)."""
        n0, s0, hinges, changes = self._coefficients(duration)
        t = np.asarray(t, dtype=float)
        out = n0 + s0 * t
        for tj, dj in zip(hinges, changes, strict=True):
            out = out + dj * np.maximum(0.0, t - tj)
        return out

    def integral(self, t: Any, duration: float) -> np.ndarray:
        """N(t) = ∫₀ᵗ n ds in rpm·s (the shaft has turned N/60 revolutions)."""
        n0, s0, hinges, changes = self._coefficients(duration)
        t = np.asarray(t, dtype=float)
        out = n0 * t + 0.5 * s0 * t * t
        for tj, dj in zip(hinges, changes, strict=True):
            out = out + 0.5 * dj * np.maximum(0.0, t - tj) ** 2
        return out

    def shaft_angle(self, t: Any, duration: float) -> np.ndarray:
        """φ(t) = ∫₀ᵗ ω ds in rad."""
        return math.pi / 30.0 * self.integral(t, duration)

    def time_at_angle(self, angle: Any, duration: float) -> np.ndarray:
        """The times t (s) at which φ(t) = ``angle`` (rad): the inverse of ``shaft_angle``
        (monotonic, as n > 0), by interpolation on the rows refined by three Newton steps
        (exact to rounding for a piecewise-quadratic φ)."""
        angle = np.asarray(angle, dtype=float)
        knots, _ = self.knots(duration)
        grid = np.linspace(0.0, max(knots[-1], duration), 4097)
        t = np.interp(angle, self.shaft_angle(grid, duration), grid)
        for _ in range(3):
            rate = math.pi / 30.0 * self.speed(t, duration)
            t = t - (self.shaft_angle(t, duration) - angle) / rate
        return t

    def _coefficients(self, duration: float) -> tuple[float, float, np.ndarray, np.ndarray]:
        times, rpm = self.knots(duration)
        slopes = np.diff(rpm) / np.diff(times)
        return float(rpm[0]), float(slopes[0]), times[1:-1], np.diff(slopes)

    def parameters(self, duration: float) -> np.ndarray:
        """The profile's inputs to the compiled step (``profile_functions``): the speed at
        t = 0 and the first slope (rpm, rpm/s), then ``hinges(rows)`` hinge times (s) and
        their changes of slope (rpm/s), padded with zero changes at t = 0 (exact: they add
        0)."""
        n0, s0, hinges, changes = self._coefficients(duration)
        pad = hinge_count(len(self.rpm)) - len(hinges)
        return np.concatenate([[n0, s0], hinges, np.zeros(pad), changes, np.zeros(pad)])

    def check_covers(self, duration: float) -> None:
        """``InputError`` unless a table reaches the end of the run (s)."""
        if self.kind == "table" and self.times[-1] < duration * (1 - 1e-12):
            raise InputError(f"speed table '{self.source or 'table'}': its last t_s "
                             f"({self.times[-1]:g} s) must reach the end of the run "
                             f"(duration {duration:g} s)")

    def attrs(self, duration: float) -> dict[str, Any]:
        """The profile as result attributes: ``speed_profile`` (ramp or table),
        ``speed_profile_t`` (s) and ``speed_profile_rpm`` (rpm), the rows; a table's file
        as ``speed_profile_file``."""
        times, rpm = self.knots(duration)
        out: dict[str, Any] = {"speed_profile": self.kind, "speed_profile_t": times,
                               "speed_profile_rpm": rpm}
        if self.source:
            out["speed_profile_file"] = self.source
        return out

    @classmethod
    def from_attrs(cls, attrs: Mapping) -> SpeedProfile | None:
        """The profile a run's attributes record (None: a constant-speed run)."""
        kind = attrs.get("speed_profile")
        if kind is None:
            return None
        times = np.atleast_1d(np.asarray(attrs.get("speed_profile_t", ()), dtype=float))
        rpm = np.atleast_1d(np.asarray(attrs.get("speed_profile_rpm", ()), dtype=float))
        if str(kind) == "ramp" and len(rpm) == 2:
            return cls.ramp(*rpm)
        if str(kind) == "table":
            return cls.table(times, rpm, str(attrs.get("speed_profile_file", "")))
        raise InputError(f"speed_profile: a run's profile must be 'ramp' (2 speeds) or "
                         f"'table', got {kind!r} with {len(rpm)} speeds (a damaged file)")

    def describe(self, duration: float | None = None) -> str:
        """'ramp 1000 → 10000 rpm', 'table of 5 rows, 1000 … 6000 rpm'."""
        if self.kind == "ramp":
            return f"ramp {self.rpm[0]:g} → {self.rpm[1]:g} rpm"
        return (f"table of {len(self.rpm)} rows, {min(self.rpm):g} … {max(self.rpm):g} rpm"
                + (f" ({self.source})" if self.source else ""))


def _positive(value: Any) -> bool:
    try:
        number = float(value)
    except (TypeError, ValueError):
        return False
    return math.isfinite(number) and number > 0


def hinge_count(rows: int) -> int:
    """Hinges of the compiled step for a table of ``rows`` rows: rows − 2 rounded up to a
    power of two (0 for a ramp), so tables of similar lengths share one compiled library."""
    inner = max(0, rows - 2)
    return 0 if inner == 0 else 1 << (inner - 1).bit_length()


def read_table(path: str | Path) -> SpeedProfile:
    """The speed table of a CSV file (see the module: header ``t_s,speed_rpm``, ``#``
    comments; a UTF-8 byte-order mark, as Excel's "CSV UTF-8" writes, is accepted); every
    problem one ``InputError`` line naming the file and the line. The file's kind and size
    are judged before it is read, and at most ``MAX_ROWS`` rows are read."""
    path = Path(path)
    text = _table_text(path)
    rows = [(number, line.split("#", 1)[0].strip())
            for number, line in enumerate(text.splitlines(), start=1)]
    rows = [(number, line) for number, line in rows if line]
    where = f"speed table '{path}'"
    if not rows:
        raise InputError(f"{where}: empty; give a header t_s,speed_rpm and rows of t, rpm")
    number, header = rows[0]
    if tuple(cell.strip() for cell in next(csv.reader([header]))) != TABLE_HEADER:
        raise InputError(f"{where} line {number}: the header must be 't_s,speed_rpm', got "
                         f"{header!r}")
    if len(rows) - 1 > MAX_ROWS:
        raise InputError(f"{where}: must have 2 to {MAX_ROWS} rows, got more than {MAX_ROWS}")
    times, rpm = [], []
    for number, line in rows[1:]:
        cells = [cell.strip() for cell in next(csv.reader([line]))]
        if len(cells) != 2:
            raise InputError(f"{where} line {number}: must hold 2 values (t_s, speed_rpm), "
                             f"got {line!r}")
        try:
            t, v = float(cells[0]), float(cells[1])
        except ValueError:
            raise InputError(f"{where} line {number}: t_s and speed_rpm must be numbers, got "
                             f"{line!r}") from None
        if times and not t > times[-1]:
            raise InputError(f"{where} line {number}: t_s must increase, got {t:g} after "
                             f"{times[-1]:g} (rows out of order)")
        times.append(t)
        rpm.append(v)
    return SpeedProfile.table(times, rpm, str(path))


TABLE_BYTES = 2**20
"""The largest speed table read, bytes (``MAX_ROWS`` rows with long comments fit)."""


def _table_text(path: Path) -> str:
    """The text of the speed table at ``path``, judged before it is read: a missing file, a
    folder, a pipe or a device, and a file over ``TABLE_BYTES`` are refused by name."""
    import os
    import stat

    from modelgen.locations import broken_link

    head = f"speed_rpm: the speed table '{path}'"
    try:
        mode = path.stat().st_mode
    except OSError as exc:
        reason = broken_link(path) or ("does not exist" if not os.path.lexists(path)
                                       else exc.strerror)
        raise InputError(f"{head} {reason}", field="speed_rpm") from None
    if stat.S_ISDIR(mode):
        raise InputError(f"{head} is a folder; give a CSV file (t_s,speed_rpm)", field="speed_rpm")
    if not stat.S_ISREG(mode):
        kind = "a pipe (FIFO)" if stat.S_ISFIFO(mode) else "a device or socket"
        raise InputError(f"{head} is {kind}, not a plain file; give a CSV file (t_s,speed_rpm)",
                         field="speed_rpm")
    size = path.stat().st_size
    if size > TABLE_BYTES:
        raise InputError(f"{head} is {size} bytes; at most {TABLE_BYTES} bytes (a table of 2 "
                         f"to {MAX_ROWS} rows)", field="speed_rpm")
    try:
        with open(path, encoding="utf-8-sig") as handle:  # a byte-order mark is dropped
            return handle.read(TABLE_BYTES + 1)
    except UnicodeDecodeError as exc:
        raise InputError(f"{head} is not UTF-8 text (byte {exc.start}); save it as CSV "
                         "UTF-8", field="speed_rpm") from None
    except OSError as exc:
        raise InputError(f"{head} cannot be read: {exc.strerror or exc}",
                         field="speed_rpm") from None


def parse_speed(text: str) -> float | SpeedProfile:
    """``--speed-rpm``: a number (rpm), a ramp ``A:B`` (rpm; A at t = 0, B at the end of the
    run; a constant one is the number A) or the path of a CSV speed table."""
    text = str(text).strip()
    try:
        return float(text)
    except ValueError:
        pass
    start, sep, end = text.partition(":")
    if sep:
        try:
            a, b = float(start), float(end)
        except ValueError:
            a = b = None
        if a is not None:
            profile = SpeedProfile.ramp(a, b)
            return profile.start_rpm if profile.is_constant else profile
    path = Path(text)
    if path.suffix.lower() == ".csv" or path.exists():
        profile = read_table(path)  # a missing file, a folder or a pipe refused by name
        return profile.start_rpm if profile.is_constant else profile
    raise InputError(f"speed_rpm: must be a speed in rpm, a ramp A:B (rpm, A at t = 0, B "
                     f"at the end) or a CSV speed table (t_s,speed_rpm), got {text!r}",
                     field="speed_rpm")


def profile_of(attrs: Mapping) -> SpeedProfile | None:
    """The speed profile of a run (its attrs), None at constant speed."""
    return SpeedProfile.from_attrs(attrs)


def refuse_profile(attrs: Mapping, what: str) -> None:
    """``InputError`` (one line) when the run of ``attrs`` changes speed: ``what`` (a
    spectrum, a Poincaré section) assumes a constant speed."""
    profile = profile_of(attrs)
    if profile is None:
        return
    raise InputError(f"{what}: the run's speed changes ({profile.describe()}), so it has no "
                     "fixed frequency or period; use `bearingdyn waterfall RUN` (short-time "
                     "spectra against speed) or `bearingdyn waterfall RUN --orders` (order "
                     "tracking)")


# --- the model side ------------------------------------------------------------------------

def time_dependence(rhs: ca.Function, p: np.ndarray, speed_index: int) -> str:
    """'' when the rhs ``f(t, z, p)`` depends on t only through sines and cosines of angles
    a(p) + K(p)·t whose rate K is proportional to the speed ``p[speed_index]`` (checked at
    ``p``: K(2n) = 2·K(n) and K ≠ 0); else what breaks it, in words. The Function is read
    instruction by instruction; each such sine or cosine is replaced by a free symbol, and
    the result must no longer depend on t."""
    inputs = [ca.SX.sym(rhs.name_in(i), rhs.sparsity_in(i)) for i in range(rhs.n_in())]
    t, z, par = inputs[0], inputs[1], inputs[2]
    doubled = np.array(p, dtype=float)
    doubled[speed_index] *= 2.0
    work: list[Any] = [None] * rhs.sz_w()
    outputs = [ca.SX.zeros(rhs.sparsity_out(i)) for i in range(rhs.n_out())]
    for i in range(rhs.n_instructions()):
        op, out, arg = rhs.instruction_id(i), rhs.instruction_output(i), rhs.instruction_input(i)
        if op == ca.OP_INPUT:
            work[out[0]] = inputs[arg[0]].nz[arg[1]]
        elif op == ca.OP_OUTPUT:
            outputs[out[0]].nz[out[1]] = work[arg[0]]
        elif op == ca.OP_CONST:
            work[out[0]] = ca.SX(rhs.instruction_constant(i))
        elif op in (ca.OP_SIN, ca.OP_COS) and ca.depends_on(work[arg[0]], t):
            angle = work[arg[0]]
            rate = ca.jacobian(angle, t)
            if ca.depends_on(rate, ca.vertcat(t, z)):
                return "an angle of its forcing does not grow linearly with the time"
            value = ca.Function("rate", [par], [rate])
            k1, k2 = float(value(p)), float(value(doubled))
            if not (k1 != 0 and abs(k2 - 2 * k1) <= 1e-12 * abs(k1)):
                return (f"it is forced at a rate of {k1 / (2 * math.pi):.4g} Hz that does not "
                        "turn with the shaft (not proportional to speed_rpm)")
            work[out[0]] = ca.SX.sym(f"rotation{i}")
        elif len(arg) == 1:
            work[out[0]] = ca.SX.unary(op, work[arg[0]])
        else:
            work[out[0]] = ca.SX.binary(op, work[arg[0]], work[arg[1]])
    if any(ca.depends_on(o, t) for o in outputs):
        return "its forces depend on the time other than through angles that turn with the shaft"
    return ""


def check_model(model: Any, structure: tuple[int, ...], values: Mapping[str, float]) -> None:
    """``InputError`` unless ``model`` can follow a speed profile: it has a ``speed_rpm``
    parameter and its time dependence is the rotation of the shaft (``time_dependence``)."""
    if not model.role("speed"):  # the parameter shaft_speed reads, found by role
        raise InputError(f"speed_rpm: model '{model.name}' has no parameter speed_rpm; a "
                         "speed profile needs a rotor", field="speed_rpm")
    reason = _reason(model, structure, tuple(sorted(values.items())))
    if reason:
        raise InputError(f"speed_rpm: model '{model.name}' cannot follow a speed profile: "
                         f"{reason}", field="speed_rpm")


@cache
def _reason(model: Any, structure: tuple[int, ...], items: tuple) -> str:
    rhs = model.functions(structure).rhs
    return time_dependence(rhs, model.parameter_vector(dict(items)),
                           model.parameter_names.index(model.role("speed")[0]))


class ProfileFunctions:
    """The CasADi Functions of a model driven by a speed profile with ``hinges`` hinges:
    ``rhs(t, z, q)``, ``jac(t, z, q)`` and ``rk4_step(t, z, q, h)`` with
    ``q = [p; profile.parameters(duration)]`` (p the model's parameter vector; its
    ``speed_rpm`` entry is not read), named like the model's own so that
    ``analysis.integrate.compiled`` builds, caches and checks their library the same way.
    """

    def __init__(self, model: Any, structure: tuple[int, ...], hinges: int):
        self.hinges = hinges
        self.tag = f"speed{hinges}"
        base = model.functions(structure).rhs
        n, n_par = base.size1_in(1), base.size1_in(2)
        t, h = ca.SX.sym("t"), ca.SX.sym("h")
        z, q = ca.SX.sym("z", n), ca.SX.sym("q", n_par + 2 + 2 * hinges)
        index = model.parameter_names.index(model.role("speed")[0])
        p, n0, s0 = q[:n_par], q[n_par], q[n_par + 1]
        knots = q[n_par + 2:n_par + 2 + hinges]
        changes = q[n_par + 2 + hinges:]

        def f(time, state):
            speed, turned = n0 + s0 * time, n0 * time + 0.5 * s0 * time * time
            for j in range(hinges):
                past = ca.fmax(0, time - knots[j])
                speed, turned = speed + changes[j] * past, turned + 0.5 * changes[j] * past * past
            driven = ca.vertcat(p[:index], speed, p[index + 1:])
            return base(turned / speed, state, driven)

        dz = ca.cse(f(t, z))
        names = ["t", "z", "p"]
        self.rhs = ca.Function("rhs", [t, z, q], [dz], names, ["dz"])
        self.jac = ca.Function("rhs_jac", [t, z, q], [ca.jacobian(dz, z)], names, ["dfdz"])
        k1 = f(t, z)
        k2 = f(t + h / 2, z + h / 2 * k1)
        k3 = f(t + h / 2, z + h / 2 * k2)
        k4 = f(t + h, z + h * k3)
        z_next = ca.cse(z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4))
        self.rk4_step = ca.Function("rk4_step", [t, z, q, h], [z_next], [*names, "h"],
                                    ["z_next"])

    def test_parameters(self, p: np.ndarray) -> np.ndarray:
        """A q for self-tests: ``p`` driven up a ramp from 5000 rpm at 1000 rpm/s, with
        hinges at 0.05 s, 0.1 s, … (changes of slope of 10 rpm/s)."""
        knots = 0.05 * (1.0 + np.arange(self.hinges))
        return np.concatenate([p, [5000.0, 1000.0], knots, 10.0 * np.ones(self.hinges)])


@cache
def profile_functions(model: Any, structure: tuple[int, ...], hinges: int) -> ProfileFunctions:
    """The ``ProfileFunctions`` of a model, its balls and a number of hinges (memoised)."""
    return ProfileFunctions(model, structure, hinges)


def describe_speed(attrs: Mapping) -> str:
    """'5000 rpm, ' or 'ramp 1000 → 10000 rpm, ' of a run's attrs ('' without a speed)."""
    profile = profile_of(attrs)
    if profile is not None:
        return f"{profile.describe()}, "
    return f"{float(attrs['speed_rpm']):g} rpm, " if "speed_rpm" in attrs else ""
