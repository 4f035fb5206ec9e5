"""Integration: the motion of a generated model in time.

``simulate`` (fixed-step RK4 as in the paper, or adaptive CVODES) returns an xarray Dataset
with provenance; ``compiled`` builds the RK4 blocks (C through CasADi, or the CasADi VM) and
caches the compiled libraries; ``checks`` validates the RK4 step against the model's time
scales; ``flow`` gives flow maps over a period and their derivatives (shooting, continuation,
Lyapunov exponents build on them). Nothing here prints or draws.
"""
