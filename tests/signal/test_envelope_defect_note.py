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


def test_a_band_of_round_off_says_so(cli, tmp_path):
    """The paper model's default envelope band (25-50 kHz) holds an envelope of about
    1e-14 m, 1e-8 of the signal: the note says it is round-off, in the text and the JSON."""
    import json

    nc = tmp_path / "r.nc"
    assert cli("simulate", "vakharia2015", "--duration", "1.2", "--transient", "0.2", "-o",
               str(nc)).returncode == 0
    out = cli("spectrum", str(nc), "--envelope", "--var", "x")
    assert out.returncode == 0, out.stderr
    assert "band 25000:50000 Hz" in out.stdout
    assert "round-off, not the response" in out.stdout
    doc = json.loads(cli("spectrum", str(nc), "--envelope", "--var", "x", "--json").stdout)
    note = doc["envelopes"][0]["note"]
    level = float(note.split("the envelope in this band is ")[1].split()[0])
    assert level < 1e-12, note
    healthy = cli("spectrum", str(nc), "--envelope", "--var", "x", "--band", "100:1000")
    assert "round-off" not in healthy.stdout  # a band with content says nothing of the kind
