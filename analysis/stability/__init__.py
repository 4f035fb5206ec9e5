"""Stability analysis: ``lyapunov`` (exponents from the tangent dynamics of the RK4 map),
``periodic`` (periodic orbits by shooting, Floquet multipliers), ``continuation``
(pseudo-arclength continuation with LP/BP/PD/NS detection) and ``classify`` (periodic-n,
quasi-periodic or chaotic). They compute and return results; they report progress only
through a callback they are given.
"""
