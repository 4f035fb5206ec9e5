"""Generated rotor-bearing models: output of bearingdyn modelgen, never edited by hand.

Regenerate with `bearingdyn generate`; check with `bearingdyn generate --check`.
"""
