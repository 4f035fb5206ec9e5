"""Target files as editors leave them: a byte-order mark is skipped, and the file reads as
the same target as without it."""

from __future__ import annotations

from analysis.inference.targets import load_target
from analysis.model import load_model

TEXT = """name = "one-row"
[conditions]
speed_rpm = 5000.0
[[rows]]
n_balls = 8
class = ["quasi-periodic", "periodic-k"]
present = { x = "X" }
"""


def test_a_byte_order_mark_is_skipped(tmp_path):
    model = load_model("vakharia2015")
    plain, marked = tmp_path / "plain.toml", tmp_path / "marked.toml"
    plain.write_text(TEXT, encoding="utf-8")
    marked.write_text(TEXT, encoding="utf-8-sig")
    assert marked.read_bytes().startswith(b"\xef\xbb\xbf")
    a, b = load_target(plain, model), load_target(marked, model)
    assert a.rows == b.rows and a.name == b.name == "one-row"
    assert a.rows[0].classes == ("quasi-periodic", "periodic-k")
    assert a.rows[0].present == (("x", ("X",)),)
