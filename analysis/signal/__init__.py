"""Signal analysis of a simulated run: ``spectrum`` (amplitude spectra, peaks named as
combinations of the shaft frequency X and each bearing's varying-compliance frequency VC)
and ``poincare`` (stroboscopic Poincaré sections at the shaft, cage, VC or a parameter's
period), for runs of any model.

Which variables a run has and its frequencies are read from its attrs by
``analysis.provenance`` (``state_names``, ``displacement_names``, ``vc_frequencies``).
"""
