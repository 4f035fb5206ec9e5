"""Regimes under manufacturing tolerances: distributions of uncertain parameters, quasi-Monte
Carlo draws run as members of the member kernels, regime probabilities with their
intervals, and Sobol' indices (``analysis.uncertainty.study.uncertainty``)."""
