"""F8's farm arrangement in EMT as a backend of the plant service (``plant.model: emt`` with the four SDViSCs of
cluster 3 as the scenario's turbine hosts, :func:`plant.service.model.build_model`).

The circuit is :class:`plant.emt.farm.EmtFarm`'s (``build_case``: four SDViSC converters wt3_1..wt3_4 behind
their turbine transformers and cluster 3's array cable, the rest of the farm one aggregated grid-following
converter, ``farm_model="gfl"``, the export path, the grid's Thevenin source, the PCC's fault switch; no SC),
stepped as its offline exchange every Ts (``exchange="ts"``, plant/emt/farm_run.py) but one Ts per
:meth:`EmtFarmServiceBackend.step`, the SDC's CTRL in place of the in-process discrete ViSCs. The plant
service around it (endpoints, AKs, recorder, clock) is the one of :class:`plant.emt.service_backend.EmtServiceBackend`.

* Indices: the farm's 50 turbines (``plant_index``: wt3_<n> is 20 + n - 1); converters 20..23 are the SDViSCs,
  the others are aggregated (no converter of their own: refused for ``set_mode``/``apply_remote``).
* CTRL (``remote``): each SDViSC's converter voltage reference v_ref from the next step on, held over Ts;
  the converter's active damping inside the circuit as farm_run's ``ts`` (the source (v_ref + k_ad phi)/(1 +
  k_ad) behind the filter divided by 1 + k_ad, ``K_AD_PARALLEL``) and its local current limit
  (``TurbineParams.i_max_local``, :func:`plant.turbine_laws.remote_current_limit` on that equivalent) at every
  circuit step. ``remote_apply: i_ref`` is refused (only ``v_ref``, the paper scenarios'). Outside ``remote``
  (before STREAM_START, after a fall-back for ``remote_loss_fallback_s`` without CTRL) a unit holds its
  converter voltage: the load flow's (P = 0, as EmtFarm before ``activate``), or its last CTRL's (recorded
  as mode ``grid_following``; counted in ``fallbacks``).
* MEAS per Ts: each SDViSC's terminal voltage and converter current as Park phasors of the Ts's last sample
  (own base), p, q from them, ``omega_meas`` from a PLL (service_backend.Pll), ``v_dc`` 1; the aggregated
  turbines: the PCC's phasor and their share of the aggregate's current.
* Events: ``fault`` at the PCC (SLG phase a, cleared at phase a's voltage zero as service_backend);
  ``set sc_connected 0`` accepted (no SC), 1 refused; no SCR step (``set_scr`` refused).
"""

from __future__ import annotations

import math

import numpy as np

from plant import turbine as T
from plant.emt import FARM_VISC_HOSTS, frame, netlist
from plant.emt.dpsim_env import OwnsSimulation, dpsim, emt_simulation
from plant.emt.farm import EmtFarm
from plant.emt.farm_run import SQRT3
from plant.emt.service_backend import OPEN_ENDED_FINAL_S, STEPS_PER_TS, Pll
from plant.turbine_laws import remote_current_limit
from sdvisc.vocabulary import F_NOMINAL_HZ, OMEGA0

VISC_HOSTS = FARM_VISC_HOSTS
"""The arrangement's SDViSC turbines (F8: the leftmost four of cluster 3, plant.cases.visc_indices(4))."""
N_FARM = 50
"""The farm's turbines (PlantParams: 5 clusters x 10)."""


class EmtFarmServiceBackend(OwnsSimulation):
    """F8's farm arrangement with four SDViSCs behind GTNET-SKT endpoints (module docstring). ``grid``: the
    phasor plant's grid keys; ``duration_s``: DPsim's final time (None: open-ended); ``fault_kind``: "slg"
    or "3ph"."""

    def __init__(self, step_s: float = 0.67e-3, *, grid: dict | None = None, remote_loss_fallback_s: float = 0.1,
                 duration_s: float | None = None, fault_kind: str = "slg", remote_apply: str = "v_ref",
                 i_max_local: float | None = None, steps_per_ts: int = STEPS_PER_TS) -> None:
        if remote_apply != "v_ref":
            raise ValueError(f"plant.model emt's farm arrangement applies remote_apply: v_ref only, not {remote_apply!r}")
        if abs(step_s - 0.67e-3) > 1e-12:
            raise ValueError(f"plant.model emt's farm arrangement runs at Ts = 0.67 ms (plant.emt.model.TS_S), not {step_s}")
        self.farm = EmtFarm(len(VISC_HOSTS), with_sc=False, steps_per_ts=steps_per_ts, farm_model="gfl",
                            exchange="ts", fault_kind=fault_kind, **(grid or {}))
        c = self.circ = self.farm.circ
        turbine = self.farm.phasor_plant.params.turbine
        self.n, self.step_s, self.n_sub, self.h = N_FARM, step_s, steps_per_ts, step_s / steps_per_ts
        self.units = list(range(20, 20 + c.n_visc))  # plant_index of wt3_1..wt3_4
        self.k = 0
        self.remote_loss_fallback_s = remote_loss_fallback_s
        self.k_ad = self.farm.k_ad
        self.a_phi = 1.0 - math.exp(-step_s * self.farm.w_ad)  # the active damping's low-pass over Ts (farm_run)
        self.z_eq = c.z_filter * c.k_unit / (1.0 + self.k_ad)  # the filter the in-circuit source sees, own base
        self.a_lim = self.h * OMEGA0 / self.z_eq.imag
        self.i_max_local = turbine.i_max_local if i_max_local is None else float(i_max_local)
        nu = c.n_visc
        self.v_ref = [complex(c.v0[f"c{j}"]) for j in range(nu)]  # held converter voltage (the load flow's)
        self.v_t = [complex(c.v0[f"t{j}"]) for j in range(nu)]
        self.i_net = [complex(x) for x in c.i_unit0]
        self.phi = list(self.v_t)
        self.pll = [Pll(turbine.kp_pll, turbine.ki_pll, v) for v in self.v_t]
        self.gfl = self.farm.gfl
        self.wpp = self.farm.wpp
        self.i_farm = complex(c.farm_i0)
        self.v_pcc = complex(c.v0["pcc"])
        self.spc = int(round(1.0 / (F_NOMINAL_HZ * self.h)))
        self._ring = np.full(self.spc, self.v_pcc, dtype=complex)
        self._at = 0
        self.v_pcc1 = self.v_pcc
        self.pll_pcc = Pll(turbine.kp_pll, turbine.ki_pll, self.v_pcc)
        self.mode = np.full(self.n, T.GFL, dtype=np.int8)
        self.last_rx_k = np.zeros(nu, dtype=np.int64)
        self.fallbacks = np.zeros(self.n, dtype=np.int64)
        self.trips = np.zeros(self.n, dtype=np.int64)  # no over-current trip in the average model
        self.ctrl_applied = np.zeros(nu, dtype=np.int64)
        self._clear_pending = self._fault_on = False
        self._start(duration_s)

    def _start(self, duration_s: float | None) -> None:
        d = dpsim()
        c = self.circ
        self.built = b = netlist.build(c.net, c.v0)
        sim = emt_simulation("sdvisc_emt_farm_service", b.sys, self.h,
                                        (duration_s if duration_s is not None else OPEN_ENDED_FINAL_S) + 10 * self.step_s)
        nu = c.n_visc
        self._vt = [b.nodes[f"t{j}"].attr("v") for j in range(nu)]
        self._i = [b.comps[f"lf{j}"].attr("i_intf") for j in range(nu)]
        self._e = [b.comps[f"conv{j}"].attr("V_ref") for j in range(nu)]
        self._pcc, self._wt = b.nodes["pcc"].attr("v"), b.nodes["wt"].attr("v")
        self._farm_ref = b.comps["farm"].attr("I_ref")
        self._fault = b.comps["fault"]
        self._to_abc = d.Math.single_phase_variable_to_three_phase
        self._started(sim)

    # ------------------------------------------------------------------ commands
    def _unit_slots(self, index) -> list[int]:
        idx = np.atleast_1d(np.asarray(index, dtype=int)).tolist()
        others = sorted(set(idx) - set(self.units))
        if others:
            raise ValueError(f"converter(s) {others} of plant.model emt's farm arrangement are aggregated into its "
                             f"grid-following converter: only {', '.join(VISC_HOSTS)} (converters "
                             f"{self.units[0]}..{self.units[-1]}) have a controllable converter")
        return [self.units.index(i) for i in idx]

    def set_mode(self, index, mode: str) -> None:
        """``remote``: the SDViSC applies the SDC's CTRL (holding its present voltage until the first); any
        other mode: it holds its present converter voltage."""
        if mode not in T.MODES:
            raise ValueError(f"mode must be one of {sorted(T.MODES)}")
        for s in self._unit_slots(index):
            self.mode[self.units[s]] = T.REMOTE if mode == "remote" else T.GFL
            self.last_rx_k[s] = self.k

    def apply_remote(self, index, v_ref_d, v_ref_q, i_ref_d=None, i_ref_q=None) -> None:
        """The newest CTRLs' converter voltage references (common frame, p.u.)."""
        d, q = np.atleast_1d(v_ref_d), np.atleast_1d(v_ref_q)
        for n, s in enumerate(self._unit_slots(index)):
            self.v_ref[s] = complex(float(d[n]), float(q[n]))
            self.last_rx_k[s] = self.k
            self.ctrl_applied[s] += 1

    def fault(self, on: bool, **_) -> None:
        """Close the PCC's fault switch now, or open it at phase a's next voltage zero."""
        if on:
            self._clear_pending, self._fault_on = False, True
            self._fault.close()
        elif self._fault_on:
            self._clear_pending = True

    def set_sc_connected(self, on: bool) -> None:
        """The farm arrangement has no SC: 0 is what it is, 1 is refused."""
        if on:
            raise ValueError("plant.model emt's farm arrangement has no SC to connect (EmtFarm with_sc=False)")

    def set_scr(self, value: float) -> None:
        raise ValueError("plant.model emt's farm arrangement has no SCR step through the service "
                         "(the offline EmtFarm builds it with scr_after)")

    # ------------------------------------------------------------------ step
    def step(self) -> None:
        """One Ts: the fall-back check, ``n_sub`` DPsim steps with each converter's in-circuit source set
        (its local current limit at each step), then MEAS, the PLLs and the aggregate's current."""
        nu, kd = self.circ.n_visc, self.k_ad
        remote = []
        for s, u in enumerate(self.units):
            if self.mode[u] == T.REMOTE and (self.k - self.last_rx_k[s]) * self.step_s >= self.remote_loss_fallback_s:
                self.mode[u] = T.GFL
                self.fallbacks[u] += 1
            remote.append(self.mode[u] == T.REMOTE)
        e = [(self.v_ref[s] + kd * self.phi[s]) / (1.0 + kd) for s in range(nu)]
        limit = [r and self.i_max_local > 0.0 for r in remote]
        to_abc, park, z, a, i_lim = self._to_abc, frame.park_sample, self.z_eq, self.a_lim, self.i_max_local
        k_unit = self.circ.k_unit
        v_t, i_u = list(self.v_t), [x / k_unit for x in self.i_net]
        t0 = self.k * self.step_s
        set_last: list = [None] * nu
        a_prev = None
        for j in range(1, self.n_sub + 1):
            tj = t0 + j * self.h
            for s in range(nu):
                v = e[s]
                if limit[s] and abs(i_u[s] + a * (v - v_t[s] - z * i_u[s])) > i_lim:
                    re, im, _ = remote_current_limit(v.real, v.imag, v_t[s].real, v_t[s].imag, i_u[s].real,
                                                     i_u[s].imag, z.real, z.imag, a, i_lim)
                    v = complex(re, im)
                if v != set_last[s]:
                    self._e[s].set(to_abc(v))
                    set_last[s] = v
            self.sim.next()
            pcc = self._pcc.get().ravel().tolist()
            self._ring[self._at] = park(pcc[0], pcc[1], pcc[2], tj)
            self._at = (self._at + 1) % self.spc
            last = j == self.n_sub
            for s in range(nu):
                if limit[s] or last:
                    va, vb, vc = self._vt[s].get().ravel().tolist()
                    ia, ib, ic = (-self._i[s].get().ravel()).tolist()  # i_intf of [m, t] flows t -> m
                    v_t[s], i_u[s] = park(va, vb, vc, tj), park(ia, ib, ic, tj) / k_unit
            if self._clear_pending and a_prev is not None and pcc[0] * a_prev <= 0.0:
                self._fault.open()
                self._clear_pending = self._fault_on = False
            a_prev = pcc[0]
        self.k += 1
        tk = self.k * self.step_s
        self.v_t, self.i_net = v_t, [x * k_unit for x in i_u]
        for s in range(nu):
            self.phi[s] += self.a_phi * (v_t[s] - self.phi[s])
            self.pll[s].update(v_t[s], self.step_s)
        self.v_pcc = complex(self._ring[(self._at - 1) % self.spc])
        self.v_pcc1 = complex(self._ring.mean())
        self.pll_pcc.update(self.v_pcc1, self.step_s)
        gfl = self.gfl
        if self.wpp is not None:
            q = self.wpp.update(tk, abs(self.v_pcc), np.array([gfl.vm]))
            gfl.q_star = gfl.q0 + float(q[0]) - self.farm._q_order0
        self.i_farm = gfl.sample(park(*self._wt.get().ravel().tolist(), tk))
        self._farm_ref.set(to_abc(self.i_farm / SQRT3))

    @property
    def t(self) -> float:
        return self.k * self.step_s

    # ------------------------------------------------------------------ outputs
    def measurements(self) -> dict[str, np.ndarray]:
        """Per converter (own p.u.): v_d, v_q, i_d, i_q, p, q, v_dc, omega_meas; the SDViSCs' from their
        waveforms, an aggregated turbine's the PCC's positive sequence and its share of the aggregate."""
        n, k_unit = self.n, self.circ.k_unit
        v = np.full(n, self.v_pcc1)
        i = np.full(n, self.i_farm / (self.circ.k_agg))
        omega = np.full(n, self.pll_pcc.omega)
        for s, u in enumerate(self.units):
            v[u], i[u], omega[u] = self.v_t[s], self.i_net[s] / k_unit, self.pll[s].omega
        p_q = v * np.conj(i)
        return {"v_d": v.real, "v_q": v.imag, "i_d": i.real, "i_q": i.imag, "p": p_q.real, "q": p_q.imag,
                "v_dc": np.ones(n), "omega_meas": omega}

    def recorded(self) -> dict:
        """``t``, |V1| at the PCC (one-cycle mean), its PLL's frequency, per converter p, q, i_mag, mode."""
        m = self.measurements()
        return {"t": self.t, "v_pcc": abs(self.v_pcc1), "f_pcc_hz": F_NOMINAL_HZ * self.pll_pcc.omega,
                "p": m["p"], "q": m["q"], "i_mag": np.hypot(m["i_d"], m["i_q"]), "mode": self.mode.copy()}

    def outputs(self) -> dict:
        """:meth:`recorded` and the SDViSCs' terminal voltages."""
        return {**self.recorded(), "v_t": [abs(v) for v in self.v_t], "v_pcc_park": self.v_pcc}
