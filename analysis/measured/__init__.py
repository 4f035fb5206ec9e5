"""Measured signals: records read from instrument files (``records``, ``readers``), bearing
geometries by name (``bearings``), the diagnosis of a record (``diagnose``) and its
comparison with a simulated run (``compare``).

A record is an ``xarray.Dataset`` on a uniform time ``t`` (s) with one variable per channel
and ``kind = "record"`` (``analysis.measured.records``)."""
