"""The ViSC grid-side control law in continuous time, vectorised over N turbines.

This module is the single definition of the law. The plant integrates it as the
"hardware-dependent ViSC" ground truth (``derivatives`` / ``outputs``); :mod:`sdc_unit.discrete`
implements the same equations with discretised blocks. The equations are written once, in
:mod:`sdc_unit.law_kernels` (``law_rhs``, with the quasi-stationary model and the circular limiter
the discrete blocks and the compiled Tustin step use too); this module runs them on arrays of N
turbines, :mod:`sdc_unit.law_jit` compiles them for the plant's hd_visc turbines. Dependencies:
numpy only.

Conventions (shared with the plant): per unit on the turbine rating, common frame rotating at
omega0 = 2*pi*f_base, complex vectors x = x_d + j*x_q, converter current positive out of the
converter, S = P + jQ = v * conj(i), time in seconds.

State vector ``x`` has shape (NX, N); row indices (see ``STATE_NAMES``):

====  =========  ====================================================================
row   name       meaning
====  =========  ====================================================================
0     delta      angle of the internal voltage E in the common frame [rad]
1     dw         omega - omega_s, per-unit speed deviation from the reference [p.u.]
2     xi_v       AVR PI integrator, K_iv * integral(e) [p.u.]
3     vf_d       low-pass filtered terminal voltage, d [p.u.]
4     vf_q       low-pass filtered terminal voltage, q [p.u.]
5     xi_d       inner current PI integrator, d [p.u.]
6     xi_q       inner current PI integrator, q [p.u.]
7     f_lpf      virtual friction input low-pass 1/(1+s T_LPF) state [p.u.]
8     f_w1       washout K_F1 s/(1+s T_v1) state [p.u.]
9     f_w2       washout K_F2 s/(1+s T_v2) state [p.u.]
10    f_ll1      first lead-lag (1+sT_1)/(1+sT_2) state [p.u.]
11    f_ll2      second lead-lag state [p.u.]
====  =========  ====================================================================

Equations (per turbine):

* swing, eq. (1) scaled to radians: d(delta)/dt = omega0 * (dw + omega_s - 1),
  2H d(dw)/dt = T_m - T_e - D dw, T_m = p_ref, T_e = p (measured) or, while the limiter
  saturates, Re(v * conj(i_lim)).
* AVR, eq. (2): e = (V* - |v_f|) + m_q (Q* - q); E = K_pv e + xi_v + E* + supp * V_F;
  d(xi_v)/dt = K_iv e, frozen while limited if avr_antiwindup (conditional integration).
* quasi-stationary model: i* = (E e^{j delta} - v_f) / (r_v + j omega l_v), omega = omega_s + dw.
* circular limiter: i_lim = i* * min(1, i_max/|i*|); ``limited`` = |i*| > i_max.
* v_f: d(v_f)/dt = (v - v_f)/t_vf, frozen while limited (if freeze_vf_when_limited).
* virtual friction, eq. (4): input u = omega_s - omega = -dw,
  V_F = u/(1+sT_LPF) * (K_F1 s/(1+sT_v1) + K_F2 s/(1+sT_v2)) * ((1+sT_1)/(1+sT_2))^2.
* inner loop: v_ref = v + j l_f i + k_pc (i_lim - i) + xi_dq, d(xi_dq)/dt = k_ic (i_lim - i).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import law_kernels as K
from .law_kernels import IX_DELTA, IX_DW, IX_FLPF, IX_FW1, IX_FW2, IX_VFD, IX_VFQ, IX_XID, IX_XIQ, IX_XIV, NX
from .params import ViscParams

# the state layout and the helpers are defined with the equations (law_kernels) and are the law's
STATE_NAMES, IX_FLL1, IX_FLL2 = K.STATE_NAMES, K.IX_FLL1, K.IX_FLL2
circular_limit, qsem_current, friction_output = K.circular_limit, K.qsem_current, K.friction_output


@dataclass
class Measurements:
    """Measurements of N turbines, arrays of shape (N,), per unit, common synchronous frame."""

    v_d: np.ndarray
    v_q: np.ndarray
    i_d: np.ndarray
    i_q: np.ndarray
    p: np.ndarray
    q: np.ndarray
    v_dc: np.ndarray
    omega_meas: np.ndarray

    @classmethod
    def from_complex(cls, v, i, v_dc=1.0, omega_meas=1.0) -> Measurements:
        """Build from complex v, i arrays; p and q computed as v * conj(i)."""
        v = np.atleast_1d(np.asarray(v, dtype=complex))
        i = np.atleast_1d(np.asarray(i, dtype=complex))
        s = v * np.conj(i)
        n = v.shape[0]
        return cls(
            v.real.copy(),
            v.imag.copy(),
            i.real.copy(),
            i.imag.copy(),
            s.real.copy(),
            s.imag.copy(),
            np.broadcast_to(np.asarray(v_dc, dtype=float), (n,)).copy(),
            np.broadcast_to(np.asarray(omega_meas, dtype=float), (n,)).copy(),
        )



@dataclass
class Outputs:
    """Controller outputs, arrays of shape (N,).

    v_ref_d/q: converter terminal voltage reference [p.u.]; i_ref_d/q: limited current reference;
    delta: internal-voltage angle [rad]; omega: ViSC speed [p.u.]; e_mag: |E| [p.u.];
    limited: current limiter active; valid: output is valid (always True from the continuous law);
    v_f: virtual friction output actually applied [p.u.]; p_e: electrical torque used in the swing.
    """

    v_ref_d: np.ndarray
    v_ref_q: np.ndarray
    i_ref_d: np.ndarray
    i_ref_q: np.ndarray
    delta: np.ndarray
    omega: np.ndarray
    e_mag: np.ndarray
    limited: np.ndarray
    valid: np.ndarray
    v_f: np.ndarray
    p_e: np.ndarray


def omega_s_of(meas, p: ViscParams):
    """Reference frequency omega_s [p.u.]: nominal 1.0 or the measured grid frequency."""
    if np.any(np.asarray(p.omega_s_measured)):
        return np.where(np.asarray(p.omega_s_measured, dtype=bool), np.asarray(meas.omega_meas), 1.0)
    return np.ones_like(np.asarray(meas.v_d, dtype=float))


def param_values(p: ViscParams) -> list:
    """The parameters as ``law_kernels.law_rhs`` reads them (rows PARAM_ROWS; each a float or an
    array of N turbines, flags as 0.0/1.0)."""
    values = [p.omega0 if name == "omega0" else getattr(p, name) for name in K.PARAM_ROWS]
    return [float(v) if np.ndim(v) == 0 else np.asarray(v, dtype=float) for v in values]


def param_rows(p: ViscParams, n: int) -> np.ndarray:
    """The parameters of N turbines as one float array (PARAM_ROWS, N), for the compiled law."""
    return np.array([np.broadcast_to(v, (n,)) for v in param_values(p)], dtype=float)


def evaluate(x, meas, p: ViscParams) -> tuple[np.ndarray, Outputs]:
    """(dx/dt (NX, N), outputs) of the law for state x (NX, N) and measurements ``meas``."""
    x = np.asarray(x, dtype=float)
    dx = np.empty_like(x)
    out = [None] * len(K.OUT_ROWS)
    K.law_rhs(x, [getattr(meas, name) for name in K.MEAS_ROWS], param_values(p), dx, out)
    return dx, outputs_from_rows(x, out)


def derivatives(x, meas, p: ViscParams):
    """dx/dt of the ViSC law (shape (NX, N)) for state x (NX, N) and measurements ``meas``."""
    return evaluate(x, meas, p)[0]


def outputs(x, meas, p: ViscParams) -> Outputs:
    """Algebraic outputs of the law for state x and measurements ``meas``."""
    return evaluate(x, meas, p)[1]


def outputs_from_rows(x, out) -> Outputs:
    """``Outputs`` of state x (NX, N) from ``law_rhs``'s output rows ``out`` (OUT_ROWS)."""
    n = np.shape(x)[1]
    return Outputs(
        v_ref_d=out[K.O_V_REF_D],
        v_ref_q=out[K.O_V_REF_Q],
        i_ref_d=out[K.O_I_REF_D],
        i_ref_q=out[K.O_I_REF_Q],
        delta=np.array(x[IX_DELTA], dtype=float),
        omega=out[K.O_OMEGA],
        e_mag=out[K.O_E_MAG],
        limited=np.asarray(out[K.O_LIMITED]) > 0.5,
        valid=np.ones(n, dtype=bool),
        v_f=out[K.O_V_F],
        p_e=out[K.O_P_E],
    )


def operating_point(meas, p: ViscParams):
    """Internal voltage at the present operating point: E e^{j delta} = v + (r_v + j omega l_v) i.

    Returns (delta [rad], e_mag [p.u.], omega_s, dw). dw is the measured frequency deviation from
    omega_s (0 when omega_s is the measured frequency).
    """
    om_s = omega_s_of(meas, p)
    omega = np.asarray(meas.omega_meas, dtype=float)
    dw = omega - om_s
    x = omega * p.l_v
    ed = meas.v_d + p.r_v * meas.i_d - x * meas.i_q
    eq = meas.v_q + p.r_v * meas.i_q + x * meas.i_d
    return np.arctan2(eq, ed), np.hypot(ed, eq), om_s, dw


def initial_state(meas, p: ViscParams):
    """State (NX, N) for a bumpless start at the present operating point.

    delta and E from v and i through the virtual impedance, v_f = v, the AVR integrator so that
    E is reproduced, the current-PI integrators so that v_ref equals the steady-state converter
    voltage v + (r_f + j l_f) i, friction states at rest (V_F = 0).
    """
    delta, e_mag, _om_s, dw = operating_point(meas, p)
    n = delta.shape[0]
    x = np.zeros((NX, n))
    x[IX_DELTA] = delta
    x[IX_DW] = dw
    vmag = np.hypot(meas.v_d, meas.v_q)
    e_avr = (p.v_ref - vmag) + p.m_q * (p.q_ref - meas.q)
    x[IX_XIV] = e_mag - p.e_ref - p.k_pv * e_avr
    x[IX_VFD] = meas.v_d
    x[IX_VFQ] = meas.v_q
    x[IX_XID] = p.r_f * meas.i_d
    x[IX_XIQ] = p.r_f * meas.i_q
    x[IX_FLPF] = -dw
    x[IX_FW1] = -dw
    x[IX_FW2] = -dw
    return x

