"""Signal analysis of a simulated run: ``spectrum`` (amplitude spectra, peaks named as
combinations of the shaft frequency X and the varying-compliance frequency VC) and
``poincare`` (stroboscopic Poincaré sections at the shaft, cage or VC period).
"""
