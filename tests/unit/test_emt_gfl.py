"""The EMT farm's aggregated grid-following converter (plant/emt/gfl_farm.py) and the exchange every Ts
(plant/emt/farm_run.py) against closed forms, the phasor plant and the exchange every step.

Tolerances: the aggregate at its operating point returns its start current to 1e-12; under a held voltage
sag its settled current equals turbine_laws.gfl_current_ref's closed form (FRT, reactive priority, the
current limit) to 1e-6 and its PLL locks onto a voltage-angle step to 1e-6 rad; the farm arrangement with
the aggregate starts at the phasor plant's PCC voltage within 1e-4 p.u. and stays within 1e-3 with
nothing happening; the exchange every Ts gives the exchange every step's droop Q and PCC voltage after the
activation within 1e-4 (relative 1e-3 on Q); F7's SCR boundary without a device, with the SC and with the
four SDViSCs of cluster 3 on the EMT backend within 0.1 SCR of the phasor plant's (issue 40's goal): the EMT farm stable at the phasor
boundary + 0.1 and not stable at − 0.1, both with the report's criterion (report/stability.py)."""

from __future__ import annotations

import cmath

import numpy as np
import pytest

from plant import turbine_laws as laws
from plant.emt import frame
from plant.emt.gfl_farm import GflAggregate
from plant.params import TurbineParams

TS = 0.67e-3


def _settle(g: GflAggregate, v: complex, seconds: float) -> complex:
    i = g.current()
    for _ in range(int(seconds / TS)):
        i = g.sample(v)
    return i


def test_aggregate_at_its_operating_point_stays_there():
    v0, i0 = 1.03 * cmath.exp(0.4j), (0.8 - 0.1j) * cmath.exp(0.4j)
    g = GflAggregate(v0, i0 * 0.9, 0.9, TS)
    i = _settle(g, v0, 0.2)
    assert abs(i - i0 * 0.9) < 1e-12 and abs(g.v_dc - 1.0) < 1e-12


@pytest.mark.parametrize("v_sag", [0.85, 0.5, 0.2])
def test_aggregate_in_a_sag_settles_at_the_current_reference_closed_form(v_sag):
    """With its terminal held at a sag (and an angle step of 0.3 rad), the aggregate's current is
    gfl_current_ref's at V_m = |v| (the FRT's reactive current first, the active current in what the
    1.1 p.u. limit leaves) and along the PLL's angle = the voltage's."""
    t = TurbineParams()
    v0, i0 = 1.0 + 0j, 0.9 - 0.05j
    g = GflAggregate(v0, i0, 1.0, TS, t)
    v = v_sag * cmath.exp(0.3j)
    i = _settle(g, v, 2.0)
    assert abs((g.theta - 0.3 + np.pi) % (2 * np.pi) - np.pi) < 1e-6
    p_star = float(laws.dc_link_control(1.0, g.v_dc, g.xd, g.p_me, g.p_me, 1.0, t.kp_dc, t.ki_dc, t.p_me_min,
                                        t.p_me_max)[0])
    i_d, i_q = laws.gfl_current_ref(p_star, -g.q_star, v_sag, t.i_max_gfl, t.frt_v_dip, t.frt_k_qv)
    assert abs(i - complex(float(i_d), float(i_q)) * cmath.exp(0.3j)) < 1e-6
    # the closed form by hand: reactive priority below 0.9, the limit 1.1
    q_hand = -g.q_star / v_sag - t.frt_k_qv * (t.frt_v_dip - v_sag)
    assert float(i_q) == pytest.approx(max(q_hand, -t.i_max_gfl), abs=1e-9)
    assert abs(complex(float(i_d), float(i_q))) <= t.i_max_gfl + 1e-9


def test_farm_with_the_aggregate_starts_at_the_phasor_plants_pcc_and_stays():
    from plant.emt.farm import EmtFarm  # noqa: PLC0415

    for n_visc in (0, 4):
        m = EmtFarm(n_visc, (0.03, 0.05, 0.07, 0.10), farm_model="gfl", exchange="ts")
        assert abs(abs(m.circ.v0["pcc"]) - float(m.phasor_plant.outputs()["v_pcc"])) < 1e-4
        r = m.run(0.3)  # the SDViSCs held at P = 0, Q = 0 (their law would move the PCC: the droop's Q)
        v1 = np.abs(frame.positive_sequence(r["v_pcc"], r["spc"]))[r["spc"]:]
        assert np.max(np.abs(v1 - abs(m.circ.v0["pcc"]))) < 1e-3
        assert np.ptp(r["gfl"]["vm"]) < 1e-3 and np.ptp(r["gfl"]["v_dc"]) < 1e-3


@pytest.mark.slow
def test_exchange_every_ts_gives_the_exchange_every_steps_droop_q():
    from plant.emt.farm import EmtFarm  # noqa: PLC0415

    out = {}
    for ex in ("step", "ts"):
        m = EmtFarm(4, (0.03, 0.05, 0.07, 0.10), e_grid=0.98, wpp_enabled=False, exchange=ex, with_sc=True)
        r = m.run(1.2, events=[(0.2, EmtFarm.activate)])
        v1 = np.abs(frame.positive_sequence(r["v_pcc"], r["spc"]))
        out[ex] = (v1[-1], r["q"][r["t_ts"] > 1.1].mean(axis=0))
    assert out["ts"][0] == pytest.approx(out["step"][0], abs=1e-4)
    assert out["step"][1][0] > 0.05  # the droop's Q built up
    assert np.allclose(out["ts"][1], out["step"][1], rtol=1e-3)


@pytest.mark.slow
@pytest.mark.parametrize("case", ["none", "SC", "4 SDViSCs of cluster 3"])
def test_f7_boundary_on_emt_within_0_1_scr_of_the_phasor_plants(case):
    from report.exp_emt_weak import CASES, emt_scr_run, emt_state  # noqa: PLC0415
    from report.weak_cases import f7_search_settings, search_boundary  # noqa: PLC0415

    t_end, xtol = f7_search_settings(False)
    b = search_boundary(case, t_end, xtol, "stable")[0].value
    assert b is not None
    assert emt_state(emt_scr_run(CASES[case], b + 0.1, t_end)).stable
    assert not emt_state(emt_scr_run(CASES[case], b - 0.1, t_end)).stable
