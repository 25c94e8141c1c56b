"""The EMT comparison arrangement as a backend of the plant service (``plant.model: emt``).

The plant service (plant/service/main.py, plant/service/core.py) keeps everything that is not the model:
the GTNET-SKT endpoints, STREAM_START/STOP, the AKs, the recorder and the run's (virtual) clock. This
module is only what it steps, through the interface every backend implements
(:class:`plant.backend.PlantBackend`): the paper's comparison arrangement (Section IV-A/B) in DPsim's
EMT solver (:mod:`plant.emt.arrangement`, the circuit :class:`plant.emt.model.EmtComparison` runs
offline) with its 40 MVA SDViSC's converter driven by the SDC's CTRL.

* Indices: the farm's ``n_farm`` turbines (0 … n_farm-1, aggregated here into one grid-following
  injection at the PCC, :class:`plant.emt.devices.FarmInjection`: they cannot stream) and the onshore
  unit ``n_farm`` (host ``wt6_1``, ``plant.cases.COMPARISON_UNIT``), the only converter with an endpoint.
* One :meth:`EmtServiceBackend.step` is one Ts: ``steps_per_ts`` DPsim steps (Ts/13 = 51.5 µs by
  default [issue 40: 0.67 ms is not a multiple of 50 µs]).
* CTRL (``remote`` mode) is the converter's reference from the next step on, held (zero-order hold in
  the common frame) until the next CTRL. ``remote_apply: i_ref``: the SDC's limited
  current reference, tracked by the converter's own current loop at every circuit step, as the phasor
  plant's remote converter does (v = φ + (r_f + j l_f) i_ref + k_pc (i_ref - i), ``TurbineParams``; φ
  the active damping's low-pass of the terminal voltage where the phasor plant feeds v forward); ``v_ref``
  (the paper scenarios' setting): the SDC's converter voltage reference (the inner loop closed over the
  network). Either goes through the converter's active damping
  (:meth:`plant.emt.devices.ViscConverter.converter_voltage`) and, at every circuit step, the
  converter's local current limit (``TurbineParams.i_max_local``, the phasor plant's
  :func:`plant.turbine_laws.remote_current_limit`: the current the voltage would drive over the step,
  clamped). Measured (:data:`REMOTE_LOOP_MEASURED`): at rest with the paper's one-sample loop; one
  sample more makes the loop grow, the limit bounds it, and it is at rest again once the one-sample loop
  resumes. Without a CTRL for ``remote_loss_fallback_s``
  the unit falls back to its own control (counted in ``fallbacks``).
* Outside ``remote`` mode the unit runs the ViSC law itself at every circuit step (the offline EMT
  run's HD ViSC, :class:`~plant.emt.devices.ViscConverter`): the arrangement's unit has no
  grid-following control of its own (the phasor plant's has); recorded as mode ``hd_visc``.
* MEAS (per Ts, after the step): the terminal voltage and the filter current as Park phasors of the
  waveforms' last sample in the common frame (:func:`plant.emt.frame.park_sample`: what a sampling
  card sends; an unbalance shows as a 100 Hz ripple), the current on the unit's base, p and q from
  them, ``omega_meas`` from a synchronous-reference-frame PLL on the terminal voltage
  (:class:`Pll`, ``TurbineParams`` kp_pll, ki_pll), ``v_dc`` 1 (the average model has no DC link).
* Events: ``fault`` closes the PCC's fault switch (SLG on phase a by default) and opens it at the
  first zero of phase a's fault current after the clearing command, as the offline run does;
  ``set sc_connected 0`` is accepted (there is no SC in this arrangement), 1 is refused.
"""

from __future__ import annotations

import math

import numpy as np

from plant import turbine as T
from plant.emt import arrangement, frame
from plant.emt.devices import FarmInjection, ViscConverter
from plant.emt.dpsim_env import OwnsSimulation, dpsim, emt_simulation
from plant.emt.operating_point import from_phasor_plant
from plant.turbine_laws import remote_current_limit
from sdvisc.vocabulary import F_NOMINAL_HZ, OMEGA0

STEPS_PER_TS = 13
"""DPsim steps per Ts [issue 40: Ts/13 = 51.54 µs, the RTDS's ~50 µs; 0.67 ms is not a multiple of 50 µs]."""
OPEN_ENDED_FINAL_S = 3600.0
"""DPsim's final time for a run without a duration, s [the longest RunSeconds of sdvisc.config]."""
REMOTE_LOOP_MEASURED = (
    "the SDC's Tustin law in-process (plant.emt.service_loop; tests/unit/test_emt_service.py): with the paper's "
    "one-sample loop (the CTRL answering the MEAS sent after step k drives step k+1) v_ref is at rest and rides "
    "through an SLG fault; 0.1 s of CTRLs a sample late (a stall's catch-up) and the loop grows: past 100 p.u. "
    "without the local current limit (the SDC then rejects the MEAS as out of range), bounded below 5 p.u. with it "
    "and at rest again after; 2026-12-06")
"""What the remote loop does on the EMT circuit (docs/plant.md, "EMT through the network")."""
MIN_PLL_VOLTAGE = 0.05
"""Below this voltage magnitude (p.u.) the PLL's phase error is normalised by it, not by |v| [assumed:
keeps the error finite in a bolted fault at the terminal]."""


class Pll:
    """A synchronous-reference-frame PLL on a p.u. phasor in the common frame, updated every Ts: phase
    error e = Im(v e^{-jθ}) / |v|, speed ω = 1 + kp e + ∫ ki e (p.u.), dθ/dt = ω0 (ω - 1) (θ relative to
    the common frame); gains ``TurbineParams`` kp_pll, ki_pll (the phasor plant's turbines' PLL)."""

    def __init__(self, kp: float, ki: float, v0: complex) -> None:
        self.kp, self.ki = kp, ki
        self.theta = math.atan2(v0.imag, v0.real)
        self.integral = 0.0
        self.omega = 1.0

    def update(self, v: complex, h: float) -> float:
        """Advance by ``h`` with the measured phasor ``v``; returns the speed (p.u.)."""
        e = (v * complex(math.cos(self.theta), -math.sin(self.theta))).imag / max(abs(v), MIN_PLL_VOLTAGE)
        self.omega = 1.0 + self.kp * e + self.integral
        self.integral += self.ki * e * h
        self.theta += OMEGA0 * (self.omega - 1.0) * h
        return self.omega


class EmtServiceBackend(OwnsSimulation):
    """The comparison arrangement with its SDViSC behind a GTNET-SKT endpoint (module docstring).

    ``n_farm``: the farm's turbines (indices before the unit's); ``step_s``: Ts; ``grid``: the phasor
    plant's grid keys (``plant.cases._params``: ``scr``, ``e_grid``, ``h_grid`` …) for the operating
    point; ``duration_s``: DPsim's final time (None: open-ended); ``k_ad``: the converter's active
    damping gain (None: ``TurbineParams.k_ad``); ``fault_kind``: "slg" (phase a) or "3ph".
    """

    def __init__(self, n_farm: int = 50, step_s: float = 0.67e-3, *, grid: dict | None = None,
                 steps_per_ts: int = STEPS_PER_TS, remote_loss_fallback_s: float = 0.1,
                 duration_s: float | None = None, k_ad: float | None = None, fault_kind: str = "slg",
                 remote_apply: str = "v_ref", i_max_local: float | None = None) -> None:
        if remote_apply not in ("i_ref", "v_ref"):
            raise ValueError(f"remote_apply must be 'i_ref' or 'v_ref', not {remote_apply!r}")
        self.remote_apply = remote_apply
        if fault_kind not in ("slg", "3ph"):
            raise ValueError(f"fault_kind must be 'slg' or '3ph', not {fault_kind!r}")
        self.op, phasor = from_phasor_plant("visc", **(grid or {}))
        if phasor.n != n_farm + 1:
            raise ValueError(f"the EMT arrangement's phasor plant has {phasor.n} converters, not n_farm + 1 = {n_farm + 1}")
        op, turbine = self.op, phasor.params.turbine
        self.n, self.unit, self.n_farm = n_farm + 1, n_farm, n_farm
        self.step_s, self.n_sub, self.h = step_s, steps_per_ts, step_s / steps_per_ts
        self.k = 0
        self.remote_loss_fallback_s = remote_loss_fallback_s
        self.k_turbine = float(phasor.net.k_t[0])  # a farm turbine's rating on the network base
        self.visc = ViscConverter(op.visc_params, op.law_state, op.k_device, op.v_terminal, op.e_source, turbine)
        if k_ad is not None:
            self.visc.k_ad = float(k_ad)
        # the law's compiled code loaded now, not in the first paced step (~0.45 s, a stall at t = 0)
        ViscConverter(op.visc_params, op.law_state, op.k_device, op.v_terminal, op.e_source,
                      turbine).sample(op.v_terminal, op.i_device, step_s)
        i_farm = op.i_farm + op.v_pcc / arrangement.R_DAMP  # with the PCC's damping resistor, as EmtComparison
        self.farm = FarmInjection(op.v_pcc * np.conj(i_farm),
                                  n_farm * turbine.s_rated_mva / phasor.params.grid.s_base_mva, turbine)
        self.i_farm_net = i_farm
        self.mode = np.full(self.n, T.GFL, dtype=np.int8)
        self.mode[self.unit] = T.HD_VISC
        self.remote_v = op.e_source
        self.remote_i = op.i_device / op.k_device
        self.z_filter = complex(turbine.rf, turbine.lf)
        self.k_pc = turbine.kpc
        self.i_max_local = turbine.i_max_local if i_max_local is None else float(i_max_local)
        self.last_rx_k = 0
        self.fallbacks = np.zeros(self.n, dtype=np.int64)
        self.trips = np.zeros(self.n, dtype=np.int64)  # no over-current trip in the average model: stays 0
        self.v_t, self.i_dev, self.v_pcc = op.v_terminal, op.i_device, op.v_pcc
        self.spc = int(round(1.0 / (F_NOMINAL_HZ * self.h)))  # circuit steps per cycle (19 at 51.5 µs)
        self._pcc_ring = np.full(self.spc, op.v_pcc, dtype=complex)  # the last cycle's PCC Park phasors
        self._ring_at = 0
        self.v_pcc1 = op.v_pcc
        self.pll = Pll(turbine.kp_pll, turbine.ki_pll, op.v_terminal)
        self.pll_pcc = Pll(turbine.kp_pll, turbine.ki_pll, op.v_pcc)
        self._clear_pending = False
        self._fault_on = False
        self._start(fault_kind, duration_s)

    # ------------------------------------------------------------------ DPsim
    def _start(self, fault_kind: str, duration_s: float | None) -> None:
        d = dpsim()
        self.circuit = circ = arrangement.build(self.op, fault_kind)
        sim = emt_simulation("sdvisc_emt_service", circ.sys, self.h,
                                        (duration_s if duration_s is not None else OPEN_ENDED_FINAL_S) + 10 * self.step_s)
        c, nd = circ.comps, circ.nodes
        self._conv_ref = c["visc_conv"].attr("V_ref")  # attribute handles fetched once (~30 µs each)
        self._farm_ref = c["farm"].attr("I_ref")
        self._v_pcc_attr = nd["pcc"].attr("v")
        self._v_t_attr = nd["visc_t"].attr("v")
        self._i_attr = c["visc_lf"].attr("i_intf")
        self._to_abc = d.Math.single_phase_variable_to_three_phase
        self._started(sim)

    # ------------------------------------------------------------------ commands
    def _check_unit(self, index) -> None:
        others = sorted(set(np.atleast_1d(np.asarray(index, dtype=int)).tolist()) - {self.unit})
        if others:
            raise ValueError(f"converter(s) {others} of plant.model emt are aggregated into the farm's injection: "
                             f"only the onshore unit (converter {self.unit}, host wt6_1) has a controllable converter")

    def set_mode(self, index, mode: str) -> None:
        """``remote``: the unit applies the SDC's CTRL (holding its present reference until the first);
        ``grid_following`` or ``hd_visc``: the unit's own ViSC law (the arrangement has no other)."""
        if mode not in T.MODES:
            raise ValueError(f"mode must be one of {sorted(T.MODES)}")
        self._check_unit(index)
        if mode == "remote":
            if self.mode[self.unit] != T.REMOTE:
                self.remote_v = self.visc.v_ref
                self.remote_i = self.i_dev / self.op.k_device
            self.last_rx_k = self.k
            self.mode[self.unit] = T.REMOTE
        else:
            self.mode[self.unit] = T.HD_VISC

    def apply_remote(self, index, v_ref_d, v_ref_q, i_ref_d=None, i_ref_q=None) -> None:
        """The newest CTRL's references (common frame, the unit's p.u.): the converter voltage's, and
        the current's (used with ``remote_apply: i_ref``)."""
        self._check_unit(index)
        self.remote_v = complex(float(np.ravel(v_ref_d)[-1]), float(np.ravel(v_ref_q)[-1]))
        if i_ref_d is not None and i_ref_q is not None:
            self.remote_i = complex(float(np.ravel(i_ref_d)[-1]), float(np.ravel(i_ref_q)[-1]))
        self.last_rx_k = self.k

    def fault(self, on: bool, **_) -> None:
        """Close the PCC's fault switch now, or open it at phase a's next current zero."""
        if on:
            self._clear_pending = False
            self._fault_on = True
            self.circuit.fault_switch.close()
        elif self._fault_on:
            self._clear_pending = True

    def set_sc_connected(self, on: bool) -> None:
        """The arrangement has the SDViSC and no SC: 0 is what it is, 1 is refused."""
        if on:
            raise ValueError("plant.model emt is the comparison arrangement's SDViSC half: it has no SC to connect")

    # ------------------------------------------------------------------ step
    def step(self) -> None:
        """One Ts: the fall-back check, ``n_sub`` DPsim steps with the converter's voltage set before
        each, the farm's current from the last cycle's PCC voltage, the PLLs."""
        unit_mode = self.mode[self.unit]
        if unit_mode == T.REMOTE and (self.k - self.last_rx_k) * self.step_s >= self.remote_loss_fallback_s:
            self.mode[self.unit] = unit_mode = T.HD_VISC
            self.fallbacks[self.unit] += 1
        remote = unit_mode == T.REMOTE
        visc, h, sim = self.visc, self.h, self.sim
        conv_set, to_abc = self._conv_ref.set, self._to_abc
        v_pcc_get, v_t_get, i_get = self._v_pcc_attr.get, self._v_t_attr.get, self._i_attr.get
        ring, spc, at = self._pcc_ring, self.spc, self._ring_at
        t = self.k * self.step_s
        current_loop = remote and self.remote_apply == "i_ref"
        i_lim = self.i_max_local
        limit_on = remote and i_lim > 0.0
        a_lim = h * OMEGA0 / self.z_filter.imag
        if remote:
            visc.v_ref = self.remote_v
        i_ref, z_f, k_pc, k_unit = self.remote_i, self.z_filter, self.k_pc, self.op.k_device
        v_t, i_unit = self.v_t, self.i_dev / k_unit
        a_prev = None
        for j in range(1, self.n_sub + 1):
            if current_loop:  # the converter's own current loop on the held i_ref, its voltage feed-forward
                # the active damping's low-pass phi (v_t fed forward raw rang on the filter's LC, an ad-hoc probe)
                visc.v_ref = visc.phi + z_f * i_ref + k_pc * (i_ref - i_unit)
            v_conv = visc.converter_voltage(v_t, h)
            # the converter's local current limit (the phasor plant's, at the circuit step); its prediction
            # of the current over the step first, to skip the call while within the limit (the usual case)
            if limit_on and abs(i_unit + a_lim * (v_conv - v_t - z_f * i_unit)) > i_lim:
                re, im, _ = remote_current_limit(v_conv.real, v_conv.imag, v_t.real, v_t.imag, i_unit.real,
                                                 i_unit.imag, z_f.real, z_f.imag, a_lim, i_lim)
                v_conv = complex(re, im)
            conv_set(to_abc(v_conv))
            sim.next()
            tj = t + j * h
            pcc = np.ravel(v_pcc_get())
            ring[at] = frame.park_sample(pcc[0], pcc[1], pcc[2], tj)
            at = (at + 1) % spc
            vt = np.ravel(v_t_get())
            v_t = frame.park_sample(vt[0], vt[1], vt[2], tj)
            if not remote or current_loop or limit_on:
                ia = np.ravel(i_get())  # i_intf of [a, b] flows b -> a: out of the source is its negative
                i_net = -frame.park_sample(ia[0], ia[1], ia[2], tj)
                i_unit = i_net / k_unit
                if not remote:  # the unit's own law at the circuit step (the HD ViSC)
                    visc.sample(v_t, i_net, h)
            if self._clear_pending and a_prev is not None and pcc[0] * a_prev <= 0.0:
                self.circuit.fault_switch.open()  # phase a's fault current (v_a / R_FAULT) crossed zero
                self._clear_pending = self._fault_on = False
            a_prev = pcc[0]
        self._ring_at = at
        self.k += 1
        t = self.k * self.step_s
        ia = np.ravel(i_get())
        self.v_t, self.i_dev = v_t, -frame.park_sample(ia[0], ia[1], ia[2], t)
        self.v_pcc = complex(ring[(at - 1) % spc])
        self.v_pcc1 = complex(ring.mean())  # positive sequence: the one-cycle mean
        i_farm = self.farm.current(self.v_pcc1, t)
        self.i_farm_net = i_farm
        self._farm_ref.set(to_abc(i_farm / np.sqrt(3.0)))
        self.pll.update(v_t, self.step_s)
        self.pll_pcc.update(self.v_pcc1, self.step_s)

    @property
    def t(self) -> float:
        return self.k * self.step_s

    # ------------------------------------------------------------------ outputs
    def measurements(self) -> dict[str, np.ndarray]:
        """Per converter (its own p.u.): v_d, v_q, i_d, i_q, p, q, v_dc, omega_meas. The unit's from its
        terminal's waveforms; each farm turbine's: the PCC's positive sequence and its share of the
        farm's injection (the aggregate has no turbines of its own)."""
        n = self.n
        v = np.full(n, self.v_pcc1)
        i = np.full(n, self.i_farm_net / (self.n_farm * self.k_turbine))
        omega = np.full(n, self.pll_pcc.omega)
        v[self.unit] = self.v_t
        i[self.unit] = self.i_dev / self.op.k_device
        omega[self.unit] = self.pll.omega
        s = v * np.conj(i)
        return {"v_d": v.real, "v_q": v.imag, "i_d": i.real, "i_q": i.imag, "p": s.real, "q": s.imag,
                "v_dc": np.ones(n), "omega_meas": omega}

    def recorded(self) -> dict:
        """What ``timeseries.csv`` holds (plant.service.recorder): ``t``, |V1| at the PCC (one-cycle mean),
        the PCC's frequency (its PLL), per converter ``p``, ``q``, ``i_mag``, ``mode``."""
        m = self.measurements()
        return {"t": self.t, "v_pcc": abs(self.v_pcc1), "f_pcc_hz": F_NOMINAL_HZ * self.pll_pcc.omega,
                "p": m["p"], "q": m["q"], "i_mag": np.hypot(m["i_d"], m["i_q"]), "mode": self.mode.copy()}

    def outputs(self) -> dict:
        """:meth:`recorded` and the unit's terminal voltage and the PCC's last Park phasor."""
        return {**self.recorded(), "v_t": abs(self.v_t), "v_pcc_park": self.v_pcc}
