"""The stepped run of F8's farm arrangement (plant/emt/farm.py's ``EmtFarm.run``): DPsim's solver between
Python's controllers, in one of two exchanges.

* ``step``: the SDViSCs' ViSC law and their active damping, and the SC's rotor and AVR, every circuit step
  (51.5 µs; the HD ViSC), everything recorded every step;
* ``ts``: the exchange every Ts = 0.67 ms (13 circuit steps), as the SDC drives the paper's converter: the
  SDC's discrete ViSCs (sdc_unit.discrete.DiscreteVisc, Tustin, the four in one call, v_ref held over Ts:
  the paper's SDViSC), the SC's rotor and AVR
  advanced over Ts (forward Euler, E'' held), the converter's active damping inside the circuit at every
  step as its exact equivalent. With v_conv = v_ref + k_ad phi - k_ad v_t at the converter behind
  r_f + j l_f to its terminal v_t, Kirchhoff's law gives v_t = (v_ref + k_ad phi)/(1 + k_ad)
  - (r_f i + (l_f/omega0) di/dt)/(1 + k_ad): a source (v_ref + k_ad phi)/(1 + k_ad) behind the filter
  divided by 1 + k_ad (the netlist's ``damping_k``), the same filter current, phi (the 50 rad/s low-pass)
  updated every Ts. Recorded: the PCC's phases every step, the rest every Ts (``t_ts``), or every step
  with ``EmtFarm.record_every_step`` (the exchange still every Ts; instantaneous peaks need it).

The aggregated farm (FarmInjection or GflAggregate) is updated every Ts in both.

The SDViSCs' law measures (``EmtFarm.meas``, frame.MEASUREMENTS) the terminal voltage's and the converter
current's raw Park phasors at the exchange's step (``park``), their positive sequence (``dsc``: quarter-cycle
delayed-signal cancellation at the circuit's step, frame.QuarterCycleDsc, the same filter for both exchanges:
``ts`` reads the Park phasors also d = T0/4 steps before each sample), or the raw v, i with P + jQ of the positive
sequence (``dsc_pq``: the swing's T_e and the AVR's droop on positive-sequence power; the inner current loop and
its feed-forward on the raw phasors), or that with the current's positive sequence as well (``dsc_ipq``: the
current loop, limiter and power on the positive sequence, the terminal voltage raw: its feed-forward through the
filter's 5 ms is unstable with the law every step, docs/plant.md "F1"). The converter's active damping
acts on the raw terminal voltage in all (it is the converter's own circuit-level loop).
"""

from __future__ import annotations

import math
import time

import numpy as np

from plant.emt import frame, netlist
from plant.emt.dpsim_env import dpsim, emt_simulation, native_stdout_silenced
from sdvisc.vocabulary import F_NOMINAL_HZ

EXCHANGES = ("step", "ts")
SQRT3 = math.sqrt(3.0)


def sdc_measurements(last: list, k_unit: float, s_net: list | None = None) -> np.ndarray:
    """The SDC's MEAS rows (sdvisc.vocabulary.MEAS_FIELDS: v_d, v_q, i_d, i_q, p, q, v_dc, omega_meas) of each
    SDViSC's (terminal voltage, converter current [network base]) phasors, own base; v_dc, omega 1; p + jq
    v conj(i), or ``s_net`` / k_unit where given (``dsc_pq``)."""
    rows = np.ones((8, len(last)))
    for j, (v, i_net) in enumerate(last):
        i = i_net / k_unit
        s = v * i.conjugate() if s_net is None else s_net[j] / k_unit
        rows[:6, j] = v.real, v.imag, i.real, i.imag, s.real, s.imag
    return rows


def sdc_sample(sdc, last: list, k_unit: float, s_net: list | None = None) -> list[complex]:
    """One sample of the SDC's discrete ViSCs (sdc_unit.discrete.DiscreteVisc, all units at once): their v_ref."""
    sdc.advance(sdc_measurements(last, k_unit, s_net))
    return (sdc.last["v_ref_d"] + 1j * sdc.last["v_ref_q"]).tolist()


def _law_state(m) -> tuple[list, list]:
    """(delta, E) of each SDViSC's law now: the SDC's last outputs (``ts``), the continuous law's state and
    output (``step``); NaN where not active."""
    if m.sdc is not None:
        return m.sdc.last["delta"].tolist(), m.sdc.last["e_mag"].tolist()
    nan = float("nan")
    return ([nan if u is None else float(u.x[0]) for u in m.units],
            [nan if u is None else float(u.e_mag) for u in m.units])


class _Poles:
    """The SCR step's breaker: each pole opens at its current's next zero once the event has come."""

    def __init__(self, built):
        self.poles = [built.comps.get(f"grid_par_pole{ph}") for ph in range(3)]
        self.i_attr = built.comps["grid_par_l"].attr("i_intf") if self.poles[0] is not None else None
        self.last = None
        self.open = [False] * 3

    def check(self, opening: bool) -> None:
        if self.i_attr is None or all(self.open) or not opening:
            return
        i = self.i_attr.get().ravel().tolist()
        if self.last is not None:
            for ph in range(3):
                if not self.open[ph] and i[ph] * self.last[ph] <= 0.0:
                    self.poles[ph].open()
                    self.open[ph] = True
        self.last = i


def _store_dsc(k: int, tk: float, vt_attr: list, i_attr: list, dsc_v: list, dsc_i: list) -> None:
    """The SDViSCs' Park phasors at step ``k`` into their delayed-signal cancellations (a step between the
    exchanges every Ts whose phasors the sample d steps later needs)."""
    for j, (va_, ia_) in enumerate(zip(vt_attr, i_attr)):
        va, vb, vc = va_.get().ravel().tolist()
        ia, ib, ic = (-ia_.get().ravel()).tolist()
        dsc_v[j].store(k, frame.park_sample(va, vb, vc, tk))
        dsc_i[j].store(k, frame.park_sample(ia, ib, ic, tk))


def _simulation(m, built, t_end: float, fault):
    d = dpsim()
    sim = emt_simulation("sdvisc_emt_farm", built.sys, m.h, t_end + 10 * m.h)
    if fault is not None:
        sim.add_event(d.event.SwitchEvent3Ph(round(fault[0] / m.h) * m.h - 0.5 * m.h, built.comps["fault"], True))
    return sim


def run_farm(m, t_end: float, events: list | None = None, fault: tuple[float, float] | None = None) -> dict:
    """``m`` an EmtFarm; see ``EmtFarm.run``."""
    c = m.circ
    built = netlist.build(c.net, c.v0)
    sim = _simulation(m, built, t_end, fault)
    conv = dpsim().Math.single_phase_variable_to_three_phase
    k_clear = None if fault is None else int(round(fault[1] / m.h))
    n, nu, n_sub, every_step = int(round(t_end / m.h)), c.n_visc, m.n_sub, m.exchange == "step"
    pending = sorted(((int(round(t / m.h)), f) for t, f in (events or [])), key=lambda e: e[0])
    t = (np.arange(n) + 1) * m.h
    spc = int(round(1.0 / (F_NOMINAL_HZ * m.h)))
    record_all = every_step or m.record_every_step
    n_rec = n if record_all else n // n_sub
    v_pcc_rows: list = [None] * n
    v_col = np.zeros((n, 3))
    v_pcc_np = np.zeros((n, 3)) if m.gfl is None or every_step else None  # the injection's one-cycle means
    v_t, i_c, i_sc = np.zeros((n_rec, nu, 3)), np.zeros((n_rec, nu, 3)), np.zeros((n_rec, 3))
    t_rec = np.zeros(n_rec)
    v_attr, col_attr = built.nodes["pcc"].attr("v"), built.nodes["col"].attr("v")
    vt_attr = [built.nodes[f"t{j}"].attr("v") for j in range(nu)]
    i_attr = [built.comps[f"lf{j}"].attr("i_intf") for j in range(nu)]
    e_attr = [built.comps[f"conv{j}"].attr("V_ref") for j in range(nu)]
    farm_ref = built.comps["farm"].attr("I_ref")
    sc = m.sc
    if sc is not None:
        sc_v, sc_i = built.nodes["sc_t"].attr("v"), built.comps["sc_l"].attr("i_intf")
        sc_ref = built.comps["sc_emf"].attr("V_ref")
    park = frame.park_sample
    poles = _Poles(built)
    poles_left = poles.i_attr is not None
    gfl = m.gfl
    wt_attr = built.nodes["wt"].attr("v") if gfl is not None else None
    gfl_rows: list[tuple] = []
    law_rows: list[tuple] = []
    ts = m.h * n_sub
    kd = m.k_ad
    a_phi = 1.0 - math.exp(-ts * m.w_ad)  # the active damping's low-pass over Ts (exact, v_t held)
    phi = [v for v, _ in m._last]
    raw_v = [v for v, _ in m._last]  # the terminals' raw Park phasors (the active damping's input)
    dsc_on = m.meas != "park"  # the positive sequence (frame.QuarterCycleDsc) of all the law's inputs or of P, Q
    v1_in, i1_in = m.meas == "dsc", m.meas in ("dsc", "dsc_ipq")  # the law's v, i: positive sequence or raw
    pq1 = m.meas in ("dsc_pq", "dsc_ipq")
    s1 = [v * i.conjugate() for v, i in m._last] if pq1 else None  # P + jQ of the positive sequence
    d_dsc = frame.dsc_delay_steps(m.h)
    dsc_v = [frame.QuarterCycleDsc(d_dsc, v) for v, _ in m._last] if dsc_on else []
    dsc_i = [frame.QuarterCycleDsc(d_dsc, i) for _, i in m._last] if dsc_on else []
    col_every_step = gfl is None  # the injection's one-cycle mean of the collector voltage
    wall0, cpu0 = time.perf_counter(), time.process_time()
    with native_stdout_silenced():  # DPsim's "Handle event time" lines (dpsim_env)
        sim.start()
        r = 0
        k_next_event = pending[0][0] if pending else n
        for k in range(n):
            if k >= k_next_event:
                while pending and pending[0][0] <= k:
                    pending.pop(0)[1](m)
                k_next_event = pending[0][0] if pending else n
            sim.next()
            v_pcc_rows[k] = v_attr.get()  # the array DPsim returns (3 x 1), stacked after the run
            if col_every_step or every_step:
                v_col[k] = col_attr.get().ravel()
                v_pcc_np[k] = v_pcc_rows[k].ravel()
            if k_clear is not None and k >= k_clear and v_pcc_rows[k][0, 0] * v_pcc_rows[k - 1][0, 0] <= 0.0:
                built.comps["fault"].open()  # at phase a's current zero, as a breaker (model.py)
                k_clear = None
            if m._opening and poles_left:
                poles.check(True)
                poles_left = not all(poles.open)
            at_ts = (k + 1) % n_sub == 0
            exchange_now = every_step or at_ts
            feeds_dsc = dsc_on and not every_step and (k + 1 + d_dsc) % n_sub == 0  # k + d is a sample
            if feeds_dsc and not record_all:
                _store_dsc(k, float(t[k]), vt_attr, i_attr, dsc_v, dsc_i)
            if not (record_all or exchange_now):
                continue
            tk = float(t[k])
            t_rec[r] = tk
            for j in range(nu):  # Python floats: numpy scalars' arithmetic is ~3x slower in park_sample
                va, vb, vc = vt_attr[j].get().ravel().tolist()
                ia, ib, ic = (-i_attr[j].get().ravel()).tolist()  # i_intf of [m, t] flows t -> m
                v_t[r, j] = va, vb, vc
                i_c[r, j] = ia, ib, ic
                if not exchange_now:
                    if feeds_dsc:
                        dsc_v[j].store(k, park(va, vb, vc, tk))
                        dsc_i[j].store(k, park(ia, ib, ic, tk))
                    continue
                vk, ik = park(va, vb, vc, tk), park(ia, ib, ic, tk)
                raw_v[j] = vk
                if dsc_on:
                    v1, i1 = dsc_v[j].push(k, vk), dsc_i[j].push(k, ik)
                    if pq1:
                        s1[j] = v1 * i1.conjugate()
                    vk, ik = (v1 if v1_in else vk), (i1 if i1_in else ik)
                m._last[j] = (vk, ik)
                u = m.units[j]
                if every_step:
                    if u is not None:
                        u.sample(vk, ik, m.h, None if s1 is None else s1[j])
                        m._e[j] = u.converter_voltage(raw_v[j], m.h)
                        e_attr[j].set(conv(m._e[j]))
                    continue
            if exchange_now and not every_step and nu:
                v_refs = m._e if m.sdc is None else sdc_sample(m.sdc, m._last, c.k_unit, s1)
                for j in range(nu):
                    phi[j] += a_phi * (raw_v[j] - phi[j])
                    e_attr[j].set(conv((v_refs[j] + kd * phi[j]) / (1.0 + kd)))
            if at_ts and nu:
                law_rows.append((tk, *_law_state(m)))
            if sc is not None:
                i_sc[r] = -sc_i.get().ravel()
                if exchange_now:
                    vs = sc_v.get().ravel().tolist()
                    sa, sb, sc_ = i_sc[r].tolist()
                    sc_ref.set(conv(sc.step(park(*vs, tk), park(sa, sb, sc_, tk), m.h if every_step else ts)))
            if not col_every_step and not every_step:
                v_col[k] = col_attr.get().ravel()
            r += 1
            if not at_ts:
                continue
            if gfl is not None:
                if m.wpp is not None:
                    q = m.wpp.update(tk, abs(park(*v_pcc_rows[k].ravel().tolist(), tk)), np.array([gfl.vm]))
                    gfl.q_star = gfl.q0 + float(q[0]) - m._q_order0
                farm_ref.set(conv(gfl.sample(park(*wt_attr.get().ravel().tolist(), tk)) / SQRT3))
                gfl_rows.append((tk, gfl.theta, gfl.vm, gfl.v_dc, gfl.i_ref_dq, gfl.q_star))
            elif k + 1 >= spc:
                lo = k + 1 - spc
                v1 = complex(np.mean(frame.park(v_col[lo:k + 1], t[lo:k + 1])))
                if m.wpp is not None:
                    v1_pcc = abs(complex(np.mean(frame.park(v_pcc_np[lo:k + 1], t[lo:k + 1]))))
                    q = float(m.wpp.update(tk, v1_pcc))
                    m.farm.s = complex(m.farm.s.real, m._q_farm0 + (q - m._q_order0) * m._q_scale)
                farm_ref.set(conv(m.farm.current(v1, tk) / SQRT3))
        sim.stop()
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    v_pcc = np.array(v_pcc_rows, dtype=float).reshape(n, 3)
    out = {"t": t, "h": m.h, "spc": spc, "v_pcc_abc": v_pcc, "v_col_abc": v_col, "v_t_abc": v_t, "i_abc": i_c,
           "i_sc_abc": i_sc, "wall_s": wall, "cpu_s": cpu, "k_unit": c.k_unit, "t_ts": t_rec,
           "exchange": m.exchange}
    if gfl_rows:  # the aggregated converter's controls every Ts: t, PLL angle, V_m, v_dc, i* (PLL frame), Q*
        out["gfl"] = {key: np.array(col) for key, col in zip(("t", "theta", "vm", "v_dc", "i_ref_dq", "q_star"),
                                                             zip(*gfl_rows))}
    if law_rows:  # the SDViSCs' law every Ts: t, delta [rad], E [p.u.] per unit (NaN before activation)
        tl, dl, el = zip(*law_rows)
        out["law"] = {"t": np.array(tl), "delta": np.array(dl), "e_mag": np.array(el)}
    out["v_pcc"] = frame.park(v_pcc, t)
    out["v_t"] = frame.park(np.moveaxis(v_t, 1, 0), t_rec).T  # [record, unit]
    out["i"] = frame.park(np.moveaxis(i_c, 1, 0), t_rec).T / c.k_unit  # own base
    out["q"] = (out["v_t"] * np.conj(out["i"])).imag if nu else np.zeros((n_rec, 0))
    return out
