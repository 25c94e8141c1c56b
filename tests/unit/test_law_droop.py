"""The droop law (sdc_unit/laws/droop.py) against closed forms: its steady state, its bumpless start,
and its equivalence with the swing equation [D'Arco & Suul 2014] through the generic trapezoid."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from scipy.integrate import solve_ivp

from sdc_unit.bank import ControllerBank
from sdc_unit.law_trapezoid import TrapezoidControllers
from sdc_unit.laws import LAWS
from sdc_unit.laws.droop import DroopParams
from sdc_unit.params import ViscParams
from sdvisc import wire
from sdvisc.vocabulary import MEAS_FIELDS

TS = 0.67e-3
OP = {"v_d": 1.0, "v_q": 0.02, "i_d": 0.5, "i_q": -0.1, "p": 0.5, "q": 0.1, "v_dc": 1.0, "omega_meas": 1.0}


def _rows(values: dict, n: int = 1) -> np.ndarray:
    return np.array([[values[k]] * n for k in MEAS_FIELDS])


def _run(ctrl: TrapezoidControllers, values: dict, steps: int) -> np.ndarray:
    """omega and e_mag of instance 0 after each of ``steps`` samples on held ``values``."""
    out = []
    for _ in range(steps):
        _, o, _ = ctrl.advance_slots(np.array([0]), _rows(values))
        out.append((o[5, 0], o[6, 0]))  # CTRL_OUTPUTS: ..., delta, omega, e_mag
    return np.array(out)


def test_steady_state_is_the_droop_line():
    """At constant P, Q: omega = 1 + m_p (P* - P), E = V* + m_q (Q* - Q) [Rocabert 2012, eqs. (2)-(3)]."""
    p = DroopParams()
    ctrl = TrapezoidControllers(LAWS["droop"], 1, TS)
    ctrl.initialise([0], SimpleNamespace(**OP))
    held = dict(OP, p=0.3, q=-0.2)
    last = _run(ctrl, held, round(1.5 / TS))[-1]  # 1.5 s = 22 filter time constants
    assert abs(last[0] - (1.0 + p.m_p * (p.p_ref - 0.3))) < 1e-9
    assert abs(last[1] - (p.v_ref + p.m_q * (p.q_ref - (-0.2)))) < 1e-9


def test_frequency_follows_the_equivalent_swing_equation():
    """D'Arco & Suul 2014: with m_p = 1/D and omega_c = D/(2H) the droop's speed is the swing
    equation's 2H dω/dt = P* − P − D(ω − 1) (the ViSC's H, D): the trapezoid's trajectory from the
    start (ω = 1) under held P matches scipy's solution of the swing equation to 1e-6 p.u."""
    visc = ViscParams()
    ctrl = TrapezoidControllers(LAWS["droop"], 1, TS)
    ctrl.initialise([0], SimpleNamespace(**OP))
    omega = _run(ctrl, OP, round(0.4 / TS))[:, 0]
    t = TS * np.arange(1, len(omega) + 1)
    swing = solve_ivp(lambda _t, w: [(0.0 - OP["p"] - visc.d * (w[0] - 1.0)) / (2 * visc.h)], (0.0, t[-1]), [1.0],
                      t_eval=t, rtol=1e-11, atol=1e-13)
    assert np.ptp(omega) > 1e-3  # it moves: 0.5 p.u. on a 1/90 droop is 5.6e-3 p.u.
    assert np.max(np.abs(omega - swing.y[0])) < 1e-6


def test_start_is_bumpless():
    """The first output is the converter voltage the turbine applies: v + (r_f + j l_f) i, speed 1."""
    p = DroopParams()
    ctrl = TrapezoidControllers(LAWS["droop"], 2, TS)
    ctrl.initialise([1], SimpleNamespace(**OP))
    v, i = OP["v_d"] + 1j * OP["v_q"], OP["i_d"] + 1j * OP["i_q"]
    expected = v + (p.r_f + 1j * p.l_f) * i
    assert abs(ctrl.last["v_ref_d"][1] - expected.real) < 1e-12
    assert abs(ctrl.last["v_ref_q"][1] - expected.imag) < 1e-12
    assert ctrl.last["omega"][1] == 1.0 and ctrl.last["i_ref_d"][1] == OP["i_d"]


def test_the_bank_runs_it_and_a_request_sets_its_runtime_words():
    """Through ControllerBank as the SDC service steps it: a REQUEST's v_ref moves E by the step; a
    word the law does not have (h) is not its to set."""
    bank = ControllerBank(3, TS, law="droop")
    bank.start(0, {"mask": int(wire.ParamMask.H), "h": 7.0})
    out, valid = bank.step(np.array([0]), _rows(OP))
    assert valid.all() and bank.runtime_params(0) == {"v_ref": 1.0, "q_ref": 0.0, "m_q": 0.02}
    for _ in range(3000):
        out, _ = bank.step(np.array([0]), _rows(OP))
    before = out["e_mag"][0]
    bank.set_params(0, {"mask": int(wire.ParamMask.V_REF), "v_ref": 1.03})
    out, _ = bank.step(np.array([0]), _rows(OP))
    assert abs(out["e_mag"][0] - before - 0.03) < 1e-6


def test_the_sdc_core_answers_with_the_droop_law(tmp_path):
    """sdc.law: droop reaches the service's core: a started turbine's first MEAS is answered by a
    CTRL whose voltage reference is the droop law's bumpless start (v + (r_f + j l_f) i)."""
    from sdc_unit.core import SdcCore
    from sdvisc.config import SdcConfig
    from sdvisc.vocabulary import BLANK_REQUEST_PARAMS

    sdn_app = ("127.0.0.2", wire.PORT_CONTROLLER)
    core = SdcCore(SdcConfig(step_s=TS, controller_vip=sdn_app[0], capacity=4, out_dir=str(tmp_path), law="droop"))
    start = {"req_id": 1, "cmd": int(wire.Command.START_INSTANCE), "wt": 101, "sdc_ip": 0, **BLANK_REQUEST_PARAMS}
    core.handle([(wire.encode(wire.MsgType.REQUEST, start, header=wire.Header(1, 0, 0)), sdn_app)], 10.0)
    meas = wire.encode(wire.MsgType.MEAS, {"wt": 101, "seq": 1, "t_sim": TS, **OP}, header=wire.Header(1, 50, 0))
    out = core.handle([(meas, ("10.0.1.1", 40000))], 10.001)
    answers = [wire.decode(d, header=True) for d, _, _ in out.sends]
    ctrl = [m for m in answers if m.type == wire.MsgType.CTRL]
    assert len(ctrl) == 1
    p = DroopParams()
    v, i = OP["v_d"] + 1j * OP["v_q"], OP["i_d"] + 1j * OP["i_q"]
    expected = v + (p.r_f + 1j * p.l_f) * i
    # one trapezoid step from the start on the same sample moves it by far less than 1e-3 p.u.
    assert abs(ctrl[0].values["v_ref_d"] - expected.real) < 1e-3
    assert abs(ctrl[0].values["v_ref_q"] - expected.imag) < 1e-3
