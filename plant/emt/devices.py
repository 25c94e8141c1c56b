"""What acts on the EMT circuit from Python between DPsim steps: the SC's rotor and AVR, the SDViSC's
ViSC law, the farm's grid-following injection. Each takes p.u. phasors in the common frame measured from
the waveforms (plant.emt.frame.park) and returns the phasor of its source."""

from __future__ import annotations

import numpy as np

from plant.condenser import Condenser
from plant.params import CondenserParams, TurbineParams
from sdc_unit import law, law_jit
from sdc_unit import law_kernels as K


class CondenserEmf:
    """The 40 MVA SC as its subtransient EMF E'' behind r_a + j x''_d (the stator branch is in the EMT
    circuit), the rotor windings, swing and SEXS AVR the phasor plant's (plant/condenser.py, same
    ``CondenserParams``), integrated (forward Euler) at every circuit step from the stator current read
    off the circuit. The EMF set on the source is E'' plus the rotor's transformer EMF
    (``Condenser.flux_emf``), as the dynamic-phasor network does: it damps the stator's DC offset."""

    def __init__(self, params: CondenserParams, x0: np.ndarray, v_ref: float, k_sc: float):
        self.model = Condenser(params)
        self.model.v_ref = v_ref
        self.x = np.array(x0, dtype=float)
        self.k = k_sc

    def step(self, v_t: complex, i_net: complex, h: float) -> complex:
        """Advance by ``h`` with terminal voltage ``v_t`` and stator current ``i_net`` (network base, out
        of the machine); returns the EMF for the source (network p.u. voltage)."""
        i_sc = i_net / self.k
        dx, _ = self.model.rhs(self.x.tolist(), v_t, abs(v_t), i_net=i_sc)
        self.x += h * np.asarray(dx)
        return complex(self.model.e_net(self.x)) + self.model.flux_emf(self.x, i_sc)


_MEAS_ORDER = [("v_d", "v_q", "i_d", "i_q", "p", "q", "v_dc", "omega_meas").index(name) for name in K.MEAS_ROWS]


class ViscConverter:
    """The 40 MVA SDViSC: the continuous ViSC law (sdc_unit.law's equations, compiled by sdc_unit.law_jit;
    the SDC's ViscParams) sampled every ``EmtComparison.law_every`` circuit steps (1: the HD ViSC; 13: Ts)
    with the terminal voltage and the filter current from the waveforms (Park, raw sample, as the SDC
    receives them), integrated by forward Euler over that interval; its v_ref is held until the next
    sample (zero-order hold in the common frame). The converter applies it with its own active
    damping at every circuit step, as the phasor plant's converter does under a ViSC reference
    (``TurbineParams`` k_ad, w_ad, ext_active_damping [paper, Section II; D'Arco 2015]):
    v_conv = v_ref - k_ad (v - phi), dphi/dt = w_ad (v - phi)."""

    def __init__(self, params, x0: np.ndarray, k_unit: float, v0: complex, v_ref0: complex,
                 turbine: TurbineParams | None = None):
        t = turbine or TurbineParams()
        self.params = params
        self.x = np.array(x0, dtype=float)[:, 0].copy()  # one unit's law state (sdc_unit.law layout)
        self.k = k_unit
        self.k_ad = t.k_ad if t.ext_active_damping else 0.0
        self.w_ad = t.w_ad
        self.phi = v0
        self.v_ref = v_ref0
        self.i_ref, self.limited, self.e_mag = 0.0, 0.0, float("nan")
        self._m = np.zeros(len(K.MEAS_ROWS))
        self._dx = np.zeros_like(self.x)
        self._out = np.zeros(len(K.OUT_ROWS))

    @property
    def params(self):
        return self._params

    @params.setter
    def params(self, p) -> None:
        self._params = p
        self._c = law.param_rows(p, 1)[:, 0].copy()

    def sample(self, v_t: complex, i_net: complex, ts: float, s_net: complex | None = None) -> None:
        """The law's sample (sdc_unit.law_jit.law_rhs, the law's equations compiled): measurements in,
        state advanced by ``ts`` (forward Euler), v_ref held. ``s_net``: the measured P + jQ (network-base
        current) when not v_t conj(i) (farm_run's ``dsc_pq``: the positive sequence's)."""
        i = i_net / self.k
        s = v_t * i.conjugate() if s_net is None else s_net / self.k
        vals = (v_t.real, v_t.imag, i.real, i.imag, s.real, s.imag, 1.0, 1.0)
        self._m[:] = [vals[k] for k in _MEAS_ORDER]
        law_jit.law_rhs(self.x, self._m, self._c, self._dx, self._out)
        self.x += ts * self._dx
        o = self._out
        self.v_ref = complex(o[K.O_V_REF_D], o[K.O_V_REF_Q])
        self.i_ref = abs(complex(o[K.O_I_REF_D], o[K.O_I_REF_Q]))
        self.limited, self.e_mag = float(o[K.O_LIMITED]), float(o[K.O_E_MAG])

    def converter_voltage(self, v_t: complex, h: float) -> complex:
        """The converter's voltage for the next circuit step (active damping advanced by ``h``)."""
        v_conv = self.v_ref - self.k_ad * (v_t - self.phi)
        self.phi += h * self.w_ad * (v_t - self.phi)
        return v_conv


class FarmInjection:
    """The 50-turbine farm seen from the PCC: one grid-following current source with the phasor plant's
    steady-state P and Q at the PCC, its current recomputed every Ts from the positive-sequence PCC
    voltage (one-cycle mean of the Park phasor), with the turbines' fault ride-through (reactive current
    k (v_dip - |V|) below v_dip, reactive priority) and current limit (``TurbineParams`` frt_v_dip,
    frt_k_qv, i_max_gfl) on the farm's rating. Not modelled: the WPP's slow Q/V control, the collector
    and export dynamics, the PLL's transient, the turbines' DC links."""

    def __init__(self, s_pcc: complex, rating_pu: float, turbine: TurbineParams | None = None):
        self.s = s_pcc
        self.rating = rating_pu
        self.t = turbine or TurbineParams()

    def current(self, v1: complex, _t: float = 0.0) -> complex:
        """The injection for the positive-sequence PCC voltage ``v1`` (network base)."""
        vm = max(abs(v1), 0.05)
        i_d, i_q = self.s.real / vm, -self.s.imag / vm  # along V: active, and - reactive (capacitive < 0)
        if vm < self.t.frt_v_dip:
            i_q -= self.t.frt_k_qv * (self.t.frt_v_dip - vm) * self.rating
        i_max = self.t.i_max_gfl * self.rating
        i_q = float(np.clip(i_q, -i_max, i_max))
        i_d = float(np.clip(i_d, -np.sqrt(i_max**2 - i_q**2), np.sqrt(i_max**2 - i_q**2)))
        return complex(i_d, i_q) * v1 / vm


class FarmReplay:
    """The farm's injection replayed from a phasor-plant run: the positive-sequence current its onshore
    transformer delivered at the PCC at each of that run's steps (linear interpolation in time), plus a
    constant ``extra`` (the EMT circuit's damping resistor). Puts the phasor farm's own fault response into
    the EMT circuit, so that a remaining difference is the devices' and the network's, not the farm's."""

    def __init__(self, t: np.ndarray, i_farm: np.ndarray, extra: complex = 0j):
        self.t, self.i, self.extra = np.asarray(t), np.asarray(i_farm), extra

    def current(self, _v1: complex, t: float = 0.0) -> complex:
        return complex(np.interp(t, self.t, self.i.real), np.interp(t, self.t, self.i.imag)) + self.extra
