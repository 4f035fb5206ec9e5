"""Linear analyses of finite-element rotors (``modelgen.fe``): damped natural frequencies,
log decrements and whirl over speed with critical speeds (``campbell``), and the 1X
unbalance response at a node (``unbalance``)."""

from analysis.linear.campbell import Campbell, CriticalSpeed, campbell, damped_modes
from analysis.linear.unbalance import UnbalanceResponse, unbalance_response

__all__ = ["Campbell", "CriticalSpeed", "UnbalanceResponse", "campbell", "damped_modes",
           "unbalance_response"]
