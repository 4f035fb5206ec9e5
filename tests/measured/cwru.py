"""The three CWRU records beside the checkout (``../shared/data/cwru/``, README.md there),
and the mark that skips a test without them, with the reason."""

from __future__ import annotations

import pytest

from tests.conftest import ROOT

CWRU = ROOT.parent / "shared" / "data" / "cwru"
IR = CWRU / "12k_Drive_End_IR007_0_105.mat"
OR = CWRU / "12k_Fan_End_OR007@6_0_294.mat"
BALL = CWRU / "12k_Drive_End_B028_0_3005.mat"
needs_cwru = pytest.mark.skipif(not IR.exists(), reason=f"the CWRU records are not in {CWRU} "
                                "(a checkout without ../shared/data/cwru)")
