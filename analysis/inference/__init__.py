"""Calibration of a model's unknown parameters against tables of observed regimes and
spectrum lines (approximate Bayesian computation on the ensemble engine).

- ``targets``: the target schema, its loader, the built-in ``paper-table2``;
- ``priors``: ``NAME:LO:HI[:log]`` priors;
- ``simulate``: one round's members on the ensemble engine, each row classified and its
  lines named;
- ``abc``: a Sobol first round, then SMC-ABC rounds of shrinking tolerance (``calibrate``);
- ``results``: the posterior as a Dataset and as JSON.
"""
