"""Issue 32: the default envelope band holds the model's structural resonance, and no fault
line is named in a band that holds none (one line says so instead)."""

import pytest

from analysis.integrate.simulate import simulate
from analysis.signal.envelope import envelope_peaks, names_withheld


@pytest.fixture(scope="module")
def outer():
    return simulate("6205-outer-defect", duration=0.45, transient=0.15)


def test_default_band_holds_the_resonance(outer):
    peaks, band = envelope_peaks(outer, "x_housing", max_peaks=6)
    assert band.chosen == "resonance" and band.low_hz <= 8000 <= band.high_hz
    assert band.resonances_hz and names_withheld(band, outer.attrs) == ""
    assert any(p.label == "BPFO" for p in peaks)


def test_no_fault_line_named_in_a_band_without_resonance(outer):
    peaks, band = envelope_peaks(outer, "x_housing", band=(125000, 240000), max_peaks=6)
    assert peaks and all(p.label is None and not p.also for p in peaks)
    why = names_withheld(band, outer.attrs)
    assert why.startswith("no fault line named") and "8000 Hz lies outside" in why


def test_cli_says_so_in_one_line(cli, tmp_path):
    run = tmp_path / "outer.nc"
    cli("simulate", "6205-outer-defect", "--duration", "0.45", "--transient", "0.15", "-o",
        str(run))
    out = cli("spectrum", str(run), "--envelope", "--var", "x_housing", "--band",
              "125000:240000")
    assert out.returncode == 0, out.stderr
    assert out.stdout.count("no fault line named") == 1
    assert "BPFO" not in out.stdout.split("envelope of x_housing")[1].split("no fault")[0]
