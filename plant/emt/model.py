"""The stepped EMT run of the comparison arrangement: DPsim's solver between Python's controllers.

Step h = Ts / 13 = 51.54 µs [src: RTDS 50 µs typical; 0.67 ms = 13 steps, issue 40's probe] by default.
Every step: read the PCC's and the device terminal's phase voltages and the device's current, update the
SC's EMF; every Ts (13 steps): the SDViSC's law and the farm's current. Events are Python callables at
their step (the fault: a DPsim ``SwitchEvent3Ph`` at the same instant)."""

from __future__ import annotations

import time

import numpy as np

from plant.emt import arrangement, frame
from plant.emt.devices import CondenserEmf, FarmInjection, ViscConverter
from plant.emt.dpsim_env import dpsim, emt_simulation, native_stdout_silenced
from plant.emt.operating_point import from_phasor_plant
from sdvisc.vocabulary import F_NOMINAL_HZ

TS_S = 0.67e-3  # the SDC's sample period [paper]
STEPS_PER_TS = 13


class EmtComparison:
    """One EMT run of the comparison arrangement with ``device`` "sc", "visc" or "none"; ``grid``: the
    phasor plant's grid keys (``scr``, ``e_grid``, ...); ``fault_kind`` "slg" (phase a) or "3ph"."""

    def __init__(self, device: str, fault_kind: str = "slg", steps_per_ts: int = STEPS_PER_TS, law_every: int = 1,
                 **grid):
        self.device = device
        self.law_every = law_every  # circuit steps per sample of the SDViSC's law (1: the HD ViSC; 13: Ts)
        self.op, self.phasor_plant = from_phasor_plant(device, **grid)
        self.n_sub = steps_per_ts
        self.h = TS_S / steps_per_ts
        self.fault_kind = fault_kind
        op = self.op
        i_farm = op.i_farm + op.v_pcc / arrangement.R_DAMP  # with the PCC's damping resistor (arrangement.py)
        self.farm = FarmInjection(op.v_pcc * np.conj(i_farm), self.phasor_plant.net.n_farm * self.phasor_plant.params.turbine.s_rated_mva
                                  / self.phasor_plant.params.grid.s_base_mva, self.phasor_plant.params.turbine)
        self.sc = self.visc = None
        if device == "sc":
            self.sc = CondenserEmf(self.phasor_plant.params.condenser, op.condenser_state, op.condenser_v_ref,
                                   op.k_device)
        elif device == "visc":
            self.visc = ViscConverter(op.visc_params, op.law_state, op.k_device, op.v_terminal, op.e_source,
                                      self.phasor_plant.params.turbine)

    # ------------------------------------------------------------------ events
    def avr_step(self, dv: float):
        """An event: the device's voltage reference + ``dv`` (SC: the AVR's; SDViSC: the law's V*)."""
        def apply(run):
            if run.sc is not None:
                run.sc.model.v_ref += dv
            if run.visc is not None:
                run.visc.params = run.visc.params.with_changes(v_ref=run.visc.params.v_ref + dv)
        return apply

    # ------------------------------------------------------------------ the run
    def run(self, t_end: float, events: list | None = None, fault: tuple[float, float] | None = None) -> dict:
        """Run to ``t_end`` s; ``events`` [(t, callable(run))], ``fault`` (on, off) instants. Returns the
        recorded traces (every step): ``t``, phase voltages ``v_pcc_abc``, ``v_t_abc`` (device terminal),
        the device's star-side current ``i_abc`` (network base) and the same on the device's own side and
        base (``i_dev_abc``), Park phasors, ``wall_s`` and ``cpu_s``."""
        d = dpsim()
        circ = arrangement.build(self.op, self.fault_kind)
        sim = emt_simulation(f"sdvisc_emt_{self.device}", circ.sys, self.h, t_end + 10 * self.h)
        k_clear = None
        if fault is not None:  # closed at its instant; opened at the first zero of the fault current after the
            # clearing instant, as a breaker interrupts (a current chopped in an inductor makes the trapezoidal
            # rule ring undamped: 15-30 p.u. measured when the switch opened at 1.2 s regardless)
            sim.add_event(d.event.SwitchEvent3Ph(self._on_grid(fault[0]) - 0.5 * self.h, circ.fault_switch, True))
            k_clear = int(round(fault[1] / self.h))
        n = int(round(t_end / self.h))
        pending = sorted(((int(round(t / self.h)), f) for t, f in (events or [])), key=lambda e: e[0])
        c, nd = circ.comps, circ.nodes
        term = {"sc": ("sc_t", "sc_l"), "visc": ("visc_t", "visc_lf")}.get(self.device)
        v_pcc = np.zeros((n, 3))
        v_t = np.zeros((n, 3))
        i_dev = np.zeros((n, 3))
        law_rec = np.full((n, 3), np.nan)  # SDViSC: |i_ref| (limited), |i*| over i_max flag, |E|
        t = (np.arange(n) + 1) * self.h
        spc = int(round(1.0 / (F_NOMINAL_HZ * self.h)))  # samples per cycle (~19.4 -> 19)
        farm_src = c["farm"]
        src = {"sc": c.get("sc_emf"), "visc": c.get("visc_conv")}.get(self.device)
        src_ref = src.attr("V_ref") if src is not None else None  # attribute handles fetched once (~30 µs each)
        farm_ref = farm_src.attr("I_ref")
        v_attr = nd["pcc"].attr("v")
        vt_attr = nd[term[0]].attr("v") if term else None
        i_attr = c[term[1]].attr("i_intf") if term else None
        conv = d.Math.single_phase_variable_to_three_phase
        wall0, cpu0 = time.perf_counter(), time.process_time()
        with native_stdout_silenced():  # DPsim's "Handle event time" lines (dpsim_env)
            sim.start()
            for k in range(n):
                while pending and pending[0][0] <= k:
                    pending.pop(0)[1](self)
                sim.next()
                v_pcc[k] = np.ravel(v_attr.get())
                if k_clear is not None and k >= k_clear and v_pcc[k, 0] * v_pcc[k - 1, 0] <= 0.0:
                    circ.fault_switch.open()  # phase a's fault current (v_a / R_FAULT) crossed zero
                    k_clear = None
                if term:
                    v_t[k] = np.ravel(vt_attr.get())
                    i_dev[k] = -np.ravel(i_attr.get())  # i_intf of [a, b] flows b -> a: out of the source
                    tk = t[k]
                    vk = frame.park_sample(*v_t[k], tk)
                    if self.sc is not None:
                        src_ref.set(conv(self.sc.step(vk, frame.park_sample(*i_dev[k], tk), self.h)))
                    else:
                        if (k + 1) % self.law_every == 0:
                            self.visc.sample(vk, frame.park_sample(*i_dev[k], tk), self.law_every * self.h)
                        src_ref.set(conv(self.visc.converter_voltage(vk, self.h)))
                        law_rec[k] = (getattr(self.visc, "i_ref", np.nan), getattr(self.visc, "limited", np.nan),
                                      getattr(self.visc, "e_mag", np.nan))
                if (k + 1) % self.n_sub == 0 and k + 1 >= spc:
                    lo = k + 1 - spc
                    v1 = complex(np.mean(frame.park(v_pcc[lo:k + 1], t[lo:k + 1])))
                    farm_ref.set(conv(self.farm.current(v1, t[k]) / np.sqrt(3.0)))
            sim.stop()
        wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
        out = {"t": t, "v_pcc_abc": v_pcc, "v_t_abc": v_t, "i_abc": i_dev, "spc": spc, "h": self.h,
               "wall_s": wall, "cpu_s": cpu, "k_device": self.op.k_device}
        out["law_i_ref"], out["law_limited"], out["law_e"] = law_rec.T
        out["i_dev_abc"] = frame.delta_side(i_dev) / self.op.k_device if term else i_dev
        out["v_pcc"] = frame.park(v_pcc, t)
        out["v_t"] = frame.park(v_t, t)
        out["i"] = frame.park(i_dev, t)
        return out

    def _on_grid(self, t_s: float) -> float:
        return round(t_s / self.h) * self.h
