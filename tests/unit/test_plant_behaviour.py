"""The paper's experiments on the 50-turbine plant (validation item 4).

Each test asserts the qualitative result the model reproduces and prints the numbers (copied to
docs/plant.md beside the paper's). Where the paper's magnitude is not reproducible with the
documented parameters the test asserts what the physics gives and says so.
"""

import numpy as np
import pytest

from plant.cases import COMPARISON_UNIT, bare_plant, comparison_visc_plant, sc_plant, visc_plant
from sdc_unit.params import ViscParams

VISC = np.arange(20, 24)  # the leftmost four turbines of cluster 3


def _t90(t, y, t0):
    y0 = y[np.searchsorted(t, t0) - 1]
    dy = y[-1] - y0
    k = np.nonzero((t > t0) & (np.abs(y - y0) >= 0.9 * abs(dy)))[0]
    return t[k[0]] - t0


def test_a_avr_step_visc_faster_than_sc():
    """The comparison arrangement (both at the onshore PCC): each device's terminal rises by about the
    paper's 0.035 (pinned in test_plant_wpp.py), the SDViSC faster; the PCC itself moves < 0.5 %."""
    p = sc_plant()
    ref0 = p.sc.v_ref
    r_sc = p.run_offline(6.0, events=[(1.0, lambda q: q.set_avr_ref(ref0 + 0.04))], record_every=10)
    p = comparison_visc_plant()
    vp = p.visc_params
    r_v = p.run_offline(3.0, events=[(1.0, lambda q: q.set_visc_params(vp.with_changes(v_ref=vp.v_ref + 0.04)))],
                        record_every=10)
    v_t_sc, v_t_v = r_sc["v_sc"], r_v["v_wt"][:, COMPARISON_UNIT]
    sc0, v0 = v_t_sc[r_sc["t"] < 1.0][-1], v_t_v[r_v["t"] < 1.0][-1]  # just before the step (not t = 0's start)
    t90_sc, t90_v = _t90(r_sc["t"], v_t_sc, 1.0), _t90(r_v["t"], v_t_v, 1.0)
    print(f"\nSC: V_t {sc0:.4f} -> {v_t_sc[-1]:.4f}, V_pcc {r_sc['v_pcc'][0]:.4f} -> {r_sc['v_pcc'][-1]:.4f}"
          f" (Q_sc {r_sc['q_sc'][-1]:.2f} p.u.), t90 {t90_sc:.2f} s")
    print(f"SDViSC 40 MVA: V_t {v0:.4f} -> {v_t_v[-1]:.4f}, V_pcc {r_v['v_pcc'][0]:.4f} -> {r_v['v_pcc'][-1]:.4f}"
          f" (Q {r_v['q_wt'][-1, COMPARISON_UNIT]:.3f} p.u.), t90 {t90_v:.2f} s")
    assert v_t_sc[-1] - sc0 > 0.025 and v_t_v[-1] - v0 > 0.025, "both raise their terminal"
    assert t90_v < 0.5 * t90_sc, "the ViSC regulates faster than the SC"
    # 40 Mvar move a 3570 MVA (SCR 7.14) PCC by well under 1 % (and the plant controller holds it)
    assert abs(r_sc["v_pcc"][-1] - r_sc["v_pcc"][0]) < 0.005 and abs(r_v["v_pcc"][-1] - r_v["v_pcc"][0]) < 0.005


def test_b_parallel_droop_sharing():
    mq = np.array([0.03, 0.05, 0.07, 0.10])
    p = visc_plant(visc_params=ViscParams(m_q=mq), activate=False, e_grid=0.955)
    r = p.run_offline(3.0, events=[(1.0, lambda q: q.set_mode(VISC, "hd_visc"))], record_every=10)
    j0 = np.searchsorted(r["t"], 0.99)
    q = r["q_wt"][-1, VISC]
    x_t = p.params.grid.x_ttr * p.params.turbine.s_rated_mva / p.params.grid.s_ttr_mva
    share = q * (mq + x_t)
    print(f"\nV_pcc {r['v_pcc'][j0]:.4f} -> {r['v_pcc'][-1]:.4f}; V_66kV {r['v_os'][j0]:.4f} -> {r['v_os'][-1]:.4f}")
    print(f"Q = {np.round(q, 4)} p.u.; Q*m_q = {np.round(q * mq, 4)}; Q*(m_q + x_t) = {np.round(share, 4)}")
    # the plant controller holds the PCC on its droop line: the SDViSCs' Q replaces the farm's, the
    # PCC moves by at most its droop x the farm order's change
    assert abs(r["v_pcc"][-1] - r["v_pcc"][j0]) < 0.01
    # the plant controller holds the farm's terminals above the SDViSCs' V* = 1: they absorb; the
    # sharing is by droop all the same (|Q| falls with m_q)
    assert np.all(np.diff(np.abs(q)) < 0), "lower droop -> more reactive power"
    # each ViSC regulates its own terminal, behind its own transformer x_t: Q_i ~ 1/(m_q,i + x_t)
    assert np.ptp(share) / share.mean() < 0.03


FAULT = [(1.0, lambda q: q.fault(True)), (1.2, lambda q: q.fault(False))]


def _during(r):
    return (r["t"] > 1.05) & (r["t"] < 1.19)


def test_c_fault_visc_limited_sc_several_pu():
    r_sc = sc_plant().run_offline(2.0, events=FAULT, record_every=5)
    r_v = visc_plant().run_offline(2.0, events=FAULT, record_every=5)
    f_sc, f_v = _during(r_sc), _during(r_v)
    i_v = r_v["i_wt"][:, VISC]
    print(f"\nSC case: V1_pcc {r_sc['v_pcc'][f_sc].mean():.3f}, phases {np.round(r_sc['v_pcc_ph'][f_sc].mean(0), 3)},"
          f" SC |I1| {r_sc['i_sc'][f_sc].max():.2f} p.u., SC max phase current {r_sc['i_sc_ph_max'][f_sc].max():.2f} p.u.")
    print(f"ViSC case: V1_pcc {r_v['v_pcc'][f_v].mean():.3f}, phases {np.round(r_v['v_pcc_ph'][f_v].mean(0), 3)},"
          f" ViSC |i| max {i_v.max():.3f}, mean during {i_v[f_v].mean():.3f} p.u., Q {r_v['q_wt'][f_v][:, VISC].mean():.2f}")
    print(f"after clearing (t=2 s): V_pcc SC {r_sc['v_pcc'][-1]:.3f}, ViSC {r_v['v_pcc'][-1]:.3f}")
    assert i_v[f_v].mean() == pytest.approx(1.5, abs=0.02), "ViSC current held at the 1.5 p.u. limit"
    assert i_v.max() < 1.6
    assert r_sc["i_sc_ph_max"][f_sc].max() > 2.0, "the SC delivers several p.u. (faulted phase)"
    assert r_sc["q_sc"][f_sc].mean() > 0.5 and r_v["q_wt"][f_v][:, VISC].mean() > 0.5, "both inject Q"
    assert abs(r_sc["v_pcc"][-1] - r_sc["v_pcc"][0]) < 0.02 and abs(r_v["v_pcc"][-1] - r_v["v_pcc"][0]) < 0.02


@pytest.mark.slow
def test_d_weak_grid_ordering():
    """SCR 7.14 -> 2.04 and -> 1.84 at 1 s, 5 s (the paper's Fig. Compare_Weak): at 2.04 the farm
    alone keeps oscillating (growing, then held by the converters' limits), with the SC or the 40 MVA
    SDViSC at the PCC it settles in the band; at 1.84 the SC case oscillates too, the SDViSC one
    settles (the SDViSC stabilises a weaker grid). The boundaries (report F7, 2026-12-04): SC 1.885,
    SDViSC 1.803 — 1.84 lies between them (1.8 did with the 0.10 step-ups' 1.791, not with 0.12's)."""
    def run(p, scr):
        r = p.run_offline(5.0, events=[(1.0, lambda q: q.set_scr(scr))], record_every=10)
        last = r["t"] > 4.0
        return r["v_pcc"][-1], np.ptp(r["v_pcc"][last])
    none, sc, visc = run(bare_plant(), 2.04), run(sc_plant(), 2.04), run(comparison_visc_plant(), 2.04)
    sc19, visc19 = run(sc_plant(), 1.84), run(comparison_visc_plant(), 1.84)
    print(f"\nV_pcc at 5 s / p-p over 4-5 s: SCR 2.04 none {none[0]:.3f}/{none[1]:.3f}, SC {sc[0]:.3f}/{sc[1]:.4f},"
          f" SDViSC {visc[0]:.3f}/{visc[1]:.4f}; SCR 1.84 SC {sc19[0]:.3f}/{sc19[1]:.3f}, SDViSC {visc19[0]:.3f}/{visc19[1]:.4f}")
    # issue 39: with the plant controller after IEC 61400-27-1 (plant/wpp.py) the loss without support is a
    # sag, not the former controller's limit cycle: the step's dip takes V_pcc under u_WPqdip 0.8, the
    # controller freezes until 0.9, and the turbines sit at their current limit / Q limitation
    assert none[1] < 0.02 and none[0] < 0.9, "without support: damped, out of the band at SCR 2.04"
    assert sc[1] < 0.02 and visc[1] < 0.02 and min(sc[0], visc[0]) > 0.9, "with either it settles in the band"
    # at 1.84 both sag now (F7's step boundaries with the IEC controller: SC 2.01, SDViSC 1.96, --quick)
    assert max(sc19[0], visc19[0]) < 0.9 and max(sc19[1], visc19[1]) < 0.02


@pytest.mark.slow
def test_e_scr_1p51_three_vs_four_visc():
    """Issue item e: SCR 7.14 -> 1.51 at 1 s with 0, 3 and 4 SDViSCs of cluster 3 (SC out), 5 s.

    Paper: 3 SDViSCs hold until about 3 s, then lose stability; 4 settle. Here: without SDViSCs the
    farm settles below 0.9 p.u.; 3 and 4 both return into the band (4 higher in its lowest voltage):
    the loss of stability with 3 is not reproduced (docs/plant.md; report F9)."""
    def run(n):
        p = visc_plant(n) if n else bare_plant()
        r = p.run_offline(5.0, events=[(1.0, lambda q: q.set_scr(1.51))], record_every=5)
        last = r["t"] > 4.0
        return r["v_pcc"][r["t"] > 1.0].min(), np.ptp(r["v_pcc"][last]), r["v_pcc"][-1]
    none, three, four = run(0), run(3), run(4)
    for name, x in (("none", none), ("3 SDViSC", three), ("4 SDViSC", four)):
        print(f"\nSCR 1.51, {name}: V_pcc min {x[0]:.3f}, p-p over 4-5 s {x[1]:.4f}, V_pcc(5 s) {x[2]:.3f}", end="")
    assert none[2] < 0.9, "without SDViSCs the farm settles below the band"
    # issue 39: with the plant controller after IEC 61400-27-1 the dip (V_pcc < u_WPqdip 0.8) freezes it and
    # four SDViSCs no longer bring V_pcc back into the band (report F9: stable from five, --quick)
    assert four[1] < 0.02 and four[2] > three[2], "four SDViSCs: damped, higher than three"
    assert four[0] > three[0], "four hold the voltage higher in the transient than three"
