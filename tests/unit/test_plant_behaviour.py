"""The paper's experiments on the 50-turbine plant (validation item 4).

Each test asserts the qualitative result the model reproduces and prints the numbers (copied to
docs/plant.md beside the paper's). Where the paper's magnitude is not reproducible with the
documented parameters the test asserts what the physics gives and says so.
"""

import numpy as np
import pytest

from plant.cases import sc_plant, visc_plant
from plant.params import PlantParams
from plant.sim import Plant
from sdc_unit.params import ViscParams

VISC = np.arange(20, 24)  # the leftmost four turbines of cluster 3


def _t90(t, y, t0):
    y0 = y[np.searchsorted(t, t0) - 1]
    dy = y[-1] - y0
    k = np.nonzero((t > t0) & (np.abs(y - y0) >= 0.9 * abs(dy)))[0]
    return t[k[0]] - t0


def test_a_avr_step_visc_faster_than_sc():
    p = sc_plant()
    ref0 = p.sc.v_ref
    r_sc = p.run_offline(6.0, events=[(1.0, lambda q: q.set_avr_ref(ref0 + 0.04))], record_every=10)
    p = visc_plant()
    vp = p.visc_params
    r_v = p.run_offline(3.0, events=[(1.0, lambda q: q.set_visc_params(vp.with_changes(v_ref=vp.v_ref + 0.04)))],
                        record_every=10)
    t90_sc, t90_v = _t90(r_sc["t"], r_sc["v_pcc"], 1.0), _t90(r_v["t"], r_v["v_pcc"], 1.0)
    dv_sc = r_sc["v_pcc"][-1] - r_sc["v_pcc"][0]
    dv_v = r_v["v_pcc"][-1] - r_v["v_pcc"][0]
    print(f"\nSC: V_pcc {r_sc['v_pcc'][0]:.4f} -> {r_sc['v_pcc'][-1]:.4f} (Q_sc {r_sc['q_sc'][-1]:.2f} p.u.,"
          f" V_sc {r_sc['v_sc'][-1]:.4f}), t90 {t90_sc:.2f} s")
    print(f"ViSC x4: V_pcc {r_v['v_pcc'][0]:.4f} -> {r_v['v_pcc'][-1]:.4f}, V_66kV {r_v['v_os'][0]:.4f} ->"
          f" {r_v['v_os'][-1]:.4f} (Q {r_v['q_wt'][-1, VISC].mean():.3f} p.u. each), t90 {t90_v:.2f} s")
    assert dv_sc > 0.005 and dv_v > 0.001, "both raise the PCC voltage"
    assert t90_v < 0.5 * t90_sc, "the ViSC regulates faster than the SC"
    # paper: both settle near 1.035 p.u.; not reachable: 40 Mvar moves a 3570 MVA (SCR 7.14) PCC by ~1 %
    assert dv_sc < 0.02


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
    assert r["v_pcc"][-1] > r["v_pcc"][j0]
    assert np.all(np.diff(q) < 0), "lower droop -> more reactive power"
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
    def run(p):
        r = p.run_offline(3.0, events=[(1.0, lambda q: q.set_scr(2.04))], record_every=10)
        return r["v_pcc"][-1], r["p_grid"][-1]
    none = run(Plant(PlantParams(sc_connected=False)))
    sc = run(sc_plant())
    visc = run(visc_plant())
    print(f"\nSCR 7.14 -> 2.04 at 1 s, V_pcc / P_grid at 3 s: none {none[0]:.3f}/{none[1]:.3f},"
          f" SC {sc[0]:.3f}/{sc[1]:.3f}, 4 ViSC {visc[0]:.3f}/{visc[1]:.3f}")
    assert none[0] < 0.8, "without support the farm cannot hold its voltage at SCR 2.04"
    assert none[0] < sc[0] < visc[0], "the SC helps, the ViSCs help more"


@pytest.mark.slow
def test_e_load_step_battery():
    def run(p, mw):
        r = p.run_offline(4.0, events=[(1.0, lambda q: q.load_step(mw))], record_every=10)
        return r["f_pcc_hz"].min() - 50.0, r["v_dc"][:, VISC].min()
    g = dict(h_grid=5.0, s_grid_mva=1000.0)
    sc = run(sc_plant(h_sc=4.0, **g), 100.0)
    v = run(visc_plant(visc_params=ViscParams(h=4.0), **g), 100.0)
    pb = visc_plant(visc_params=ViscParams(h=4.0), **g)
    pb.set_battery(VISC, True)
    vb = run(pb, 100.0)
    print(f"\n100 MW, H=4: nadir SC {sc[0]:.3f} Hz, ViSC {v[0]:.3f} Hz (v_dc min {v[1]:.3f}),"
          f" ViSC+battery {vb[0]:.3f} Hz (v_dc min {vb[1]:.3f})")
    assert vb[1] > v[1] + 0.1, "the battery holds the DC link up"
    assert vb[0] > v[0], "and the frequency nadir is shallower with the battery"


def _load_step_nadir(p, mw, t_end=4.0):
    """Frequency nadir of the PCC PLL [Hz] and initial RoCoF of the grid source [Hz/s] after +mw at 1 s."""
    r = p.run_offline(t_end, events=[(1.0, lambda q: q.load_step(mw))], record_every=5)
    t, fg = r["t"], (r["f_grid"] - 1.0) * 50.0
    k = (t > 1.0) & (t < 1.1)
    return r["f_pcc_hz"].min() - 50.0, np.polyfit(t[k], fg[k], 1)[0]


@pytest.mark.slow
def test_f_load_50mw_larger_visc_inertia_smaller_dip():
    """Issue item f, first half: +50 MW load, ViSC H = 3 s vs 5 s (and the SC with H = 3 s).

    Reproduced only as an ordering: the dip shrinks with H but by < 0.01 Hz, because the grid
    source (5 s on 1000 MVA = 5000 MWs, assumed) dwarfs 4 x 10 MVA x H = 120-200 MWs and the law's
    D = 90 (2H/D = 67 ms) makes the ViSC follow the grid frequency within a few cycles.
    """
    g = dict(h_grid=5.0, s_grid_mva=1000.0)
    sc = _load_step_nadir(sc_plant(h_sc=3.0, **g), 50.0)
    v3 = _load_step_nadir(visc_plant(visc_params=ViscParams(h=3.0), **g), 50.0)
    v5 = _load_step_nadir(visc_plant(visc_params=ViscParams(h=5.0), **g), 50.0)
    print(f"\n+50 MW: nadir SC H3 {sc[0]:.4f} Hz, ViSC H3 {v3[0]:.4f} Hz, ViSC H5 {v5[0]:.4f} Hz;"
          f" RoCoF SC {sc[1]:.4f}, ViSC H3 {v3[1]:.4f}, H5 {v5[1]:.4f} Hz/s")
    assert v5[0] > v3[0], "larger ViSC inertia: smaller frequency dip"
    assert abs(v5[1]) < abs(v3[1]), "and a smaller initial RoCoF"
    assert v5[0] - v3[0] < 0.01, "the effect is small with a 5000 MWs grid (see docstring)"


@pytest.mark.slow
def test_e_scr_1p51_three_vs_four_visc():
    """Issue item e: SCR 7.14 -> 1.51 at 1 s with 0, 3 and 4 ViSCs (SC out of service).

    Paper: 3 ViSCs lose stability, 4 settle. Here: without ViSCs the farm oscillates (sustained);
    4 ViSCs settle at V_pcc ~ 0.57; 3 ViSCs also settle, at a lower voltage (~ 0.44): the loss of
    stability with 3 is not reproduced (see docs/plant.md).
    """
    def run(n):
        pp = PlantParams(sc_connected=False)
        pp.visc_params = ViscParams()
        p = Plant(pp)
        if n:  # only the n ViSC turbines are taken to P = 0; the others keep producing
            p.set_power_ref(VISC[:n], p=0.0)
            p.reinitialise()
            p.set_mode(VISC[:n], "hd_visc")
        r = p.run_offline(4.0, events=[(1.0, lambda q: q.set_scr(1.51))], record_every=5)
        last = r["t"] > 3.0
        return r["v_pcc"][r["t"] > 1.0].min(), np.ptp(r["v_pcc"][last]), r["v_pcc"][-1], r["p_grid"][-1]
    none, three, four = run(0), run(3), run(4)
    for name, x in (("none", none), ("3 ViSC", three), ("4 ViSC", four)):
        print(f"\nSCR 1.51, {name}: V_pcc min {x[0]:.3f}, peak-to-peak over 3-4 s {x[1]:.4f},"
              f" V_pcc(4 s) {x[2]:.3f}, P_grid(4 s) {x[3]:.3f}", end="")
    assert none[1] > 0.3, "without support: sustained oscillation"
    assert four[1] < 1e-3, "four ViSCs: settles"
    assert four[2] > three[2] and four[0] > three[0], "four ViSCs hold the voltage higher than three"
