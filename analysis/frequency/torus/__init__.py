"""Quasi-periodic responses on a 2-torus by 2-D harmonic balance: the equations and the
2-D Fourier basis (``equations``), one torus with its truncation measures and λ1
(``solve``), tori as Datasets and runs sampled from them (``dataset``) and the torus
branch family of the continuation engine with its stop report (``continuation``). Public
names are importable from ``analysis.frequency``."""
