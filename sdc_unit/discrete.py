"""DiscreteVisc: the SDC unit's discretised ViSC law, N instances vectorised.

The equations are those of :mod:`sdc_unit.law`; each dynamic block is replaced by its discrete
counterpart from :mod:`sdc_unit.blocks` (PIs, first-order filters) and :mod:`sdc_unit.swing`.
This module holds the instances' state: the blocks, memory, run-time parameters, start-up,
re-parameterisation and snapshots; a sample is evaluated by an engine of :mod:`sdc_unit.engines`
(the block-by-block reference or the compiled Tustin step). Per sample k (time k*Ts; there is no
wall clock):

1. v_f(k): low-pass of v (optionally held while the limiter is active, ``freeze_vf_when_limited``).
2. swing: T(k) = p_ref - P_e(k), P_e = p measured, or the limited current's power when the limiter
   is active at k (predicted by a trial pass that commits no state, so there is neither a
   one-sample lag nor an algebraic loop delta(k) -> limiter -> T(k));
   delta(k) from the eq. (15) recursion, omega(k) = 1 + [delta(k) - delta(k-1)]/(omega0 Ts)
   (backward difference).
3. virtual friction chain with input omega_s - omega(k) -> V_F(k).
4. AVR PI on e(k) = (V* - |v_f(k)|) + m_q (Q* - q(k)); E = u + E* + supp V_F.
5. quasi-stationary model, circular limiter -> i_ref(k).
6. current PI: v_ref = v + j l_f i + PI(i_ref - i).
"""

from __future__ import annotations

import numpy as np

from sdvisc.vocabulary import MEAS_FIELDS

from . import law
from .blocks import METHODS, make_first_order, make_pi
from .engines import OUT_FIELDS, make_engine
from .law import Outputs
from .params import RUNTIME_PARAMS, ViscParams
from .swing import make_swing


class DiscreteVisc:
    """N discretised ViSC instances.

    Parameters: n instances, ``params`` (:class:`ViscParams`, scalars), ``ts`` sampling period [s],
    ``method`` in ("tustin", "trapezoid_cumulative", "euler"), ``dtype`` float64 or float32 (all
    state and arithmetic). In "trapezoid_cumulative" the PIs and the swing use the explicit running
    sums of eq. (13); the first-order filters use Tustin (the trapezoidal rule of a first-order lag
    is its Tustin recursion). ``engine`` (see :data:`sdc_unit.engines.ENGINES`) chooses how a Tustin sample is
    evaluated; every engine gives the same trajectory. Instances start inactive; call
    :meth:`initialise` (or :meth:`restore`) first.
    """

    def __init__(self, n: int, params: ViscParams | None = None, ts: float = 0.67e-3, method: str = "tustin", dtype=np.float64,
                 engine: str = "auto"):
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}")
        self.n = int(n)
        self.p = params or ViscParams()
        self.ts = float(ts)
        self.method = method
        self.dtype = np.dtype(dtype)
        if self.dtype not in (np.dtype(np.float64), np.dtype(np.float32)):
            raise ValueError("dtype must be float64 or float32")
        self.k = 0  # step counter; time = k * ts
        p, n, ts, dt = self.p, self.n, self.ts, self.dtype
        self.w0 = p.omega0
        # run-time parameters, one per instance
        self.rp = {name: np.full(n, float(getattr(p, name))) for name in RUNTIME_PARAMS}
        fo = lambda num, den: make_first_order(method, num, den, ts, n, dt)  # noqa: E731
        self.lpf_d = fo((0.0, 1.0), (p.t_vf, 1.0))
        self.lpf_q = fo((0.0, 1.0), (p.t_vf, 1.0))
        self.swing = make_swing(method, p.h, p.d, ts, n, dt, scale=self.w0, wrap=(method == "tustin"))
        self.avr = make_pi(method, p.k_pv, p.k_iv, ts, n, dt)
        self.pi_d = make_pi(method, p.k_pc, p.k_ic, ts, n, dt)
        self.pi_q = make_pi(method, p.k_pc, p.k_ic, ts, n, dt)
        self.f_lpf = fo((0.0, 1.0), (p.t_lpf, 1.0))
        self.f_w1 = fo((p.k_f1, 0.0), (p.t_v1, 1.0))
        self.f_w2 = fo((p.k_f2, 0.0), (p.t_v2, 1.0))
        self.f_ll1 = fo((p.t_1, 1.0), (p.t_2, 1.0))
        self.f_ll2 = fo((p.t_1, 1.0), (p.t_2, 1.0))
        self.blocks = {
            "lpf_d": self.lpf_d,
            "lpf_q": self.lpf_q,
            "swing": self.swing,
            "avr": self.avr,
            "pi_d": self.pi_d,
            "pi_q": self.pi_q,
            "f_lpf": self.f_lpf,
            "f_w1": self.f_w1,
            "f_w2": self.f_w2,
            "f_ll1": self.f_ll1,
            "f_ll2": self.f_ll2,
        }
        # own per-instance memory
        z = lambda: np.zeros(n, dtype=dt)  # noqa: E731
        self.mem = {
            "limited": z(),  # limiter active at the last step (0/1)
            "ild": z(),  # last limited current reference
            "ilq": z(),
            "vmag": z(),  # last |v_f| and q used by the AVR (for bumpless re-referencing)
            "q": z(),
            "vfr": z(),  # last raw virtual friction output
        }
        self.last = {f: np.zeros(n) for f in OUT_FIELDS}
        self.last_limited = np.zeros(n, dtype=bool)
        self.active = np.zeros(n, dtype=bool)
        self.engine = make_engine(self, engine)  # after the blocks and memory it works on

    # ------------------------------------------------------------------ helpers
    def _mask(self, index) -> np.ndarray:
        if index is None:
            return np.ones(self.n, dtype=bool)
        idx = np.asarray(index)
        if idx.dtype == bool:
            return np.broadcast_to(idx, (self.n,)).copy()
        m = np.zeros(self.n, dtype=bool)
        m[idx] = True
        return m

    def _meas(self, meas):
        """Sanitised measurements in dtype and the per-instance finiteness mask."""
        if isinstance(meas, np.ndarray):  # a (len(MEAS_FIELDS), n) matrix, rows in MEAS_FIELDS order
            raw = np.asarray(meas, dtype=float).reshape(len(MEAS_FIELDS), self.n)
        else:
            fields = [getattr(meas, f) for f in MEAS_FIELDS]
            raw = None
            if all(type(v) is np.ndarray and v.shape == (self.n,) for v in fields):
                raw = np.array(fields, dtype=float)
        if raw is not None:  # one stacked pass
            finite = np.isfinite(raw).all(axis=0)
            clean = np.where(finite, raw, 0.0).astype(self.dtype)
            rows = _Rows(zip(MEAS_FIELDS, clean))
            rows.matrix = clean
            return rows, finite
        raw = {f: np.broadcast_to(np.asarray(v, dtype=float), (self.n,)) for f, v in zip(MEAS_FIELDS, fields)}
        finite = np.ones(self.n, dtype=bool)
        for v in raw.values():
            finite &= np.isfinite(v)
        clean = {f: np.where(finite, v, 0.0).astype(self.dtype) for f, v in raw.items()}
        return clean, finite

    def _c(self, x):
        return np.broadcast_to(np.asarray(x, dtype=float), (self.n,)).astype(self.dtype)

    def step(self, meas) -> Outputs:
        """One sample for all active instances with finite measurements (``meas``: an object with
        the MEAS_FIELDS as attributes, or a (len(MEAS_FIELDS), n) matrix in that row order).

        Returns :class:`Outputs`; ``valid`` is False for inactive instances and for instances with
        non-finite measurements (those are not stepped; their fields hold the last valid output,
        never NaN).
        """
        return self._outputs(self.advance(meas))

    def advance(self, meas, stepping: np.ndarray | None = None) -> np.ndarray:
        """:meth:`step` without building its :class:`Outputs` (they are in ``last`` and
        ``last_limited``); returns ``valid``. ``stepping`` (boolean, one per instance): step only
        those of the active instances (the others keep their states and outputs)."""
        m, finite = self._meas(meas)
        mask = self.active & finite
        if stepping is not None:
            mask &= stepping
        ok = self.engine.advance(m, mask)
        self.k += 1
        return ok

    def advance_slots(self, slots: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`advance` of the active instances among ``slots`` (distinct indices) on ``rows``, their
        measurements as a (len(MEAS_FIELDS), len(slots)) float64 matrix that is finite (the caller
        has checked); the others are not touched. Returns (valid, outputs, limited) per slot:
        ``outputs`` holds the slots' last outputs after the step, rows in OUT_FIELDS order."""
        direct = getattr(self.engine, "advance_slots", None)
        if direct is None:
            full = np.zeros((len(MEAS_FIELDS), self.n))
            full[:, slots] = rows
            stepping = np.zeros(self.n, dtype=bool)
            stepping[slots] = True
            ok = self.advance(full, stepping)[slots]
            return ok, np.array([self.last[f] for f in OUT_FIELDS])[:, slots], self.last_limited[slots]
        result = direct(slots, rows)
        self.k += 1
        return result

    @property
    def answers_datagrams(self) -> bool:
        """True where the engine steps MEAS datagrams into CTRL datagrams itself (:meth:`meas_to_ctrl`)."""
        return hasattr(self.engine, "meas_to_ctrl")

    def meas_to_ctrl(self, rows: np.ndarray, data: np.ndarray, with_header: bool, out: np.ndarray,
                     ctrl_seq: np.ndarray, flag_bits: int, hdr_sec: int, hdr_nsec: int) -> None:
        """:meth:`advance_slots` on MEAS datagrams, writing the CTRL datagrams (the compiled engine's
        :meth:`sdc_unit.engines.CompiledEngine.meas_to_ctrl`, see there; :attr:`answers_datagrams`)."""
        self.engine.meas_to_ctrl(rows, data, with_header, out, ctrl_seq, flag_bits, hdr_sec, hdr_nsec)
        self.k += 1

    def _outputs(self, valid) -> Outputs:
        rows = np.array([self.last[f] for f in OUT_FIELDS])  # one copy of every output
        return Outputs(**dict(zip(OUT_FIELDS, rows)), limited=self.last_limited.copy(),
                       valid=np.array(valid, dtype=bool))

    def track(self, meas, index=None) -> None:
        """Warm standby: advance the states of instances ``index`` on ``meas`` without producing output."""
        m, finite = self._meas(meas)
        self.engine.advance(m, self._mask(index) & finite)

    # ------------------------------------------------------------------ initialisation
    def initialise(self, index, meas) -> None:
        """Bumpless start of instances ``index`` from the turbine's present operating point.

        delta and |E| from v and i through the virtual impedance (E e^{j delta} = v + (r_v + j omega l_v) i),
        v_f = v, friction at rest, the AVR so that E is reproduced, the current PIs so that the
        first v_ref equals the present converter voltage v + (r_f + j l_f) i. Activates them.
        """
        self.engine.states_replaced()
        m, finite = self._meas(meas)
        mask = self._mask(index) & finite
        p, c = self.p, self._c
        mf = {k: v.astype(float) for k, v in m.items()}

        class _M:
            pass

        mm = _M()
        for k, v in mf.items():
            setattr(mm, k, v)
        delta, e_mag, om_s, dw = law.operating_point(mm, p)
        self.lpf_d.set_steady(mask, m["v_d"])
        self.lpf_q.set_steady(mask, m["v_q"])
        self.swing.set_operating_point(mask, delta, dw, p.p_ref - mf["p"], om_s - 1.0)
        for b in (self.f_lpf, self.f_w1, self.f_w2):
            b.set_steady(mask, -dw)
        for b in (self.f_ll1, self.f_ll2):
            b.set_steady(mask, np.zeros(self.n))
        vmag = np.hypot(mf["v_d"], mf["v_q"])
        e = (self.rp["v_ref"] - vmag) + self.rp["m_q"] * (self.rp["q_ref"] - mf["q"])
        self.avr.set_operating_point(mask, e_mag - p.e_ref, e)
        self.pi_d.set_operating_point(mask, p.r_f * mf["i_d"], np.zeros(self.n))
        self.pi_q.set_operating_point(mask, p.r_f * mf["i_q"], np.zeros(self.n))
        new_mem = dict(limited=0.0, ild=mf["i_d"], ilq=mf["i_q"], vmag=vmag, q=mf["q"], vfr=0.0)
        for k, v in new_mem.items():
            self.mem[k] = np.where(mask, c(v), self.mem[k]).astype(self.dtype)
        init_out = dict(
            v_ref_d=mf["v_d"] + p.r_f * mf["i_d"] - p.l_f * mf["i_q"],
            v_ref_q=mf["v_q"] + p.r_f * mf["i_q"] + p.l_f * mf["i_d"],
            i_ref_d=mf["i_d"],
            i_ref_q=mf["i_q"],
            delta=delta,
            omega=om_s + dw,
            e_mag=e_mag,
            v_f=np.zeros(self.n),
            p_e=mf["p"],
        )
        for f in OUT_FIELDS:
            self.last[f] = np.where(mask, init_out[f], self.last[f])
        self.last_limited = np.where(mask, False, self.last_limited)
        self.active |= mask

    def deactivate(self, index) -> None:
        self.active &= ~self._mask(index)

    # ------------------------------------------------------------------ run-time parameters
    def set_params(self, index, bumpless: bool = True, **changes) -> None:
        """Change run-time parameters (h, d, m_q, v_ref, q_ref, supp) of instances ``index``.

        With ``bumpless=False`` the change acts like a step of the continuous law's parameter
        (e.g. a V* step gives the AVR's proportional kick K_pv dV*). With ``bumpless=True``
        (default) the states are re-initialised so the output is continuous:

        h, d: the swing recursion gets the new coefficients (Tustin: the delta history carries the
        state; cumulative: the running sums are restarted at the last sample). m_q, v_ref, q_ref:
        the AVR's last error is re-expressed with the new references so the proportional part does
        not jump. supp: the AVR integrator absorbs the change of the applied V_F.
        """
        self.engine.states_replaced()
        bad = set(changes) - set(RUNTIME_PARAMS)
        if bad:
            raise KeyError(f"not run-time parameters: {sorted(bad)}")
        mask = self._mask(index)
        old = {k: v.copy() for k, v in self.rp.items()}
        new = {k: v.copy() for k, v in self.rp.items()}
        for k, v in changes.items():
            new[k] = np.where(mask, float(v), new[k])
        if "h" in changes or "d" in changes:
            self.swing.set_hd(mask, new["h"], new["d"])
        if not bumpless:
            self.rp = new
            return
        if {"m_q", "v_ref", "q_ref"} & set(changes):
            vm, q = self.mem["vmag"].astype(float), self.mem["q"].astype(float)
            e_old = (old["v_ref"] - vm) + old["m_q"] * (old["q_ref"] - q)
            e_new = (new["v_ref"] - vm) + new["m_q"] * (new["q_ref"] - q)
            self.avr.change_prev_error(mask, e_old, e_new)
        if "supp" in changes:
            dsupp = (old["supp"] > 0.5).astype(float) - (new["supp"] > 0.5).astype(float)
            self.avr.shift(mask, dsupp * self.mem["vfr"].astype(float))
        self.rp = new

    # ------------------------------------------------------------------ warm standby
    def snapshot(self, index: int) -> dict[str, float]:
        """All state of instance ``index`` (block states, memory, run-time parameters) as floats."""
        i = int(index)
        d: dict[str, float] = {}
        for bn, b in self.blocks.items():
            for k, v in b.snapshot(i).items():
                d[f"{bn}.{k}"] = v
        for k, v in self.mem.items():
            d[f"mem.{k}"] = float(v[i])
        for k, v in self.rp.items():
            d[f"param.{k}"] = float(v[i])
        for k, v in self.last.items():
            d[f"last.{k}"] = float(v[i])
        d["last.limited"] = float(self.last_limited[i])
        d["active"] = float(self.active[i])
        return d

    def restore(self, index: int, state: dict[str, float]) -> None:
        """Load a :meth:`snapshot` into instance ``index`` (e.g. a backup SDC taking over)."""
        self.engine.states_replaced()
        i = int(index)
        mask = self._mask(i)
        for k in self.rp:
            self.rp[k][i] = state[f"param.{k}"]
        self.swing.set_hd(mask, self.rp["h"], self.rp["d"], rebase=False)
        for bn, b in self.blocks.items():
            b.restore(i, {k.split(".", 1)[1]: v for k, v in state.items() if k.startswith(bn + ".")})
        for k in self.mem:
            self.mem[k][i] = state[f"mem.{k}"]
        for k in self.last:
            self.last[k][i] = state[f"last.{k}"]
        self.last_limited[i] = bool(state["last.limited"])
        self.active[i] = bool(state["active"])


class _Rows(dict):
    """Measurement rows by name, with the stacked matrix they are views of (``matrix``)."""

    matrix: np.ndarray | None = None

