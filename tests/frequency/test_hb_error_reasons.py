"""Issue 41: where an HB error estimate cannot be made, the reason is printed in its place
(never a bare "nan"), stored in ``error_notes``, and the JSON holds null with a note; a
doubled solve that is refused is tried at 1.5H first."""

import json
import math

from analysis.errors import InputError
from analysis.frequency.accuracy import error_words, hb_error, json_attrs
from analysis.frequency.methods import PERIODIC, Request
from analysis.model import System

DUFFING = dict(linear_stiffness=1.0, cubic_stiffness=0.5, damping=0.1, forcing_amplitude=0.3,
               speed_rpm=12.0)


class Refusing:
    """The periodic HB method, refusing the solves whose harmonics are in ``refused`` and
    every solve with more samples when ``samples`` is False."""

    def __init__(self, refused, samples=True):
        self.refused, self.samples = refused, samples

    def resized(self, system, request):
        if request.resolution in self.refused:
            raise InputError(f"harmonics: {request.resolution} need too much memory")
        if not self.samples and "samples" in request.options:
            raise InputError("hb: no periodic response found (no convergence)")
        return PERIODIC["hb"].resized(system, request)


def test_reasons_in_place_of_nan():
    system = System.make("duffing", **DUFFING)
    request = Request(6, period="shaft")
    data = PERIODIC["hb"].run(system, request)
    falls_back = hb_error(Refusing({12}), system, request, data)
    assert falls_back.attrs["error_harmonics_at"] == "9"  # 1.5H when 2H is refused
    assert math.isfinite(falls_back.attrs["error_harmonics"])
    assert "change at H = 9 " in error_words(falls_back)
    nothing = hb_error(Refusing({12, 9}, samples=False), system, request, data)
    words = error_words(nothing)
    assert "nan" not in words.lower()
    assert ("change at H = 12 not computed (at H = 12: harmonics: 12 need too much memory / "
            "at H = 9: harmonics: 9 need too much memory)") in words
    assert "aliasing (2x samples) not computed (hb: no periodic response found" in words
    assert "error bound not computed (it needs both changes)" in words
    found = json.loads(json.dumps(json_attrs(nothing, ("error_harmonics", "error_aliasing",
                                                       "error_bound", "error_notes")),
                                  allow_nan=False))
    assert found["error_harmonics"] is None and found["error_bound"] is None
    assert "not computed" in found["null_note"]
