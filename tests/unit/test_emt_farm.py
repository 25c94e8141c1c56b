"""The EMT backend's netlist and F8's farm arrangement (plant/emt/netlist.py, plant/emt/farm.py) against closed
forms and the phasor plant.

Tolerances: the netlist's phasor load flow exact to 1e-12 against a hand divider; DPsim's steady state from
that load flow within 1e-3 p.u. of it (the trapezoidal rule's error at Ts/13 is ~1e-5); the power balance of
sources and resistors within 0.5 % (one-cycle means of instantaneous products); the farm arrangement starts
at the phasor plant's PCC voltage within 1e-4 and stays within 1e-3 with nothing happening; after the SCR step
the PCC's V1 within 1 % of the phasor plant's at the same SCR (the farm a constant-P/Q injection in both, the
WPP's order the same controller); the four SDViSCs share Q by droop (Q·(m_q + x_t) equal within 5 %)."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from plant.emt import frame, netlist
from sdvisc.vocabulary import OMEGA0

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _divider() -> tuple[netlist.Netlist, dict]:
    n = netlist.Netlist()
    e, r1, x1, r2, i_inj = 1.02 + 0.05j, 0.01, 0.15, 1.6, 0.2 - 0.05j
    n.add("V", "src", "s", netlist.GND, e)
    n.add("R", "r1", "s", "m", r1)
    n.add("L", "l1", "m", "n", (x1, x1))
    n.add("R", "load", "n", netlist.GND, r2)
    n.add("I", "inj", "n", netlist.GND, i_inj)
    v_n = (e / complex(r1, x1) + i_inj) / (1.0 / complex(r1, x1) + 1.0 / r2)  # hand nodal solution
    return n, {"e": e, "r1": r1, "x1": x1, "r2": r2, "i_inj": i_inj, "v_n": v_n}


def test_load_flow_matches_the_hand_solution_and_names_bad_elements():
    n, h = _divider()
    v = netlist.load_flow(n)
    assert abs(v["n"] - h["v_n"]) < 1e-12 and abs(v["s"] - h["e"]) < 1e-12
    assert abs(netlist.branch_current(n, v, "load") - h["v_n"] / h["r2"]) < 1e-12
    with pytest.raises(ValueError, match="'x'.*unknown kind"):
        n.add("Q", "x", "a", "b", 1.0)
    with pytest.raises(ValueError, match="'load' added twice"):
        n.add("R", "load", "n", netlist.GND, 1.0)


def test_dpsim_stays_at_the_load_flow_and_balances_power():
    """The circuit built from the netlist starts in its steady state (the current source's and the voltage
    source's scaling agree with the phasor convention) and the sources' power equals the resistors', with
    the branch current as DPsim computes it."""
    from plant.emt.dpsim_env import dpsim  # noqa: PLC0415

    d = dpsim()
    n, h = _divider()
    v0 = netlist.load_flow(n)
    built = netlist.build(n, v0)
    sim = d.Simulation("netlist_check", d.LogLevel.off)
    sim.set_system(built.sys)
    sim.set_domain(d.Domain.EMT)
    step = 0.67e-3 / 13
    sim.set_time_step(step)
    sim.set_final_time(0.2)
    sim.do_init_from_nodes_and_terminals(True)
    sim.start()
    steps = int(0.1 / step)
    vn, vs, i_branch = np.zeros((steps, 3)), np.zeros((steps, 3)), np.zeros((steps, 3))
    for k in range(steps):
        sim.next()
        vn[k] = np.ravel(built.nodes["n"].attr("v").get())
        vs[k] = np.ravel(built.nodes["s"].attr("v").get())
        i_branch[k] = -np.ravel(built.comps["l1"].attr("i_intf").get())  # i_intf of [m, n] flows n -> m
    sim.stop()
    t = (np.arange(steps) + 1) * step
    assert np.max(np.abs(frame.park(vn, t) - h["v_n"])) < 1e-3
    last = slice(steps - 388, steps)  # the last 20 cycles' worth of whole-cycle samples (388 = 20 x 19.4)
    i_src = frame.phasor_to_abc(h["i_inj"], t)
    p_load = np.mean(np.sum(vn[last] ** 2, axis=1)) / h["r2"]
    p_r1 = np.mean(np.sum(i_branch[last] ** 2, axis=1)) * h["r1"]
    p_v = np.mean(np.sum(vs[last] * i_branch[last], axis=1))
    p_i = np.mean(np.sum(vn[last] * i_src[last], axis=1))
    assert p_v + p_i == pytest.approx(p_load + p_r1, rel=5e-3)
    # and in p.u.: the load's power is |V|^2 / R of the phasor solution (the waveforms' scaling)
    assert p_load == pytest.approx(abs(h["v_n"]) ** 2 / h["r2"], rel=5e-3)


def test_dpsim_native_output_does_not_reach_stdout_or_stderr():
    """DPsim's 'Handle event time' (C++ stdout) and its solver's info line (stderr) stay out of the report."""
    code = ("from plant.emt.model import EmtComparison\nprint('before')\n"
            "EmtComparison('none').run(0.03, fault=(0.01, 0.02))\nprint('after')\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env={**os.environ, "PYTHONPATH": ROOT},
                         check=True, capture_output=True, text=True)
    assert out.stdout.split() == ["before", "after"]
    assert "Handle event time" not in out.stdout + out.stderr and "MnaSolverFactory" not in out.stderr


def test_farm_arrangement_starts_at_the_phasor_plants_pcc_and_stays():
    from plant.emt.farm import EmtFarm  # noqa: PLC0415

    m = EmtFarm(4, (0.03, 0.05, 0.07, 0.10), e_grid=0.98, wpp_enabled=False)
    p = m.phasor_plant
    assert abs(abs(m.circ.v0["pcc"]) - float(p.outputs()["v_pcc"])) < 1e-4
    r = m.run(0.15)
    v1 = np.abs(frame.positive_sequence(r["v_pcc"], r["spc"]))[r["spc"]:]
    assert np.max(np.abs(v1 - abs(m.circ.v0["pcc"]))) < 1e-3
    assert np.max(np.abs(r["q"])) < 1e-3  # the SDViSC turbines at P = 0, Q = 0 before the request


@pytest.mark.slow
def test_four_sdviscs_share_q_by_droop_on_emt():
    from plant.emt.farm import EmtFarm  # noqa: PLC0415

    m_q = np.array([0.03, 0.05, 0.07, 0.10])
    m = EmtFarm(4, m_q, e_grid=0.98, wpp_enabled=False)
    r = m.run(1.2, events=[(0.2, EmtFarm.activate)])
    pp = m.phasor_plant.params
    x_t = pp.grid.x_ttr * pp.turbine.s_rated_mva / pp.grid.s_ttr_mva
    q = r["q"][-200:].mean(axis=0)
    assert np.all(np.diff(q) < 0) and q[0] > 0.01
    share = q * (m_q + x_t)
    assert np.ptp(share) <= 0.05 * np.mean(share)


@pytest.mark.slow
def test_scr_step_reaches_the_phasor_plants_steady_state():
    from plant.cases import bare_plant  # noqa: PLC0415
    from plant.emt.farm import EmtFarm  # noqa: PLC0415

    scr = 4.0
    m = EmtFarm(0, scr_after=scr)
    assert abs(abs(m.circ.v0["pcc"]) - float(m.phasor_plant.outputs()["v_pcc"])) < 1e-4  # the parallel branch
    r = m.run(3.0, events=[(1.0, EmtFarm.scr_step)])
    v1 = np.abs(frame.positive_sequence(r["v_pcc"], r["spc"]))
    rp = bare_plant().run_offline(3.0, events=[(1.0, lambda q: q.set_scr(scr))], record_every=10)
    assert v1[r["t"] < 1.0][-1] == pytest.approx(rp["v_pcc"][rp["t"] < 1.0][-1], abs=1e-3)
    assert v1[-1] != pytest.approx(v1[r["t"] < 1.0][-1], abs=1e-3)  # the step happened
    assert v1[-1] == pytest.approx(rp["v_pcc"][-1], rel=0.01)


def test_sequence_inductance_passes_no_zero_sequence_when_open():
    from plant.emt.arrangement import OPEN_SEQUENCE_X, sequence_inductance  # noqa: PLC0415

    lmat = sequence_inductance(0.1, OPEN_SEQUENCE_X) * OMEGA0
    a = np.exp(2j * np.pi / 3)
    assert np.allclose(lmat @ np.array([1, a * a, a]), 0.1 * np.array([1, a * a, a]))
    assert np.allclose(lmat @ np.ones(3), OPEN_SEQUENCE_X * np.ones(3))


def test_sdviscs_activated_before_the_first_step_start_bumpless():
    """An activation at t = 0 (before any sample) starts the law at the load flow's v and i: no transient."""
    from plant.emt.farm import EmtFarm  # noqa: PLC0415

    m = EmtFarm(4, (0.03, 0.05, 0.07, 0.10), e_grid=0.98, wpp_enabled=False)
    r = m.run(0.05, events=[(0.0, EmtFarm.activate)])
    assert np.max(np.abs(r["i"])) < 0.05  # own base: from P = 0, Q = 0, the droops' Q builds up slowly


@pytest.mark.slow
def test_four_sdviscs_stay_at_rest_with_the_farms_active_damping():
    """With K_AD_PARALLEL the four converters in parallel have no growing mode over 3 s (with the phasor
    plant's 0.2 the PCC's V1 swings by 0.4 p.u. by then: K_AD_PARALLEL's docstring)."""
    from plant.emt.farm import EmtFarm  # noqa: PLC0415

    m = EmtFarm(4, (0.03, 0.05, 0.07, 0.10), e_grid=0.98, wpp_enabled=False)
    r = m.run(3.0, events=[(0.0, EmtFarm.activate)])
    v1 = np.abs(frame.positive_sequence(r["v_pcc"], r["spc"]))
    assert np.ptp(v1[r["t"] > 2.0]) < 1e-3
