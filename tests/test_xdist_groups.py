"""The tests grouped with ``xdist_group`` run on one xdist worker (``tests/conftest.py`` turns
``--dist load`` into ``loadgroup``): the bad-input catalogue's commands and the long module
fixtures run once, not once per worker. xdist marks a grouped test by renaming its node id
``<id>@<group>``; where that renaming has no effect (pytest 9.2 with pytest-xdist 3.8: the
node id comes from a structured id) the grouping silently stops and CI takes minutes more.
This test fails then."""

from __future__ import annotations

import os

import pytest

pytestmark = pytest.mark.xdist_group("grouping-check")


def test_a_grouped_test_carries_its_group_on_an_xdist_worker(request):
    if "PYTEST_XDIST_WORKER" not in os.environ:
        pytest.skip("not on an xdist worker (-n N): nothing is grouped")
    assert request.config.option.loadgroup, "the worker does not run --dist loadgroup"
    assert request.node.nodeid.endswith("@grouping-check"), (
        f"xdist did not mark the grouped test ({request.node.nodeid}): its group is not kept "
        "on one worker (pytest-xdist's loadgroup against this pytest)")
