"""Pins of the paper's numbers the offline testbed reproduces (issue 28, build item 10), computed the
way the report computes them (its own experiment functions), each asserting the testbed's number is
within 10 % of the paper's: a test that fails if the physics regresses, not only if the code breaks.

F6.a: the SC's first fault-current peak (paper ≈ 4 p.u.) lies between the initial symmetrical
current I'' and the IEC 60909 peak κ I''; F6.b: the SC's residual terminal voltage during the SLG
fault (paper > 0.7 p.u.); F7.a: the farm-alone SCR stability boundary (paper 2.04), the report's
bisection with its --quick and its full settings. Offline, about 25 s together."""

from __future__ import annotations

import pytest

from report import exp_grid, exp_weak
from report.registry import Context
from report.verdicts import close_to

REL = 0.10  # the report's "reproduced" tolerance (report/verdicts.py REL_YES)


@pytest.fixture(scope="module")
def f6(tmp_path_factory):
    """Report F6 as `python -m report --only F6` runs it (the figure into a temporary directory)."""
    return exp_grid._f6(Context(out_dir=tmp_path_factory.mktemp("f6"), quick=True))


def test_f6a_the_sc_first_current_peak_brackets_the_papers_4_pu(f6):
    m = f6["F6.a"].measured
    i_initial, i_peak = m["i_sc_initial_phase"], m["i_sc_peak_full_offset"]
    # 2026-12-03: I'' 2.41, κ I'' 4.75 (κ 1.971): 4 p.u. lies in the range the point on wave spans
    assert i_initial * (1.0 - REL) <= 4.0 <= i_peak * (1.0 + REL), (i_initial, i_peak)
    assert 1.9 < m["kappa"] < 2.0  # R/X of the SC branch ≈ 0.01: nearly the full DC offset
    assert f6["F6.a"].verdict == "yes"


def test_f6b_the_sc_residual_terminal_voltage_is_above_the_papers_0p7(f6):
    v = f6["F6.b"].measured["v1_sc_terminal"]
    # 2026-12-03: 0.706 (the paper's bound is "> 0.7"); within 10 % of it and above the bare PCC
    assert v >= 0.7 * (1.0 - REL), v
    assert close_to(v, 0.7) == "yes"
    assert v > f6["F6.b"].measured["v1_pcc_none"]  # the SC lifts its own terminal above the faulted PCC


@pytest.mark.slow
@pytest.mark.parametrize("quick", [True, False], ids=["quick", "full"])
def test_f7a_the_farm_alone_loses_stability_near_scr_2p04(quick):
    t_end, xtol = exp_weak.f7_search_settings(quick)
    b, runs = exp_weak.search_boundary("none", t_end, xtol, "stable")
    # 2026-12-03 (double-loop turbines): 2.102 with --quick (3 s runs, to 0.08), 2.107 in full (4 s, 0.02)
    assert b.value is not None and close_to(b.value, 2.04) == "yes", b
    assert abs(b.value - 2.04) <= REL * 2.04
    lo, hi = b.bracket
    assert not exp_weak.of_run(runs[lo], exp_weak.T_EVENT).stable and exp_weak.of_run(runs[hi], exp_weak.T_EVENT).stable
