"""Footnotes do not cover axis labels (issue 32, section 4): the layout makes room for a
footnote of any length under the axes' labels."""

from __future__ import annotations

import pytest

from analysis.reports import canvas

NOTE = ("BPFO = VC = 332.23 Hz for a fixed outer race: this band spans VC harmonics k = "
        "76…150 and no structural resonance, so a BPFO line here does not by itself show a "
        "defect (the varying compliance alone makes one); the model has no structural "
        "resonance for impacts to ring. ")


@pytest.mark.parametrize("repeat", [1, 3])
def test_a_footnote_stays_below_the_axis_labels_and_inside_the_figure(repeat):
    fig, ax = canvas.subplots(figsize=(9, 4), layout="constrained")
    ax.plot([0, 2500], [0, 3e-9])
    ax.set_xlabel("frequency (Hz)")
    canvas.footnote(fig, NOTE * repeat)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    note = fig._supxlabel.get_window_extent(renderer)
    label = ax.xaxis.label.get_window_extent(renderer)
    ticks = [t.get_window_extent(renderer) for t in ax.get_xticklabels() if t.get_text()]
    assert note.y1 <= label.y0, (note, label)
    assert all(note.y1 <= t.y0 for t in ticks)
    assert note.x1 <= fig.bbox.width + 1 and note.y0 >= -1  # wrapped, not cut off
    assert fig._supxlabel.get_text().count("\n") >= repeat  # broken into lines
