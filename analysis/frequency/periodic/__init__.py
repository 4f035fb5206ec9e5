"""Periodic responses by harmonic balance: the AFT equations (``harmonic``), Hill's
stability (``hill``), one response and its convergence in H (``solve``) and the branch
family of the continuation engine (``continuation``). Public names are importable from
``analysis.frequency``."""
