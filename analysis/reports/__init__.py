"""Output for people: ``plots`` (figures), ``paper`` (the seed paper's data and the per-N_b
step shared by the jobs), ``reproduce`` (the reproduction's computation), ``report`` (the
``run`` job's peak table and the reproduction report in Markdown/HTML/JSON) and ``progress``
(progress bars and log lines on the terminal). Imports go one way: ``paper`` ← ``reproduce``
← ``report``. Everything else in ``analysis`` computes; this is where results become files,
figures and text.
"""
