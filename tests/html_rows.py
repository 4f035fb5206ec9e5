"""The rows of every table of an HTML fragment, as text cells (for rich displays)."""

from __future__ import annotations

from html.parser import HTMLParser


class TableRows(HTMLParser):
    """``feed(html)``, then ``rows``: one list of cell texts (``td`` and ``th``) per ``tr``."""

    def __init__(self):
        super().__init__()
        self.rows: list[list[str]] = []
        self._row: list[str] | None = None

    def handle_starttag(self, tag, attrs):
        if tag == "tr":
            self._row = []
        elif tag in ("td", "th") and self._row is not None:
            self._row.append("")

    def handle_endtag(self, tag):
        if tag == "tr" and self._row is not None:
            self.rows.append(self._row)
            self._row = None

    def handle_data(self, data):
        if self._row:
            self._row[-1] += data


def table_rows(html: str) -> list[list[str]]:
    parser = TableRows()
    parser.feed(html)
    return parser.rows
