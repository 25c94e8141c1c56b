"""Programmable H at run time (issue 28 item 8, report F4h/F4hnet): an OWFCC ``set_params {h: …}``
changes the SDC's swing equation, the SDC service says what it applied, the scenario file validates,
and what the report measures on a load step. No plant physics is pinned here (it is being changed)."""

from __future__ import annotations

import socket

import numpy as np
import pytest

from report import programmable_h as ph
from report.network_runs import scenario_path
from sdc_unit.bank import ControllerBank
from sdc_unit.params import ViscParams
from sdc_unit.service import SdcService
from sdvisc import wire
from sdvisc.config import SdcConfig
from sdvisc.vocabulary import mask_of
from tests.integration.helpers import sdvisc

TS = 0.67e-3
# a steady operating point at P = 0 (a ViSC has T_m = 0): the swing's torque is zero, nothing moves
STEADY = {"v_d": 1.0, "v_q": 0.0, "i_d": 0.0, "i_q": 0.1, "p": 0.0, "q": -0.1, "v_dc": 1.0, "omega_meas": 1.0}


def _request(h: float) -> dict:
    """The parameter words of an SDC REQUEST asking for ``h`` (what the SDN app forwards)."""
    return {"mask": mask_of({"h": h}), "h": h}


def _bank(h_start: float, n: int = 2) -> ControllerBank:
    bank = ControllerBank(n, TS, method="tustin")
    for slot in range(n):
        bank.start(slot, _request(h_start))
    bank.step(np.arange(n), {k: np.full(n, v) for k, v in STEADY.items()})  # initialised on the first MEAS
    return bank


def swing_step_closed_form(t: np.ndarray, h: float, d: float, torque: float, w0: float) -> np.ndarray:
    """delta(t) of eq. (1), w0 T/(2H s^2 + D s) for a torque step T at t = 0: w0 T/D [t − τ(1 − e^{−t/τ})], τ = 2H/D."""
    tau = 2.0 * h / d
    return w0 * torque / d * (t - tau * (1.0 - np.exp(-t / tau)))


def test_set_params_h_gives_the_swing_the_step_response_of_the_new_inertia():
    bank = _bank(3.0)
    bank.set_params(1, _request(5.0))  # slot 1 only, as the SDC does for one turbine's request
    assert bank.runtime_params(0)["h"] == 3.0 and bank.runtime_params(1)["h"] == 5.0
    swing, p = bank.visc.swing, ViscParams()
    swing.set_operating_point(None, np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2))  # at rest
    torque, n = 0.01, 1500  # 1 s
    delta = np.array([swing.step(np.full(2, torque), np.zeros(2))[0] for _ in range(n)])
    # Tustin takes the sampled step as a ramp over the sample before: the step is at -Ts/2
    t = (np.arange(n) + 0.5) * TS
    for slot, h in ((0, 3.0), (1, 5.0)):
        exact = swing_step_closed_form(t, h, p.d, torque, p.omega0)
        other = swing_step_closed_form(t, 8.0 - h, p.d, torque, p.omega0)
        scale = np.abs(exact).max()
        assert np.abs(delta[:, slot] - exact).max() < 2e-3 * scale, h
        assert np.abs(delta[:, slot] - other).max() > 3e-2 * scale, h  # it is not the other inertia's


def test_a_run_time_change_of_h_steps_as_a_controller_started_with_it():
    changed, started_5, kept_3 = _bank(3.0, 1), _bank(5.0, 1), _bank(3.0, 1)
    changed.set_params(0, _request(5.0))
    disturbed = {k: np.array([v]) for k, v in {**STEADY, "p": 0.05, "i_d": 0.05}.items()}
    runs = [[b.step(np.array([0]), disturbed)[0]["omega"][0] for _ in range(300)] for b in (changed, started_5, kept_3)]
    assert np.allclose(runs[0], runs[1], rtol=0, atol=1e-12)  # the compiled engine uses the new coefficients
    assert np.abs(np.array(runs[0]) - np.array(runs[2])).max() > 1e-5


def test_set_params_before_the_first_measurement_waits_for_it():
    bank = ControllerBank(1, TS)
    bank.start(0, _request(3.0))
    bank.set_params(0, _request(5.0))
    assert bank.pending_params[0] == {"h": 5.0}
    bank.step(np.array([0]), {k: np.array([v]) for k, v in STEADY.items()})
    assert bank.runtime_params(0)["h"] == 5.0 and 0 not in bank.pending_params


# ------------------------------------------------------------------- the SDC service's record of it
CONTROLLER = ("127.0.0.2", wire.PORT_CONTROLLER)
TURBINE = ("127.0.0.1", wire.PORT_TURBINE)


def _datagram_request(cmd: wire.Command, wt: int, req_id: int, **params) -> bytes:
    values = {"req_id": req_id, "cmd": int(cmd), "wt": wt, "sdc_ip": wire.ip_to_i32("127.0.0.1"), "mask": 0,
              "h": 0.0, "d": 0.0, "m_q": 0.0, "v_ref": 0.0, "q_ref": 0.0, "supp": 0, **params}
    return wire.encode(wire.MsgType.REQUEST, values, header=wire.Header(req_id, 0, 0))


def _meas(wt: int, seq: int) -> bytes:
    values = {"wt": wt, "seq": seq, "t_sim": seq * TS, **STEADY}
    return wire.encode(wire.MsgType.MEAS, values, header=wire.Header(seq, 0, 0))


@pytest.fixture
def service(tmp_path):
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.setblocking(False)
    yield SdcService(SdcConfig(step_s=TS, controller_vip="127.0.0.2", capacity=4, out_dir=str(tmp_path)), sock=sock)
    sock.close()


def test_the_sdc_records_the_h_a_set_params_request_put_in_effect(service):
    def feed(datagrams):
        service.serve(datagrams, now=1.0)

    feed([(_datagram_request(wire.Command.START_INSTANCE, 101, 1, **_request(3.0)), CONTROLLER)])
    feed([(_datagram_request(wire.Command.SET_PARAMS, 101, 2, **_request(4.0)), CONTROLLER)])
    early = service.events[-1]
    assert early["cmd"] == "SET_PARAMS" and early["status"] == "OK" and early["pending"] is True
    for seq in (1, 2):
        feed([(_meas(101, seq), TURBINE)])
    feed([(_datagram_request(wire.Command.SET_PARAMS, 101, 3, **_request(5.0)), CONTROLLER)])
    done = service.events[-1]
    assert done["params"] == {"h": 5.0} and done["in_effect"]["h"] == 5.0 and done["pending"] is False
    assert set(done["in_effect"]) >= {"h", "d", "m_q", "v_ref", "q_ref", "supp"}


# --------------------------------------------------------------------------- the scenario file
def test_the_scenario_file_validates_and_asks_for_h_5_between_the_load_steps():
    res = sdvisc("check", str(scenario_path(ph.NAME)), timeout=120)
    assert res.returncode == 0, res.stdout + res.stderr
    c = ph.case()
    assert (c["h_before"], c["h_after"]) == (3.0, 5.0) and len(c["turbines"]) == 4
    (t1, mw1), (t2, mw2) = c["loads"]
    assert mw1 == mw2 > 0 and c["t_on"] < t1 < c["t_set"] < t2 < c["duration_s"]
    assert c["grid"]["h_grid"] > 0  # the frequency can move


# ------------------------------------------------------------------------ what is measured per event
def test_event_metrics_find_the_dip_its_time_and_the_oscillation_frequency():
    t = np.arange(0.0, 10.0, 0.005)
    f_osc, t0 = 0.4, 2.0
    after = np.clip(t - t0, 0.0, None)
    f = 50.0 - 0.05 - np.where(t >= t0, 0.2 * np.sin(2 * np.pi * f_osc * after) * np.exp(-after / 3.0), 0.0)
    m = ph.event_metrics(t, f, t0, 10.0)
    expected_low = np.min(f[t >= t0])
    assert m["nadir_hz"] == pytest.approx(expected_low - 50.0) and m["dip_hz"] == pytest.approx(expected_low - 49.95)
    assert m["t_nadir_s"] == pytest.approx(np.arctan(2 * np.pi * f_osc * 3.0) / (2 * np.pi * f_osc), abs=0.01)
    assert m["osc_hz"] == pytest.approx(f_osc, abs=1.0 / 8.0)  # within the 8 s window's resolution
    windows = ph.event_windows({"loads": [(1.0, 50.0), (8.0, 50.0)]}, 14.0)  # as long as the shortest, 8-14 s
    assert np.allclose(windows, [(1.0, 7.0 - ph.END_MARGIN_S), (8.0, 14.0 - ph.END_MARGIN_S)])
