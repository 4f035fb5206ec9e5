"""``python -m analysis.cli`` (the Ctrl-C handler of ``analysis.cli.entry`` first)."""

from analysis.cli.entry import main

main()
