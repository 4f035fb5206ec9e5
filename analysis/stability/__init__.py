"""Stability analysis of a System of any state size n: ``lyapunov`` (n exponents from the
tangent dynamics of the RK4 map), ``periodic`` (periodic orbits by shooting, n Floquet
multipliers, ``stability_boundary`` by bisection on the multipliers, the Liouville check),
``continuation`` (pseudo-arclength continuation on n + 1 unknowns with LP/BP/PD/NS
detection) and ``classify`` (periodic-n, quasi-periodic or chaotic). They compute and
return results; they report progress only through a callback they are given.
"""
