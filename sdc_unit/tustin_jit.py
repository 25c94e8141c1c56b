"""One Tustin sample of :class:`sdc_unit.discrete.DiscreteVisc`, compiled with numba.

Why: in numpy every operation on a 50-element array costs one to a few microseconds of call
overhead, whatever the arithmetic, and one sample of the ViSC law with its limiter prediction is
some 250 of them -- too many for 50 turbines at Ts = 0.67 ms. Compiled, the same sample is a loop
of about 150 flops per turbine.

What: the recursions of :class:`sdc_unit.blocks.TustinFirstOrder`, :class:`~sdc_unit.blocks.TustinPI`
and :class:`~sdc_unit.swing.TustinSwing`, chained as in :meth:`sdc_unit.engines.BlockEngine._pass`,
operand for operand and in the same order, with the law's own helpers
(:mod:`sdc_unit.law_kernels`) compiled in, in the working precision (float64 or float32: the arrays
and constants passed in are of that dtype, so the arithmetic stays in it). The limiter prediction
is decided per turbine: a first pass assumes the last sample's limiter state; only a turbine that
was or becomes limited is evaluated again with the predicted state (for the others the second pass
would repeat the first exactly). Only turbines in ``mask`` are evaluated and committed.

The block objects stay the owners of the states and coefficients (snapshot, restore, bumpless
re-parameterisation work on them); :class:`sdc_unit.engines.CompiledEngine` stacks them into the
matrices below once and makes the blocks' state entries rows (views) of them, so the compiled step
updates them in place; whatever changes states or parameters outside the step marks the matrices
for re-stacking. A unit test holds this kernel to the block-by-block pass (float64 bit-identical,
float32 to a few ulps).
"""

from __future__ import annotations

import hashlib
import inspect
import math

import numpy as np
from numba import njit

from sdvisc.vocabulary import MEAS_FIELDS

from . import law_kernels

# rows of the state matrix X: (block, state) in DiscreteVisc order
FIRST_ORDER_BLOCKS = ("lpf_d", "lpf_q", "f_lpf", "f_w1", "f_w2", "f_ll1", "f_ll2")
PI_BLOCKS = ("avr", "pi_d", "pi_q")
STATE_ROWS = (
    tuple((b, s) for b in FIRST_ORDER_BLOCKS for s in ("u1", "y1"))
    + tuple((b, s) for b in PI_BLOCKS for s in ("y1", "e1"))
    + tuple(("swing", s) for s in ("d1", "d2", "t1", "t2", "w1", "w2"))
)
# rows of the coefficient matrix C
COEF_ROWS = (
    tuple((b, c) for b in FIRST_ORDER_BLOCKS for c in ("b0", "b1", "a1"))
    + tuple((b, c) for b in PI_BLOCKS for c in ("b0", "b1", "kp"))
    + tuple(("swing", c) for c in ("a1", "a2", "bt", "bw0", "bw1", "bw2"))
)
# scalar constants K (working precision)
CONST_NAMES = ("one", "zero", "two", "two_pi", "swing_scale_ts", "p_ref", "e_ref", "i_max", "l_f", "r_v", "l_v",
               "lpf_d_dc", "lpf_q_dc")
# flags F (int64)
FLAG_NAMES = ("freeze_vf_when_limited", "omega_s_measured", "avr_antiwindup", "ff_filtered", "wrap")
MEM_ROWS = ("limited", "ild", "ilq", "vmag", "q", "vfr")
# where the kernel finds each constant and flag: from the names above, never a number typed here
(_K_ONE, _K_ZERO, _K_TWO, _K_TWO_PI, _K_SWING_SCALE_TS, _K_P_REF, _K_E_REF, _K_I_MAX, _K_L_F, _K_R_V, _K_L_V,
 _K_LPF_D_DC, _K_LPF_Q_DC) = (CONST_NAMES.index(n) for n in (
    "one", "zero", "two", "two_pi", "swing_scale_ts", "p_ref", "e_ref", "i_max", "l_f", "r_v", "l_v", "lpf_d_dc",
    "lpf_q_dc"))
_FLAG_FREEZE_VF, _FLAG_OMEGA_S_MEASURED, _FLAG_AVR_ANTIWINDUP, _FLAG_FF_FILTERED, _FLAG_WRAP = (
    FLAG_NAMES.index(n) for n in ("freeze_vf_when_limited", "omega_s_measured", "avr_antiwindup", "ff_filtered", "wrap"))
OUT_ROWS = ("v_ref_d", "v_ref_q", "i_ref_d", "i_ref_q", "delta", "omega", "e_mag", "v_f", "p_e")
REF_ROWS = ("v_ref", "m_q", "q_ref", "supp")

_LPF_D, _LPF_Q, _F_LPF, _F_W1, _F_W2, _F_LL1, _F_LL2 = range(7)
_AVR, _PI_D, _PI_Q = range(3)
_SW = 2 * len(FIRST_ORDER_BLOCKS) + 2 * len(PI_BLOCKS)  # first swing row in X
_SWC = 3 * len(FIRST_ORDER_BLOCKS) + 3 * len(PI_BLOCKS)  # first swing row in C
# rows of the measurement matrix M: the measurements in wire order (sdvisc.vocabulary.MEAS_FIELDS)
_M_VD, _M_VQ, _M_ID, _M_IQ, _M_P, _M_Q, _M_OMEGA = (MEAS_FIELDS.index(f) for f in ("v_d", "v_q", "i_d", "i_q", "p", "q",
                                                                              "omega_meas"))

# Only the entry point, tustin_step, is cached on disk (see _entry); the functions it calls are
# compiled into it.
_qsem_current = njit(law_kernels.qsem_current)
_circular_limit = njit(law_kernels.circular_limit)


@njit
def _fo(X, C, blk, i, u, new):
    """TustinFirstOrder: y = b0 u + b1 u(k-1) - a1 y(k-1); new states into ``new``."""
    y = C[3 * blk, i] * u + C[3 * blk + 1, i] * X[2 * blk, i] - C[3 * blk + 2, i] * X[2 * blk + 1, i]
    new[2 * blk] = u
    new[2 * blk + 1] = y
    return y


@njit
def _pi(X, C, blk, i, e, hold, new):
    """TustinPI: y = y(k-1) + b0 e + b1 e(k-1), or y(k-1) + kp (e - e(k-1)) on hold."""
    row = 2 * len(FIRST_ORDER_BLOCKS) + 2 * blk
    crow = 3 * len(FIRST_ORDER_BLOCKS) + 3 * blk
    y1 = X[row, i]
    e1 = X[row + 1, i]
    if hold:
        y = y1 + C[crow + 2, i] * (e - e1)
    else:
        y = y1 + C[crow, i] * e + C[crow + 1, i] * e1
    new[row] = y
    new[row + 1] = e
    return y


@njit
def _evaluate(X, C, K, F, M, R, i, lim_prev, ild_pred, ilq_pred, new, mem, out):
    one, zero, two, two_pi, sc_ts = K[_K_ONE], K[_K_ZERO], K[_K_TWO], K[_K_TWO_PI], K[_K_SWING_SCALE_TS]
    p_ref, e_ref, i_max, l_f = K[_K_P_REF], K[_K_E_REF], K[_K_I_MAX], K[_K_L_F]
    r_v, l_v = K[_K_R_V], K[_K_L_V]
    v_d, v_q, i_d, i_q, p, q = M[_M_VD, i], M[_M_VQ, i], M[_M_ID, i], M[_M_IQ, i], M[_M_P, i], M[_M_Q, i]
    omega_meas = M[_M_OMEGA, i]
    hold_vf = F[_FLAG_FREEZE_VF] != 0 and lim_prev
    # v_f low-pass (held at its output while limited, if so configured)
    if hold_vf:
        vfd = X[2 * _LPF_D + 1, i]
        new[2 * _LPF_D] = vfd / K[_K_LPF_D_DC]
        new[2 * _LPF_D + 1] = vfd
        vfq = X[2 * _LPF_Q + 1, i]
        new[2 * _LPF_Q] = vfq / K[_K_LPF_Q_DC]
        new[2 * _LPF_Q + 1] = vfq
    else:
        vfd = _fo(X, C, _LPF_D, i, v_d, new)
        vfq = _fo(X, C, _LPF_Q, i, v_q, new)
    om_s = omega_meas if F[_FLAG_OMEGA_S_MEASURED] != 0 else one
    # swing
    p_lim = v_d * ild_pred + v_q * ilq_pred
    p_e = p_lim if lim_prev else p
    t = p_ref - p_e
    w = om_s - one
    d1, d2, t1, t2, w1, w2 = X[_SW, i], X[_SW + 1, i], X[_SW + 2, i], X[_SW + 3, i], X[_SW + 4, i], X[_SW + 5, i]
    dl = (C[_SWC, i] * d1 - C[_SWC + 1, i] * d2 + C[_SWC + 2, i] * (t + two * t1 + t2)
          + C[_SWC + 3, i] * w + C[_SWC + 4, i] * w1 + C[_SWC + 5, i] * w2)
    dev = (dl - d1) / sc_ts
    d_prev = d1
    if F[_FLAG_WRAP] != 0:
        m = np.rint(dl / two_pi)
        dl = dl - m * two_pi
        d_prev = d_prev - m * two_pi
    new[_SW], new[_SW + 1], new[_SW + 2], new[_SW + 3], new[_SW + 4], new[_SW + 5] = dl, d_prev, t, t1, w, w1
    omega = one + dev
    # virtual friction, input omega_s - omega
    a = _fo(X, C, _F_LPF, i, om_s - omega, new)
    y = _fo(X, C, _F_W1, i, a, new) + _fo(X, C, _F_W2, i, a, new)
    vfr = _fo(X, C, _F_LL2, i, _fo(X, C, _F_LL1, i, y, new), new)
    vfr_app = vfr if R[3, i] > 0.5 else zero
    # AVR
    vmag = math.hypot(vfd, vfq)
    e = (R[0, i] - vmag) + R[1, i] * (R[2, i] - q)
    u = _pi(X, C, _AVR, i, e, F[_FLAG_AVR_ANTIWINDUP] != 0 and lim_prev, new)
    e_mag = u + e_ref + vfr_app
    # quasi-stationary model and circular limiter (the law's own helpers, compiled)
    isd, isq = _qsem_current(e_mag, dl, vfd, vfq, omega, r_v, l_v)
    ild, ilq, limited = _circular_limit(isd, isq, i_max)
    # inner current loop
    ffd, ffq = (vfd, vfq) if F[_FLAG_FF_FILTERED] != 0 else (v_d, v_q)
    out[0] = ffd - l_f * i_q + _pi(X, C, _PI_D, i, ild - i_d, False, new)
    out[1] = ffq + l_f * i_d + _pi(X, C, _PI_Q, i, ilq - i_q, False, new)
    out[2], out[3], out[4], out[5], out[6], out[7], out[8] = ild, ilq, dl, omega, e_mag, vfr_app, p_e
    mem[0] = one if limited else zero
    mem[1], mem[2], mem[3], mem[4], mem[5] = ild, ilq, vmag, q, vfr
    return limited


def compiled_in_key() -> int:
    """A hash of what the step compiles in from other files: the source of
    :mod:`sdc_unit.law_kernels` and the measurement rows (numba freezes globals as constants)."""
    text = inspect.getsource(law_kernels) + repr(MEAS_FIELDS)
    return int(hashlib.sha256(text.encode()).hexdigest()[:15], 16)


@njit
def _advance_one(X, C, K, F, M, R, MEM, i, LAST, LIMITED, new, mem, out):
    """Turbine i of :func:`tustin_step` (states and memory in place); True if its outputs are finite
    (then written to LAST[:, i] and LIMITED[i])."""
    lim_last = MEM[0, i] > 0
    limited = _evaluate(X, C, K, F, M, R, i, lim_last, MEM[1, i], MEM[2, i], new, mem, out)
    if lim_last or limited:
        limited = _evaluate(X, C, K, F, M, R, i, limited, mem[1], mem[2], new, mem, out)
    X[:, i] = new
    MEM[:, i] = mem
    for j in range(out.shape[0]):
        if not np.isfinite(out[j]):
            return False
    for j in range(out.shape[0]):
        LAST[j, i] = out[j]
    LIMITED[i] = limited
    return True


def _entry(compiled_in: int):
    """The compiled step, cached on disk by numba. numba stamps that cache with this file only
    (changes in other files are not seen), and the step also compiles code and constants from
    elsewhere: their hash (:func:`compiled_in_key`) is a closure constant of the step, and numba's
    cache key includes the closure, so a change there recompiles the step instead of loading a
    stale one."""

    @njit(cache=True)
    def tustin_step(X, C, K, F, M, R, MEM, mask, LAST, LIMITED, OK):
        """Advance every turbine i with mask[i]: states X and memory MEM in place. Where the outputs
        are finite, they are written to LAST[:, i] (float64) and LIMITED[i], and OK[i] is set; a
        turbine outside the mask is not touched (OK[i] = False)."""
        n = X.shape[1]
        if compiled_in == 0:  # never true: the reference puts the key into the closure (see _entry)
            n = 0
        new = np.empty(X.shape[0], dtype=X.dtype)
        mem = np.empty(MEM.shape[0], dtype=X.dtype)
        out = np.empty(LAST.shape[0], dtype=X.dtype)
        for i in range(n):
            OK[i] = mask[i] and _advance_one(X, C, K, F, M, R, MEM, i, LAST, LIMITED, new, mem, out)

    return tustin_step


def _slots_entry(compiled_in: int):
    """:func:`tustin_step` for a list of turbines (see :func:`_entry` for the cache key)."""

    @njit(cache=True)
    def tustin_step_slots(X, C, K, F, M, R, MEM, slots, rows, ACTIVE, LAST, LIMITED, OK, OUT, OUT_LIMITED):
        """Advance the active ones of the turbines ``slots`` (distinct) on their measurements
        ``rows`` (column j for slots[j], float64, finite), first copied into M's columns in the
        working precision; as :func:`tustin_step` otherwise, OK[j] per slot. OUT[:, j] and
        OUT_LIMITED[j] get LAST[:, slots[j]] and LIMITED[slots[j]] after the step (stepped or not)."""
        if compiled_in == 0:  # never true (see _entry)
            return
        new = np.empty(X.shape[0], dtype=X.dtype)
        mem = np.empty(MEM.shape[0], dtype=X.dtype)
        out = np.empty(LAST.shape[0], dtype=X.dtype)
        for j in range(slots.shape[0]):
            i = slots[j]
            OK[j] = False
            if ACTIVE[i]:
                for r in range(rows.shape[0]):
                    M[r, i] = rows[r, j]
                OK[j] = _advance_one(X, C, K, F, M, R, MEM, i, LAST, LIMITED, new, mem, out)
            for r in range(OUT.shape[0]):
                OUT[r, j] = LAST[r, i]
            OUT_LIMITED[j] = LIMITED[i]

    return tustin_step_slots


tustin_step = _entry(compiled_in_key())
tustin_step_slots = _slots_entry(compiled_in_key())
