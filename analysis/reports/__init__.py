"""Output for people: ``plots`` (figures), ``report`` (the paper's case as a job and the
reproduction report in Markdown/HTML) and ``reproduce`` (the reproduction's computation).
Everything else in ``analysis`` computes; this is where results become files, figures and
text.
"""
