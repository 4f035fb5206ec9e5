"""Parameter sweeps: ``grid`` (the axes and the setting every point shares), ``diagram``
(bifurcation diagrams), ``chart`` (stability charts, their points in ``points``),
``executors`` (one interface for serial, process-pool and Dask execution) and ``store`` (each
finished point on disk at once, so that an interrupted sweep resumes). Progress is reported
through a ``(done, total)`` callback; drawing it is ``analysis.reports.progress``'s job.
"""
