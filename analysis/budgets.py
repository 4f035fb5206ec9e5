"""Memory the package allows itself: one place for every budget a command is refused by
before it starts (bytes). Each budget bounds a different kind of holding, so they differ:

- ``RUN_MEMORY``: the samples of one run held in memory (``integrate.plan``), and the
  results of one member-kernel call held on the host (``integrate.kernels.members``);
- ``STUDY_MEMORY``: an attractor study's labels, states and a chunk of section points
  (``stability.attractors.study``), half the above since a study holds them beside a
  kernel call's results;
- ``DENSE_MEMORY``: the dense matrices of one harmonic-balance solve with Hill's
  stability, of a torus or of an invariant circle (``frequency``), which LAPACK's
  workspace doubles.
"""

GIB = 2**30
"""Bytes in a gibibyte."""
RUN_MEMORY = 8 * GIB
"""Bytes of one run's samples, or of one member-kernel call's results, in host memory."""
STUDY_MEMORY = 4 * GIB
"""Bytes of an attractor study's labels, states and section chunk in host memory."""
DENSE_MEMORY = 2 * GIB
"""Bytes of the dense matrices of one frequency-domain solve."""
