"""A small subset of benchmarks/robustness_matrix.py (issue 42): a run ended at a random moment by
SIGINT or SIGTERM, and a time scale the scenario cannot take: each ends (no hang), with a summary or
one clear line, no traceback, nothing left behind."""

from __future__ import annotations

import random

import pytest

from benchmarks.robustness_matrix import cell
from tests.integration.helpers import ROOT

pytestmark = pytest.mark.network


@pytest.mark.parametrize(("name", "auto", "ending"), [("smoke", False, "SIGINT"), ("link_failure_dr", False, "SIGTERM"),
                                                      ("external_peer", True, "end")])
def test_a_cell_of_the_matrix(name, auto, ending):
    c = cell(ROOT / "scenarios" / f"{name}.yaml", auto, ending, random.Random(42))
    assert c["ok"], c
    if name == "external_peer":  # --time-scale auto with an emulated peer: refused before building
        assert c["refused"] and "--time-scale auto" in c["stderr_tail"][0]
