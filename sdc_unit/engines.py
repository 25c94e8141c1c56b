"""How one sample of :class:`sdc_unit.discrete.DiscreteVisc` is evaluated (its ``engine``).

* :class:`BlockEngine` -- the reference: one block object of :mod:`sdc_unit.blocks` /
  :mod:`sdc_unit.swing` per transfer function, numpy on arrays of N instances; every method.
* :class:`CompiledEngine` -- the same Tustin arithmetic compiled with numba
  (:mod:`sdc_unit.tustin_jit`; float64 bit-identical, float32 to a few ulps from the float32
  cos/sin), on matrices whose rows are the blocks' state arrays.

Both carry out the same sample (see :meth:`BlockEngine.advance`). An engine reads and writes the
instance's blocks, memory (``mem``), run-time parameters (``rp``) and last outputs (``last``,
``last_limited``) and returns which stepped instances produced a finite output.
"""

from __future__ import annotations

import importlib.util

import numpy as np

from sdvisc.vocabulary import CTRL_OUTPUTS, MEAS_FIELDS

from .law_kernels import circular_limit, qsem_current

if importlib.util.find_spec("numba") is None:  # a declared dependency: without it only engine="blocks"
    jit = ctrl_jit = None
else:
    from . import ctrl_jit  # our compiled datagram path (it imports tustin_jit)
    from . import tustin_jit as jit  # our compiled step: a failure to import it is a bug, and raises

ENGINES = ("auto", "jit", "blocks")
"""How a Tustin sample is evaluated: "blocks" = :class:`BlockEngine` (the reference, and the only
engine of the other methods); "jit" = :class:`CompiledEngine`; "auto" = "jit" where it applies
(method tustin with scalar switches), else "blocks". "auto" and "jit" on a Tustin controller raise
when numba is not installed: a production SDC never runs the slow path without saying so."""

OUT_FIELDS = CTRL_OUTPUTS + ("v_f", "p_e")
"""The outputs kept per instance (``last``): what the wire carries, then what the law reports besides."""


def make_engine(visc, engine: str):
    """The engine called ``engine`` (see :data:`ENGINES`) for the instance ``visc``."""
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {ENGINES}")
    if engine == "blocks" or (engine == "auto" and visc.method != "tustin"):
        return BlockEngine(visc)
    if visc.method != "tustin":
        raise ValueError("engine 'jit' needs method 'tustin'")
    if jit is None:
        raise RuntimeError("numba is not installed (a declared dependency of the SDC unit): no compiled Tustin "
                           "step; install numba, or ask for engine='blocks' (the reference, about 5x slower)")
    tables = CompiledEngine.tables(visc)
    if tables is None:
        if engine == "jit":
            raise ValueError("engine 'jit' needs scalar switches (per-instance switches run on the blocks)")
        return BlockEngine(visc)
    return CompiledEngine(visc, tables)


class BlockEngine:
    """The reference engine: the blocks, stepped one transfer function at a time."""

    def __init__(self, visc) -> None:
        self.visc = visc

    def states_replaced(self) -> None:
        """Something outside the step replaced states or parameters (nothing is cached here)."""

    def _cast(self, x):
        v = self.visc
        return np.broadcast_to(np.asarray(x, dtype=float), (v.n,)).astype(v.dtype)

    def advance(self, m, mask: np.ndarray) -> np.ndarray:
        """One sample. The limiter decides P_e (swing), the v_f hold and the AVR anti-windup of the
        SAME sample: a trial pass predicts the limiter state from the last one, then the committed
        pass uses that prediction (no one-sample lag, no algebraic loop).

        When no stepped instance was limited at the last sample and none is in the trial, the
        committed pass would repeat the trial's arithmetic exactly (P_e is the measured p, nothing
        is held), so the trial is kept as the result. Otherwise the trial's states are rolled back
        (blocks replace their state arrays, never write into them, so keeping the old references
        is a complete snapshot) and the committed pass runs."""
        v = self.visc
        lim_last = v.mem["limited"] > 0
        saved = [(b, dict(b.s)) for b in v.blocks.values()]
        trial = self._pass(m, mask, (lim_last, v.mem["ild"], v.mem["ilq"]))
        limited = trial[2]
        if not (np.any(lim_last & mask) or np.any(limited & mask)):
            return self._commit_pass(mask, *trial)
        for b, states in saved:
            b.s = states
        lim_pred = (limited, trial[0]["ild"], trial[0]["ilq"])
        return self._commit_pass(mask, *self._pass(m, mask, lim_pred))

    def _commit_pass(self, mask: np.ndarray, new_mem: dict, out: dict, limited: np.ndarray) -> np.ndarray:
        v, dt = self.visc, self.visc.dtype  # stacked selects; the dicts hold rows of the results
        keys = tuple(new_mem)
        mem = np.where(mask, np.array([new_mem[k] for k in keys], dtype=dt), np.array([v.mem[k] for k in keys], dtype=dt))
        v.mem.update(zip(keys, mem))
        outs = np.array([out[f] for f in OUT_FIELDS], dtype=float)
        ok = mask & np.isfinite(outs).all(axis=0)
        last = np.where(ok, outs, np.array([v.last[f] for f in OUT_FIELDS], dtype=float))
        v.last.update(zip(OUT_FIELDS, last))
        v.last_limited = np.where(ok, limited, v.last_limited)
        return ok

    def _pass(self, m: dict, mask: np.ndarray, lim_pred):
        """Evaluate one sample with the limiter state ``lim_pred`` = (limited, i_d, i_q) assumed for
        P_e, the v_f hold and the AVR anti-windup; block states are committed where ``mask``.
        Returns (new memory, outputs, limited)."""
        v = self.visc
        p, dt, rp = v.p, v.dtype, v.rp
        c = self._cast
        one = dt.type(1.0)
        lim_prev, ild_pred, ilq_pred = lim_pred
        hold = lim_prev if p.freeze_vf_when_limited else None
        vfd = v.lpf_d.step(m["v_d"], mask, hold)
        vfq = v.lpf_q.step(m["v_q"], mask, hold)
        om_s = np.where(p.omega_s_measured, m["omega_meas"], one).astype(dt)
        # swing
        p_lim = m["v_d"] * ild_pred + m["v_q"] * ilq_pred
        p_e = np.where(lim_prev, p_lim, m["p"])
        t_err = c(p.p_ref) - p_e
        delta, dev = v.swing.step(t_err, om_s - one, mask)
        omega = one + dev
        # virtual friction, input omega_s - omega
        a = v.f_lpf.step(om_s - omega, mask)
        y = v.f_w1.step(a, mask) + v.f_w2.step(a, mask)
        vfr = v.f_ll2.step(v.f_ll1.step(y, mask), mask)
        supp = rp["supp"] > 0.5
        vfr_app = np.where(supp, vfr, dt.type(0.0))
        # AVR
        vmag = np.hypot(vfd, vfq)
        e = (c(rp["v_ref"]) - vmag) + c(rp["m_q"]) * (c(rp["q_ref"]) - m["q"])
        u = v.avr.step(e, mask, lim_prev if p.avr_antiwindup else None)
        e_mag = u + c(p.e_ref) + vfr_app
        # quasi-stationary model and limiter
        isd, isq = qsem_current(e_mag, delta, vfd, vfq, omega, dt.type(p.r_v), dt.type(p.l_v))
        ild, ilq, limited = circular_limit(isd, isq, dt.type(p.i_max))
        # inner current loop
        lf = dt.type(p.l_f)
        ffd, ffq = (vfd, vfq) if p.ff_filtered else (m["v_d"], m["v_q"])
        v_ref_d = ffd - lf * m["i_q"] + v.pi_d.step(ild - m["i_d"], mask)
        v_ref_q = ffq + lf * m["i_d"] + v.pi_q.step(ilq - m["i_q"], mask)
        new_mem = dict(limited=limited.astype(dt), ild=ild, ilq=ilq, vmag=vmag, q=m["q"], vfr=vfr)
        out = dict(
            v_ref_d=v_ref_d,
            v_ref_q=v_ref_q,
            i_ref_d=ild,
            i_ref_q=ilq,
            delta=delta,
            omega=omega,
            e_mag=e_mag,
            v_f=vfr_app,
            p_e=p_e,
        )
        return new_mem, out, limited


class CompiledEngine:
    """The Tustin sample compiled (:func:`sdc_unit.tustin_jit.tustin_step`). The blocks stay the
    owners of the states and coefficients; their state entries are made rows (views) of the
    matrices the compiled step updates in place."""

    def __init__(self, visc, tables) -> None:
        self.visc = visc
        self.consts, self.flags = tables
        self.stale = True
        self._slot_meas: np.ndarray | None = None  # advance_slots' measurement matrix

    def states_replaced(self) -> None:
        """Something outside the step replaced states or parameters: stack them again before the next step."""
        self.stale = True

    @staticmethod
    def tables(visc):
        """Constants and flags of the compiled step, or None where it cannot be used."""
        p, dt = visc.p, visc.dtype
        if tuple(jit.OUT_ROWS) != OUT_FIELDS:  # advance_slots hands the kernel's output rows out as OUT_FIELDS
            raise RuntimeError(f"tustin_jit.OUT_ROWS {jit.OUT_ROWS} differ from OUT_FIELDS {OUT_FIELDS}")
        switches = dict(freeze_vf_when_limited=p.freeze_vf_when_limited, omega_s_measured=p.omega_s_measured,
                        avr_antiwindup=p.avr_antiwindup, ff_filtered=p.ff_filtered, wrap=visc.swing.wrap)
        flags = tuple(switches[name] for name in jit.FLAG_NAMES)  # in the kernel's order, by name
        if any(np.ndim(f) for f in flags):
            return None  # per-instance switches: the numpy pass handles them
        consts = dict(one=1.0, zero=0.0, two=2.0, two_pi=2.0 * np.pi, swing_scale_ts=visc.swing.scale * visc.ts,
                      p_ref=p.p_ref, e_ref=p.e_ref, i_max=p.i_max, l_f=p.l_f, r_v=p.r_v, l_v=p.l_v,
                      lpf_d_dc=visc.lpf_d.dc, lpf_q_dc=visc.lpf_q.dc)
        return (np.array([consts[k] for k in jit.CONST_NAMES], dtype=dt), np.array([bool(f) for f in flags], dtype=np.int64))

    def _stack(self) -> None:
        """Matrices of the compiled step; the dicts' entries become their rows (views), so the step
        updates states, memory and outputs in place. Called again after anything outside the step
        replaced those arrays (:meth:`states_replaced`)."""
        v = self.visc
        dt, blocks = v.dtype, v.blocks
        self._x = np.array([blocks[b].s[s] for b, s in jit.STATE_ROWS], dtype=dt)
        for (b, s), row in zip(jit.STATE_ROWS, self._x):
            blocks[b].s[s] = row
        self._coef = np.array([getattr(blocks[b], c) for b, c in jit.COEF_ROWS], dtype=dt)
        self._refs = np.array([v.rp[k] for k in jit.REF_ROWS]).astype(dt)
        self._mem = np.array([v.mem[k] for k in jit.MEM_ROWS], dtype=dt)
        v.mem.update(zip(jit.MEM_ROWS, self._mem))
        self._last = np.array([v.last[f] for f in jit.OUT_ROWS], dtype=float)
        v.last.update(zip(jit.OUT_ROWS, self._last))
        self.stale = False

    def advance(self, m, mask: np.ndarray) -> np.ndarray:
        """``m``: the measurements as a dict of rows or a (8, n) matrix in the working precision."""
        v = self.visc
        if self.stale:
            self._stack()
        consts, flags = self.consts, self.flags
        meas = getattr(m, "matrix", None)  # rows in MEAS_FIELDS order, as the step reads them
        if meas is None:
            meas = np.array([m[k] for k in MEAS_FIELDS], dtype=v.dtype)
        limited = v.last_limited.copy()
        ok = np.empty(v.n, dtype=bool)
        jit.tustin_step(self._x, self._coef, consts, flags, meas, self._refs, self._mem, mask, self._last, limited, ok)
        v.last_limited = limited
        return ok

    def _ready_for_slots(self) -> None:
        """The matrices stacked and the persistent measurement matrix of the per-slot kernels there."""
        v = self.visc
        if self.stale:
            self._stack()
        if self._slot_meas is None or self._slot_meas.shape[1] != v.n:
            self._slot_meas = np.zeros((len(MEAS_FIELDS), v.n), dtype=v.dtype)

    def advance_slots(self, slots: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`advance` of the active ones of the instances ``slots`` (distinct, intp), on ``rows``
        (finite, (len(MEAS_FIELDS), len(slots)), float64) in one kernel call
        (:func:`sdc_unit.tustin_jit.tustin_step_slots`: the rows go into a persistent measurement
        matrix, whose other columns the kernel does not read). Returns (valid, outputs, limited) per
        slot: outputs = the slots' last outputs (rows OUT_FIELDS) after the step."""
        v = self.visc
        self._ready_for_slots()
        rows = np.ascontiguousarray(rows, dtype=np.float64)  # one kernel signature (no compile at run time)
        k = len(slots)
        ok, outputs, limited = np.empty(k, dtype=bool), np.empty((len(OUT_FIELDS), k)), np.empty(k, dtype=bool)
        jit.tustin_step_slots(self._x, self._coef, self.consts, self.flags, self._slot_meas, self._refs, self._mem,
                              slots, rows, v.active, self._last, v.last_limited, ok, outputs, limited)
        return ok, outputs, limited

    def meas_to_ctrl(self, rows: np.ndarray, data: np.ndarray, with_header: bool, out: np.ndarray,
                     ctrl_seq: np.ndarray, flag_bits: int, hdr_sec: int, hdr_nsec: int) -> None:
        """Instances ``rows`` (int64: their slots, replaced by the codes) advanced on their admitted MEAS
        datagrams ``data`` (uint8, one after the other) and their CTRL datagrams written to ``out``,
        in one kernel call (:func:`sdc_unit.ctrl_jit.meas_to_ctrl`); the same sample as
        :meth:`advance_slots`."""
        v = self.visc
        if self.stale or self._slot_meas is None:
            self._ready_for_slots()
        ctrl_jit.meas_to_ctrl(self._x, self._coef, self.consts, self.flags, self._slot_meas, self._refs, self._mem,
                              v.active, self._last, v.last_limited, rows, data, with_header, out, ctrl_seq,
                              flag_bits, hdr_sec, hdr_nsec)
