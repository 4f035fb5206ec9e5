"""bearingdyn model generator: equation spec (TOML) -> SymPy equations -> CasADi code.

Nothing here is needed to *run* a generated model: ``generated/<model>/`` imports only
casadi and numpy.
"""

__version__ = "0.1.0"
