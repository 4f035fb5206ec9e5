"""The chart's verdicts of many points at once: ``classify.classify_section``'s class, period
and graph ratio, computed with numpy over the members of one kernel call that hold the same
number of section points (``points.chart_points``).

The steps are ``classify_section``'s, element for element: the section points normalised as
``classify._normalised_points`` does (velocities over the section's angular frequency,
positions of another unit rescaled to the orbit size), the smallest repeat period n <= 16
with every |P_{k+n} − P_k| < 1e-3 of the orbit size (``classify.repeat_period``), then for a
point forced at X and VC on the shaft section the graph ratio (``classify.graph_ratio``: the
same seed, so the same random pairs for every point of K samples), then λ1 against its
interval and the chaos floor. Only the fields of a chart's point are produced (class,
period, graph ratio); ``tests/sweeps/test_classes.py`` checks them equal to
``classify_section``'s on kernel points and on a few hundred varied section sets.
"""

from __future__ import annotations

from functools import cache

import numpy as np

from analysis.stability.classify import GRAPH_RATIO


def normalised(sections: np.ndarray, ptp: np.ndarray, names: tuple[str, ...],
               units: dict[str, str], period: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``sections`` (m × K × n states, SI units, the order of ``names``) normalised as
    ``classify``: velocities over 2π/``period`` (m, s), positions of another unit than the
    first position's rescaled; returns the points and the orbit sizes (m)."""
    index = {name: i for i, name in enumerate(names)}
    pairs = [(q, f"v{q}") for q in names if f"v{q}" in index]
    if 2 * len(pairs) != len(names):
        raise ValueError("state variables are not positions with their velocities")
    unit_of = [units[q] for q, _ in pairs]
    scale = {u: np.max(ptp[:, [index[q] for (q, _), uq in zip(pairs, unit_of, strict=True)
                               if uq == u]], axis=1) for u in unit_of}
    size = np.maximum(scale[unit_of[0]], 1e-300)
    omega = 2 * np.pi / period
    # one pass over all the points, not two per variable: x / d * f with d = 1 for a
    # position and ω for a velocity, f = 1 for the first position's unit (x / 1 and x * 1
    # are x: the same bits as position·f and velocity / ω · f taken variable by variable)
    divisor, factor = np.ones((len(sections), len(names))), None
    for (q, v), u in zip(pairs, unit_of, strict=True):
        divisor[:, index[v]] = omega
        if u != unit_of[0]:
            factor = np.ones_like(divisor) if factor is None else factor
            factor[:, index[q]] = factor[:, index[v]] = size / np.maximum(scale[u], 1e-300)
    out = np.divide(sections, divisor[:, None, :])
    if factor is not None:
        out *= factor[:, None, :]
    return out, size


CHUNK = 256
"""Members per numpy pass of ``repeat_periods`` and ``graph_ratios``: their temporaries
(members × K × n doubles) stay in the cache; the values are the same for any chunk."""


GRAPH_CHUNK = 48
"""Members per pass of ``graph_ratios`` taken by component: its K × members planes stay in
the cache (13–14 µs a member of K = 201 at 48, 14–15 at 64, 17–18 at 128, three runs
each); any chunk, the same values."""


PROBE = 8
"""Gaps of a period checked first by ``repeat_periods`` (see there)."""


def _norms(d: np.ndarray) -> np.ndarray:
    """``np.linalg.norm(d, axis=-1)`` squared, the same operations (sqrt(add.reduce(d·d)))
    without the square root (taken after a max or a median: the same bits, sqrt being
    monotonic and correctly rounded)."""
    return np.add.reduce(d * d, axis=-1)


def repeat_periods(points: np.ndarray, size: np.ndarray, rel_tol: float = 1e-3,
                   max_period: int = 16) -> np.ndarray:
    """``classify.repeat_period`` of each member (m × K × n points, sizes m): the smallest
    n, 0 where none."""
    found = np.zeros(len(points), dtype=np.int64)
    for lo in range(0, len(points), CHUNK):
        part, out, limit = points[lo:lo + CHUNK], found[lo:lo + CHUNK], \
            rel_tol * size[lo:lo + CHUNK]
        todo = np.arange(len(part))
        count = points.shape[1]
        # the first sections one component per plane (sections × n × members), where the
        # squares add in order (``_sums_in_order``): the probes in long contiguous rows
        planes = np.ascontiguousarray(part[:, :max_period + PROBE].transpose(1, 2, 0)) \
            if _sums_in_order(points.shape[2]) else None
        for n in range(1, max_period + 1):
            if count < 2 * n + 2 or not len(todo):
                break
            # the first PROBE gaps first: a member with one of them >= its limit (or NaN)
            # cannot repeat with period n, and most do not (the max of all is then not
            # needed; the members left get the max over all their gaps, as before)
            whole = len(todo) == len(part)  # none found yet: a view, not a copy
            if whole and planes is not None:
                gaps = min(PROBE, count - n)  # P_{k+n} − P_k, k < gaps: the probe's
                steps = (planes[n:n + gaps] - planes[:gaps]).transpose(1, 0, 2)
                first = np.sqrt(np.max(_plane_norms(steps), axis=0))
            else:
                head = part[:, :n + PROBE] if whole else part[todo, :n + PROBE]
                first = np.sqrt(np.max(_norms(head[:, n:] - head[:, :-n]), axis=1))
            check = todo[first < (limit if whole else limit[todo])]
            if not len(check):
                continue
            sub = part[check]
            gap = np.sqrt(np.max(_norms(sub[:, n:] - sub[:, :-n]), axis=1))
            hit = check[gap < limit[check]]
            out[hit] = n
            if len(hit):  # todo without hit (both ascending)
                keep = np.ones(len(todo), dtype=bool)
                keep[np.searchsorted(todo, hit)] = False
                todo = todo[keep]
    return found


@cache
def _sums_in_order(n: int) -> bool:
    """Whether ``np.add.reduce`` over a contiguous last axis of ``n`` doubles adds them in
    order, ((a0 + a1) + a2) + …, as numpy's pairwise sum does below 8 terms: checked once
    per n on 4096 random rows (then ``_plane_norms`` gives ``_norms``' bits)."""
    if n >= 8:
        return False
    d = np.random.default_rng(n).normal(size=(4096, n)) * np.logspace(-6, 3, n)
    return bool(np.array_equal(_norms(d), _plane_norms(np.ascontiguousarray(d.T))))


def _plane_norms(planes: np.ndarray) -> np.ndarray:
    """``_norms`` of vectors stored one component per plane (n × …), the squares added in
    order as ``graph_ratios`` adds them (``_sums_in_order``: the same bits where it
    holds)."""
    out = planes[0] * planes[0]
    for plane in planes[1:]:
        out += plane * plane
    return out


def _median_root(squares: np.ndarray) -> np.ndarray:
    """``np.median(np.sqrt(squares), axis=0)`` of columns of squared distances (N ×
    m), bit for bit: the square root is monotonic and correctly rounded, so the middle
    values are the roots of the middle squares (one partition at N // 2, the lower middle
    the largest below it); two of them averaged as ``np.median`` does (their sum over 2)
    for an even N; NaN where a column holds one."""
    rows = np.array(squares.T, order="C")  # a copy, partitioned in place
    half = rows.shape[1] // 2
    nan = np.isnan(rows).any(axis=1)
    rows.partition(half, axis=1)
    upper = np.sqrt(rows[:, half])
    middle = upper if rows.shape[1] % 2 else (np.sqrt(rows[:, :half].max(axis=1)) + upper) / 2
    return np.where(nan, np.nan, middle)


def graph_ratios(points: np.ndarray, phase: np.ndarray, seed: int = 0) -> np.ndarray:
    """``classify.graph_ratio`` of each member (m × K × n points, phases m × K). With
    fewer than 8 state variables (``_sums_in_order``) the distances are taken one
    component at a time (K × members planes: contiguous gathers and in-place sums, the
    squares added in order) and the medians from the squared distances (``_median_root``):
    the same bits as the direct form (``tests/sweeps/test_chart_host_batched.py``)."""
    count = points.shape[1]
    rng = np.random.default_rng(seed)
    i, j = rng.integers(0, count, (2, 4 * count))
    i, j = i[i != j], j[i != j]
    out = np.empty(len(points))
    planes = _sums_in_order(points.shape[2])
    chunk = GRAPH_CHUNK if planes else CHUNK
    for lo in range(0, len(points), chunk):
        part = points[lo:lo + chunk]
        order = np.argsort(phase[lo:lo + chunk], axis=1)
        if planes:
            width = len(part)
            flat = (order.T * width + np.arange(width)).ravel()  # plane[order.T, members]
            pairs, gap, other = np.empty((3, len(i), width))
            neighbours = None
            for plane in np.ascontiguousarray(part.transpose(2, 1, 0)):  # K × members
                step = np.diff(np.take(plane.ravel(), flat).reshape(count, width), axis=0)
                step *= step
                into = gap if neighbours is not None else pairs  # the first plane: pairs
                np.take(plane, i, axis=0, out=into, mode="clip")  # i, j < K: none clipped
                np.take(plane, j, axis=0, out=other, mode="clip")
                into -= other
                into *= into
                if neighbours is None:
                    neighbours = step
                else:
                    neighbours += step
                    pairs += gap
            out[lo:lo + chunk] = _median_root(neighbours) / np.maximum(
                _median_root(pairs), 1e-300)
            continue
        sorted_points = np.take_along_axis(part, order[:, :, None], axis=1)
        neighbours = np.sqrt(_norms(np.diff(sorted_points, axis=1)))
        pairs = np.sqrt(_norms(part[:, i] - part[:, j]))
        out[lo:lo + chunk] = np.median(neighbours, axis=1) / np.maximum(
            np.median(pairs, axis=1), 1e-300)
    return out


def _phases(times: np.ndarray, hz: np.ndarray) -> np.ndarray:
    """``np.mod(times * hz[:, None], 1.0)`` (the phases of section times ``times`` s, m × K,
    at ``hz`` Hz, m) as t·f − ⌊t·f⌋, bit for bit and 10 times faster than ``np.mod``: both
    are one rounding of the same exact value (for x >= 0 the fraction itself, exact; for
    x < 0 fmod(x, 1) + 1 and x − ⌊x⌋ are the same real; +0 where x is whole; NaN where x is
    not finite)."""
    x = times * hz[:, None]
    whole = np.floor(x)
    return np.subtract(x, whole, out=whole)


def chart_classes(sections: np.ndarray, ptp: np.ndarray, names: tuple[str, ...],
                  units: dict[str, str], period: np.ndarray, times: np.ndarray,
                  graph: np.ndarray, vc_hz: np.ndarray, lam: np.ndarray, ci: np.ndarray,
                  chaos_floor: float = 0.01
                  ) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Class, period (0: none) and graph ratio (NaN: none) of m points as
    ``classify_section`` gives them (``rel_tol`` 1e-3, periods up to 16): ``sections``
    m × K × n, ``ptp`` m × n peak-to-peak (SI units), ``period`` the section periods (s),
    ``times`` m × K the section times (s), ``graph`` whether a point's graph ratio is
    judged (forced at X and VC, shaft section), ``vc_hz`` its VC frequency (Hz), ``lam``
    and ``ci`` λ1 and its 95 % half-width (1/s)."""
    classes, code, periods, ratios = class_codes(sections, ptp, names, units, period, times,
                                                 graph, vc_hz, lam, ci, chaos_floor)
    return classes[code].tolist(), periods, ratios


def class_codes(sections: np.ndarray, ptp: np.ndarray, names: tuple[str, ...],
                units: dict[str, str], period: np.ndarray, times: np.ndarray,
                graph: np.ndarray, vc_hz: np.ndarray, lam: np.ndarray, ci: np.ndarray,
                chaos_floor: float = 0.01
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``chart_classes`` with the classes as an index: the class names (an object array:
    quasi-periodic, chaotic, periodic-1 … periodic-N), each point's index into them, the
    periods and the graph ratios (the same arguments): the points' classes are
    ``names[code]`` without a string per point."""
    points, size = normalised(sections, ptp, names, units, period)
    periods = repeat_periods(points, size)
    ratios = np.full(len(points), np.nan)
    judged = graph & (periods == 0)
    if judged.all():  # every member: no copy of the points
        ratios[:] = graph_ratios(points, _phases(times, vc_hz))
    elif judged.any():
        ratios[judged] = graph_ratios(points[judged], _phases(times[judged], vc_hz[judged]))
    floor = chaos_floor * 2 * np.pi / period
    # periodic-n where a period repeats, else quasi-periodic by the graph ratio (NaN: not
    # judged), else chaotic where λ1 is above its interval and the chaos floor
    with np.errstate(invalid="ignore"):
        chaotic = ~(ratios < GRAPH_RATIO) & (lam - ci > 0) & (lam > floor)
    code = np.where(periods > 0, periods + 1, chaotic.astype(np.int64))
    classes = np.array(["quasi-periodic", "chaotic",
                        *(f"periodic-{n}" for n in range(1, int(periods.max(initial=0)) + 1))],
                       dtype=object)
    return classes, code, periods, ratios
