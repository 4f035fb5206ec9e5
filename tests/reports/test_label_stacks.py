"""Peak labels do not stack into a tower that stretches the axis (issue 32, section 4): a
label climbs at most ``MAX_LABEL_STEPS`` steps; a smaller peak's label with no room is
left out (the printed table names it) and the data keep the axes' height."""

from __future__ import annotations

import numpy as np

from analysis.reports.plots import (
    LABEL_STEP_PT,
    MAX_LABEL_STEPS,
    label_box,
    peak_labels,
    spectrum_figure,
)
from tests.reports.test_figure_quality import VC_HZ, X_HZ, _run


def test_crowded_labels_stay_within_the_stack_and_the_axis_keeps_its_data():
    # eight named lines within 300 Hz, and one far line that widens the range to 6 kHz:
    # at this scale every low label sits on the others
    lines = [(X_HZ, 2e-6), (2 * X_HZ, 1.6e-6), (3 * X_HZ, 1.5e-6), (VC_HZ, 1.4e-6),
             (VC_HZ - X_HZ, 1.3e-6), (VC_HZ + X_HZ, 1.2e-6), (VC_HZ - 2 * X_HZ, 1.1e-6),
             (2 * VC_HZ - 2 * X_HZ, 1.05e-6), (6000.0, 1.5e-6)]
    fig = spectrum_figure(_run(lines, duration=2.0, dt=5e-5), variables=["x"])
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        notes = peak_labels(ax)
        if not notes:
            continue
        assert max(n.xyann[1] for n in notes) <= 4.0 + MAX_LABEL_STEPS * LABEL_STEP_PT
        boxes = [label_box(n, renderer) for n in notes]
        for i, a in enumerate(boxes):
            assert not any(a.overlaps(b) for b in boxes[i + 1:])
        # the largest line still rises above the lower third of the axes (not squashed)
        low, high = ax.get_ylim()
        top = max(np.max(line.get_ydata()) for line in ax.get_lines()
                  if len(line.get_ydata()) > 100)
        assert np.log10(top / low) / np.log10(high / low) > 0.6, (low, high, top)
