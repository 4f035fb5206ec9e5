"""The error estimate of a harmonic-balance response (issue 32: a residual of 1e-13 says the
equations of H harmonics are met, not how far the response is from the true one).

Two more solves of the same response: at 2H harmonics (the truncation: the change when the
harmonics double) and at H harmonics with twice the AFT samples (the aliasing of the
nonlinear force's harmonics above the sampled band). Each change is the largest difference
of the two responses over one period (on a grid of 8(4H + 1) phases), relative to each
state's amplitude (max − min)/2, the largest over the states. On a branch they are measured
at its first point.

A torus by 2-D harmonic balance (``torus --method hb``) gets the same two estimates: the
re-solve at (2H1, 2H2) and at twice the grid (2N1, 2N2), each from the simulation's fit as
the first solve (the solves are the method's own), compared on a grid of 2(4H1 + 1) ×
2(4H2 + 1) phases (θ1, θ2) of the larger harmonics. A doubled solve that the memory bound
refuses, or that does not converge, is tried at 1.5H (rounded up) before it gives NaN,
and every NaN has its reason in the attr ``error_notes`` (printed in its place; JSON null).

**A bound for ``hb``.** The change at 2H is not the error: against shooting at Δt = 1e-6 s
(balanced rotor, period vc, H = 5, 10, 20, 40 at 3000–8000 rpm, 6 and 50 N) the true error
was 0.90–1.21 × the change (``benchmarks`` script in docs/frequency.md). A periodic
response so states ``error_bound`` = ``HB_SAFETY`` × the larger of its two changes, a bound
that held with a margin of 24 % in every case measured
(tests/frequency/test_hb_bound.py). A torus by 2-D HB gets no bound: on contact its
coefficients fall like H^-1.4, where the error can reach 1/(1 − 2^-1.4) = 1.6 × the change,
and no reference was measured at its sizes; its change is called an estimate.

>>> import numpy as np
>>> t = np.linspace(0, 2 * np.pi, 4, endpoint=False)
>>> np.round(series(np.array([[1.0], [0.0], [2.0]]), t)[:, 0], 6).tolist()
[1.0, 3.0, 1.0, -1.0]
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import xarray as xr

from analysis.model import System

ESTIMATES = ("error_harmonics", "error_aliasing")
"""The attrs an HB response carries its error estimates in (fractions of the amplitude)."""
HB_SAFETY = 1.5
"""``error_bound`` of a periodic HB response: this × the larger of its two changes (true
error against shooting measured 0.90–1.21 × the change at 2H: module docstring)."""


def series(coefficients: np.ndarray, phase: np.ndarray) -> np.ndarray:
    """z at the phases ``phase`` (rad) of the harmonic-major coefficients c0, a1, b1, …, aH,
    bH (rows; one column per state): c0 + Σ a_k cos kθ + b_k sin kθ."""
    h = (coefficients.shape[0] - 1) // 2
    k = np.arange(1, h + 1)
    cos, sin = np.cos(np.outer(phase, k)), np.sin(np.outer(phase, k))
    return coefficients[0] + cos @ coefficients[1::2] + sin @ coefficients[2::2]


def doubled(harmonics: object) -> int | str:
    """The harmonics ``harmonics`` (an HB result's attr: ``"H"`` or ``"H1,H2"``) doubled.

    >>> doubled(10), doubled("8,4")
    (20, '16,8')
    """
    parts = [2 * int(v) for v in str(harmonics).split(",")]
    return parts[0] if len(parts) == 1 else ",".join(str(v) for v in parts)


def _is_torus(data: xr.Dataset) -> bool:
    return "frequencies" in data.attrs


def _torus_values(data: xr.Dataset, theta1: np.ndarray, theta2: np.ndarray) -> np.ndarray:
    """The first torus of ``data`` at the forcing phases (θ1, θ2) (rad): points × n."""
    from analysis.frequency.torus.dataset import torus_of

    ts, coeffs = torus_of(data, 0)
    phi = np.mod(theta2 - ts.shear * theta1, 2 * np.pi)
    return ts.basis.evaluate(coeffs, theta1, phi, ts.n)


def change(a: xr.Dataset, b: xr.Dataset) -> float:
    """max over the states of max |z_a − z_b| / ((max − min)/2 of z_a), at the first point
    of each response: over one period of a periodic one, over a (θ1, θ2) grid of a
    torus."""
    if _is_torus(a):
        h1, h2 = (max(int(x), int(y)) for x, y in zip(
            str(a.attrs["harmonics"]).split(","), str(b.attrs["harmonics"]).split(","),
            strict=True))
        t1, t2 = np.meshgrid(np.linspace(0, 2 * np.pi, 2 * (4 * h1 + 1), endpoint=False),
                             np.linspace(0, 2 * np.pi, 2 * (4 * h2 + 1), endpoint=False))
        za = _torus_values(a, t1.ravel(), t2.ravel())
        zb = _torus_values(b, t1.ravel(), t2.ravel())
    else:
        ca = a.coefficients.values[0]
        cb = b.coefficients.values[0]
        h = max(ca.shape[0], cb.shape[0]) // 2
        phase = np.linspace(0, 2 * np.pi, 8 * (4 * h + 1), endpoint=False)
        za, zb = series(ca, phase), series(cb, phase)
    amp = np.maximum(np.ptp(za, axis=0) / 2, 1e-300)
    return float(np.max(np.max(np.abs(za - zb), axis=0) / amp))


def _doubled_samples(samples: object) -> int | tuple[int, int]:
    """Twice the AFT samples of an HB result's attr (``"N"`` or ``"N1,N2"``)."""
    parts = [2 * int(v) for v in str(samples).split(",")]
    return parts[0] if len(parts) == 1 else (parts[0], parts[1])


def hb_error(method, system: System, request, data: xr.Dataset) -> xr.Dataset:
    """``data`` with attrs ``error_harmonics`` (the change at 2H), ``error_aliasing`` (the
    change at twice the AFT samples) and ``error_at`` (where they were measured); each a
    fraction of the amplitude, NaN where that solve did not converge. ``method``: the
    ``methods.PERIODIC`` or ``methods.TORUS["hb"]`` entry that made ``data``; ``request``:
    its request (the extra solves without λ1)."""
    from analysis.errors import InputError

    single = replace(request, param=None, start=None, stop=None, progress=None,
                     lyapunov_duration=0.0)
    options = {k: v for k, v in single.options.items() if k != "samples"}
    out, notes = {}, []
    harmonics = data.attrs["harmonics"]
    tries = {"error_harmonics": [replace(single, resolution=h, options=options)
                                 for h in dict.fromkeys((doubled(harmonics),
                                                         scaled(harmonics, 1.5)))],
             "error_aliasing": [replace(single, options={
                 **options, "samples": _doubled_samples(data.attrs["samples"])})]}
    for name, asks in tries.items():
        out[name], why = float("nan"), []
        for ask in asks:
            try:
                out[name] = change(data, method.resized(system, ask))
            except InputError as exc:
                why.append(f"at H = {ask.resolution}: {exc}" if len(asks) > 1 else str(exc))
                continue
            if name == "error_harmonics":
                out["error_harmonics_at"] = str(ask.resolution)
            break
        if why and not math.isfinite(out[name]):
            notes.append(f"{name}: not computed: " + " / ".join(why))
    out.setdefault("error_harmonics_at", str(doubled(harmonics)))
    if not _is_torus(data):
        larger = max(out["error_harmonics"], out["error_aliasing"])
        out["error_bound"] = HB_SAFETY * larger if math.isfinite(larger) else float("nan")
        if not math.isfinite(larger):
            notes.append("error_bound: not computed: it needs both changes")
    param = data.attrs.get("param", "")
    out["error_at"] = (f"{param} = {float(data[param].values[0]):.6g}" if param
                       else "the response")
    out["error_notes"] = "; ".join(notes)
    data = data.copy()
    data.attrs.update(out)
    return data


def scaled(harmonics: object, factor: float) -> int | str:
    """The harmonics ``harmonics`` (``"H"`` or ``"H1,H2"``) × ``factor``, rounded up.

    >>> scaled(10, 1.5), scaled("8,4", 1.5)
    (15, '12,6')
    """
    parts = [math.ceil(factor * int(v)) for v in str(harmonics).split(",")]
    return parts[0] if len(parts) == 1 else ",".join(str(v) for v in parts)


def json_attrs(data: xr.Dataset, keys) -> dict:
    """The attrs ``keys`` that ``data`` has, as JSON values: a NaN is null, and
    ``null_note`` then says why (``error_notes``, or 'not computed')."""
    from analysis.provenance import plain

    out = {k: plain(data.attrs[k], finite=True) for k in keys if k in data.attrs}
    if any(v is None for v in out.values()):
        out["null_note"] = ("null: a number that could not be computed; "
                            + (str(data.attrs.get("error_notes", "")) or "not computed"))
    return out


def _said(data: xr.Dataset, key: str) -> str:
    """An estimate as printed: ``%.1e``, or 'not computed (reason)' for NaN."""
    value = float(data.attrs.get(key, math.nan))
    if math.isfinite(value):
        return f"{value:.1e}"
    why = [n.split(": not computed: ", 1)[1] for n in
           str(data.attrs.get("error_notes", "")).split("; ") if n.startswith(f"{key}:")]
    return f"not computed ({why[0]})" if why else "not computed"


def error_words(data: xr.Dataset) -> str:
    """'error estimate: change at H = 80 …, aliasing …' of an HB response or torus, and
    the periodic response's bound ('' without one); 'not computed (why)' for a NaN."""
    if "error_harmonics" not in data.attrs:
        return ""
    where = "" if data.attrs["error_at"] == "the response" else f" at {data.attrs['error_at']}"
    at = data.attrs.get("error_harmonics_at", doubled(data.attrs["harmonics"]))
    words = (f"error estimate{where}: change at H = {at} "
             f"{_said(data, 'error_harmonics')} of the amplitude, aliasing (2x "
             f"samples) {_said(data, 'error_aliasing')}")
    if "error_bound" in data.attrs:
        words += (f"; error bound {_said(data, 'error_bound')} ({HB_SAFETY:g} x the larger: "
                  "the true error measured 0.90-1.21 x the change against shooting)")
    elif _is_torus(data):
        words += " (an estimate, not a bound)"
    return words
