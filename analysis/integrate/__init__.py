"""Integration: the motion of a generated model in time.

``simulate`` (fixed-step RK4 as in the paper, or adaptive CVODES) returns an xarray Dataset
with provenance; ``compiled`` builds the RK4 blocks (C through CasADi, or the CasADi VM) and
caches the compiled libraries; ``checks`` validates the RK4 step against the model's time
scales; ``flow`` gives flow maps over a period and their derivatives (shooting, continuation,
Lyapunov exponents build on them); ``ensemble`` runs many initial states or parameter
points of one System together (``StroboscopicMap``, ``ensemble``), each member ``simulate``'s
run bit for bit; ``kernels`` is the one writer of compiled member code (states, or states
and a tangent for λ1) and its CPU (OpenMP) and CUDA (CuPy) builds, ``kernels.run_members``
the call every ensemble, chart and brute-force diagram goes through. Nothing here prints or
draws.
"""

from analysis.integrate.ensemble import StroboscopicMap, ensemble

__all__ = ["StroboscopicMap", "ensemble"]
