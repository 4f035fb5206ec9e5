"""``python -m analysis.cli``."""

from analysis.cli import app

app()
