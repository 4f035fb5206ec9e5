"""Tori as Datasets, their spectrum lines, and time series sampled from them.

``tori_dataset`` writes one torus or a branch of them along ``point``: the torus on its
grid (``torus``: point × state × theta1 × theta2, the states' units), the coefficients,
the spectrum lines (every harmonic k1·F1 + k2·F2 of the set, its frequency in Hz, its
amplitude per state and its name as ``analysis.signal.spectrum`` names lines: X, VC,
VC-2X, …), amplitude, stability (λ1), residuals and provenance (``run_attrs``). The same
Dataset is read back by ``torus_of`` (the ``TorusSystem`` and coefficients of a point), and
``torus_run`` samples a run-like Dataset (``provenance.to_dataset``: one variable per state
over ``t``, the attrs of a run) at any times, which ``spectrum``, ``poincare`` and ``plot``
accept.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.frequency.torus.equations import TorusSystem, parse_frequencies
from analysis.frequency.torus.solve import TorusResponse, stability_of
from analysis.model import System
from analysis.provenance import completed_attrs, run_attrs, system_of_attrs, to_dataset
from analysis.signal.spectrum import frequency_names

SYMBOLS = {"shaft": "X", "vc": "VC", "param": "F"}
"""How a base frequency is written in line names (``vc[name]`` as ``VC[name]``)."""


def symbol(per, several_bearings: bool) -> str:
    """The line-name symbol of a base frequency ``per`` (a ``Period``)."""
    if per.kind == "vc" and per.name and several_bearings:
        return f"VC[{per.name}]"
    return SYMBOLS[per.kind]


def _term(k: int, name: str) -> str:
    return name if abs(k) == 1 else f"{abs(k)}{name}"


def line_name(k1: int, k2: int, ts: TorusSystem, p: np.ndarray | None = None) -> str:
    """The name of the line k1·F1 + k2·F2: the spectrum's own (``frequency_names``, the
    exact combination) for F1, F2 = shaft and a VC; else, and for combinations the spectrum
    does not name (a VC minus more shafts than it, as 4X-VC), written the same way."""
    model = ts.system.model
    several = len(model.bearing_names) > 1
    w1, w2 = ts.omegas(p)
    f = abs(k1 * w1 + k2 * w2) / (2 * math.pi)
    kinds = [per.kind for per in ts.frequencies]
    if sorted(kinds) == ["shaft", "vc"]:
        i_shaft = kinds.index("shaft")
        m, n = (k1, k2) if i_shaft == 0 else (k2, k1)
        if n < 0 or (n == 0 and m < 0):
            m, n = -m, -n
        vc = ts.frequencies[1 - i_shaft]
        shaft_hz, vc_hz = (w1, w2)[i_shaft] / (2 * math.pi), (w1, w2)[1 - i_shaft] / (2 * math.pi)
        vcs = {vc.name: vc_hz} if several and vc.name else {"": vc_hz}
        for label, mm, nn, _ in frequency_names(f, shaft_hz, vcs, 1e-9 * max(f, 1.0),
                                                max(abs(m), 1), max(n, 1)):
            if (mm, nn) == (m, n):
                return label
    names = [symbol(per, several) for per in ts.frequencies]
    terms = [(k2, names[1]), (k1, names[0])] if kinds[0] != "vc" else \
        [(k1, names[0]), (k2, names[1])]
    if k1 * w1 + k2 * w2 < 0:
        terms = [(-k, s) for k, s in terms]
    terms = [(k, s) for k, s in terms if k != 0]
    terms.sort(key=lambda ks: ks[0] < 0)  # a positive term first
    out = ("-" if terms[0][0] < 0 else "") + _term(terms[0][0], terms[0][1])
    for k, s in terms[1:]:
        out += ("+" if k > 0 else "-") + _term(k, s)
    return out


def harmonic_names(ts: TorusSystem) -> list[str]:
    """Names of the coefficient columns: c0, then a(k1,k2), b(k1,k2) in F1, F2 orders."""
    out = ["c0"]
    for k1, k2 in ts.line_orders():
        out += [f"a({k1},{k2})", f"b({k1},{k2})"]
    return out


def tori_dataset(ts: TorusSystem, coefficients: np.ndarray, params: list[np.ndarray],
                 residuals: np.ndarray, residual_fine: np.ndarray, tails: np.ndarray,
                 lambda1: np.ndarray, lambda1_ci95: np.ndarray, drift: np.ndarray,
                 specials: list[str],
                 state_scale: np.ndarray, variables: dict | None = None,
                 **extra: object) -> xr.Dataset:
    """Tori of ``ts`` (coefficients point × (n M), each at its parameter vector of
    ``params``) as a Dataset along ``point`` (module docstring); attrs ``run_attrs`` of
    ``ts.system`` (the first point's parameters), ``method``, ``frequencies``,
    ``harmonics`` (H1,H2), ``samples`` (N1,N2), ``shear`` and ``extra``."""
    system, model = ts.system, ts.system.model
    n, size = ts.n, ts.basis.size
    coeffs = np.asarray(coefficients, dtype=float).reshape(-1, size, n)
    grids = np.array([ts.on_grid(c.reshape(-1)) for c in coeffs])  # point × N1 × N2 × n
    amplitude = np.ptp(grids.reshape(len(coeffs), -1, n), axis=1) / 2
    lines = np.hypot(coeffs[:, 1::2, :], coeffs[:, 2::2, :])  # point × M⁺ × n
    orders = ts.line_orders()
    freq = np.array([np.abs(ts.line_orders() @ np.array(ts.omegas(p))) / (2 * math.pi)
                     for p in params])
    names = [line_name(int(k1), int(k2), ts, params[0]) for k1, k2 in orders]
    lam = np.asarray(lambda1, dtype=float)
    ci = np.asarray(lambda1_ci95, dtype=float)
    drift = np.asarray(drift, dtype=float)
    kinds = [stability_of(a, b, c) for a, b, c in zip(lam, ci, drift, strict=True)]
    stable = np.array([{"stable": 1, "unknown": -1}.get(k, 0) for k in kinds])
    units = model.state_units
    attrs = run_attrs(model, system.structure, dict(system.parameters))
    attrs.update(method="torus harmonic balance (2-D AFT), lambda1 by Lyapunov",
                 frequencies=",".join(str(per) for per in ts.frequencies),
                 harmonics=f"{ts.harmonics[0]},{ts.harmonics[1]}",
                 samples=f"{ts.samples[0]},{ts.samples[1]}", shear=ts.shear, **extra)
    n1, n2 = ts.samples
    data = {
        "torus": (("point", "state", "theta1", "theta2"), np.transpose(grids, (0, 3, 1, 2)),
                  {"long_name": "the torus u(theta1, theta2) on its grid, in the state's "
                                "unit (coordinate state_units); z(t) = u(w1 t, (w2 - shear "
                                "w1) t)"}),
        "amplitude": (("point", "state"), amplitude,
                      {"long_name": "(max - min)/2 of each state over the torus grid, in the "
                                    "state's unit (coordinate state_units)"}),
        "stable": ("point", stable, {"long_name": "1: lambda1 < 0 beyond its 95 % "
                                                  "half-width and drift <= DRIFT_LIMIT, 0: "
                                                  "not, -1: not computed"}),
        "drift": ("point", drift, {"long_name": "largest |z(t) - u(w t)| / amplitude over "
                                                "the last half of the lambda1 run from "
                                                "u(0, 0)"}),
        "special": ("point", np.array(specials, dtype=object)),
        "residual": ("point", np.asarray(residuals, dtype=float),
                     {"long_name": "max |R_i| / (w1 s_i) on the N1 x N2 grid"}),
        "residual_fine": ("point", np.asarray(residual_fine, dtype=float),
                          {"long_name": "max |R_i| / (w1 s_i) of the same coefficients on a "
                                        "grid twice as fine in each hyper-time"}),
        "border": ("point", np.asarray(tails, dtype=float),
                 {"long_name": "largest harmonic on the border of the set / largest "
                               "harmonic (states scaled)"}),
        "lambda1": ("point", lam, {"units": "1/s", "long_name": "largest Lyapunov exponent "
                                   "of the trajectory started on the torus"}),
        "lambda1_ci95": ("point", ci, {"units": "1/s"}),
        "coefficients": (("point", "harmonic", "state"), coeffs,
                         {"long_name": "u = c0 + sum a(k1,k2) cos(k.theta) + b(k1,k2) "
                                       "sin(k.theta), k in the basis's hyper-times"}),
        "line_frequency": (("point", "line"), freq, {"units": "Hz"}),
        "line_amplitude": (("point", "line", "state"), lines,
                           {"long_name": "amplitude sqrt(a^2 + b^2) of the line, in the "
                                         "state's unit"}),
        "line_k1": ("line", orders[:, 0]),
        "line_k2": ("line", orders[:, 1]),
        "state_scale": ("state", np.asarray(state_scale, dtype=float)),
        **(variables or {})}
    return xr.Dataset(data, coords={
        "point": np.arange(len(coeffs)), "state": list(model.state_names),
        "state_units": ("state", [units[s] for s in model.state_names]),
        "theta1": ("theta1", 2 * np.pi * np.arange(n1) / n1, {"units": "rad"}),
        "theta2": ("theta2", 2 * np.pi * np.arange(n2) / n2, {"units": "rad"}),
        "harmonic": harmonic_names(ts), "line": names}, attrs=attrs)


def torus_dataset(response: TorusResponse) -> xr.Dataset:
    """One torus as the Dataset of ``tori_dataset`` (one point), with attrs
    ``converged``, ``iterations`` and ``message``."""
    return tori_dataset(
        response.torus, response.coefficients[None, :], [response.system.p],
        np.array([response.residual]), np.array([response.residual_fine]),
        np.array([response.tail]), np.array([response.lambda1]),
        np.array([response.lambda1_ci95]), np.array([response.drift]), [""],
        response.scale,
        converged=int(response.converged), iterations=response.iterations,
        message=response.message)


def torus_of(data: xr.Dataset, point: int = -1) -> tuple[TorusSystem, np.ndarray]:
    """The ``TorusSystem`` (at the point's parameter when the Dataset is a branch) and the
    coefficients of ``point`` of a torus Dataset."""
    if "torus" not in data or "coefficients" not in data or "frequencies" not in data.attrs:
        raise InputError("torus: the dataset is not a torus result (bearingdyn torus)")
    n_points = data.sizes["point"]
    if not -n_points <= point < n_points:
        raise InputError(f"point: must be in [{-n_points}, {n_points}), got {point}")
    system = system_of_attrs(data.attrs)
    param = data.attrs.get("param", "")
    if param:
        system = system.replace(**{param: float(data[param].values[point])})
    freqs = parse_frequencies(str(data.attrs["frequencies"]), system.model)
    harmonics = tuple(int(v) for v in str(data.attrs["harmonics"]).split(","))
    samples = tuple(int(v) for v in str(data.attrs["samples"]).split(","))
    ts = TorusSystem(system, freqs, harmonics, samples, int(data.attrs.get("shear", 0)),
                     dense=data.attrs.get("solver", "hb") != "shooting")
    return ts, np.asarray(data.coefficients.values[point], dtype=float).reshape(-1)


def check_torus_run(system: System, duration: float, dt: float | None = None,
                    t_start: float = 0.0) -> tuple[float, int]:
    """``(dt, steps)`` of a run sampled from a torus of ``system`` over ``duration`` s
    (``dt``: the spec's step when None), judged before any torus is solved (the command
    line calls it first): ``InputError`` naming the field otherwise."""
    dt = float(system.model.simulation_defaults["dt"] if dt is None else dt)
    for name, value, low in (("duration", duration, 0.0), ("dt", dt, 0.0)):
        if not (math.isfinite(value) and value > low):
            raise InputError(f"{name}: must be a finite number > 0 s, got {value!r}",
                             field=name)
    if not math.isfinite(t_start):
        raise InputError(f"t_start: must be a finite number of s, got {t_start!r}",
                         field="t_start")
    steps = round(duration / dt)
    if steps < 2 or steps > 50_000_000:
        raise InputError(f"duration: {duration:g} s at dt = {dt:g} s gives {steps} samples; "
                         "give between 2 and 5e7", field="duration")
    return dt, steps


def torus_run(source: xr.Dataset | TorusResponse, duration: float, dt: float | None = None,
              t_start: float = 0.0, point: int = -1) -> xr.Dataset:
    """A run-like Dataset sampled from a torus: z(t) = u(ω1 t, ω2 t) at t = t_start +
    k·dt over ``duration`` s (``dt`` default the spec's step), the attrs of a run
    (``completed_attrs``, method ``torus``), so ``spectrum``, ``poincare``, ``classify``
    and ``plot`` read it as they read ``simulate``'s."""
    if isinstance(source, TorusResponse):
        ts, coeffs = source.torus, source.coefficients
    else:
        ts, coeffs = torus_of(source, point)
    system = ts.system
    dt, steps = check_torus_run(system, duration, dt, t_start)
    t = t_start + dt * np.arange(steps + 1)
    z = ts.at_times(coeffs, t)
    attrs = completed_attrs(system, method="torus", dt=dt, save_every=1, duration=duration,
                            transient=0.0, t_start=t_start)
    attrs.update(frequencies=",".join(str(per) for per in ts.frequencies),
                 harmonics=f"{ts.harmonics[0]},{ts.harmonics[1]}")
    return to_dataset(t, z.T, attrs, system.model)
