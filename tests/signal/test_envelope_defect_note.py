"""Issue 41: the envelope band's note names a defect only where the model has one. A band
holding the housing resonance of the healthy `rotor_housing` model no longer says a BPFO
line there means an outer-race defect; the 6205 outer-defect model's still does."""

from analysis.integrate.simulate import simulate
from analysis.model import load_model
from analysis.signal.envelope import band_note, named_defects


def note_at_resonance(model: str) -> str:
    attrs = simulate(model, duration=0.01, transient=0.0).attrs
    resonance = load_model(model).support_resonances()[0]
    inside, note = band_note(0.8 * resonance, 1.2 * resonance, attrs)
    assert inside, "the band holds the model's resonance"
    return note


def test_healthy_model_names_no_defect():
    note = note_at_resonance("rotor_housing")
    assert "names no outer-race defect" in note and "(an outer-race defect)" not in note
    assert named_defects(simulate("rotor_housing", duration=0.01, transient=0.0).attrs) == ()


def test_defect_model_names_its_defect():
    assert "the model's outer-race defect" in note_at_resonance("model_6205_outer_defect")
