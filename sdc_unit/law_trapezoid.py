"""The generic discretisation of any law's right-hand side: the trapezoidal rule (Tustin's map,
s = (2/Ts)(z − 1)/(z + 1), applied to the whole state-space law), for N instances.

At sample k, with the measurements m_k just received, the state is completed over the last interval

    x_k = x_{k−1} + (Ts/2) [f(x_{k−1}, m_{k−1}) + f(x_k, m_k)]

(implicit in x_k: solved by fixed-point iteration, which contracts while Ts/2 times the law's
largest rate is below 1; a law whose rate is not — Ts/2 · 1/t_vf = 0.1 at Ts = 0.67 ms for the
ViSC's voltage filter — would need Newton's method) and the outputs are those of (x_k, m_k): the
same algebraic loop from measurement to output as the ViSC's hand-derived Tustin engine
(sdc_unit.engines), for a linear law exactly its Tustin recursion. Rows named ``delta`` are wrapped
to (−π, π]. Two engines: ``compiled`` (default: the law's rhs and the
iteration compiled with numba, :mod:`sdc_unit.law_trapezoid_jit`) and ``numpy`` (rows of N
instances at once; the reference the compiled one is tested against).

The class offers what :class:`sdc_unit.bank.ControllerBank` uses of
:class:`sdc_unit.discrete.DiscreteVisc`: ``initialise``, ``deactivate``, ``set_params``, ``rp``,
``track``, ``advance_slots``, ``last``, ``last_limited``, ``answers_datagrams``. Dependencies: numpy.
"""

from __future__ import annotations

import numpy as np

from sdc_unit.law_spec import Law
from sdvisc.vocabulary import CTRL_OUTPUTS, MEAS_FIELDS

MAX_ITERATIONS = 50
"""Fixed-point iterations per sample at most (a contracting law converges in a few)."""
TOLERANCE = 1e-12
"""The iteration stops when no state moves by more than this (absolute, p.u. or rad)."""


class TrapezoidControllers:
    """``n`` instances of ``law`` sampled every ``ts`` seconds (float64 state)."""

    answers_datagrams = False

    def __init__(self, law: Law, n: int, ts: float, params=None, dtype: str = "float64",
                 engine: str = "compiled") -> None:
        if law.rhs is None:
            raise ValueError(f"law {law.name!r} has no right-hand side to discretise")
        if str(np.dtype(dtype)) != "float64":
            raise ValueError(f"law {law.name!r}: the trapezoid discretisation runs in float64 only, got {dtype}")
        self.law, self.n, self.ts = law, int(n), float(ts)
        self.p = params if params is not None else law.params_type()
        self.c = np.repeat(law.param_rows(self.p)[:, None], self.n, axis=1)
        self.rp = {name: self.c[law.param_row_names.index(name)] for name in law.runtime_params}
        self.nx = len(law.state_names)
        self.x = np.zeros((self.nx, self.n))
        self.f = np.zeros((self.nx, self.n))  # f(x_{k−1}, m_{k−1})
        self.m = np.zeros((len(MEAS_FIELDS), self.n))  # m_{k−1}
        self.out = np.zeros((len(law.out_rows), self.n))
        self.active = np.zeros(self.n, dtype=bool)
        self.fresh = np.zeros(self.n, dtype=bool)  # initialised, not stepped yet
        self.wrap = [r for r, name in enumerate(law.state_names) if name == "delta"]
        self.last = {k: np.zeros(self.n) for k in CTRL_OUTPUTS}
        self.last_limited = np.zeros(self.n, dtype=bool)
        self.iterations = 0
        """Fixed-point iterations of the last sample (the largest over its instances)."""
        if engine not in ("compiled", "numpy"):
            raise ValueError(f"engine {engine!r}: 'compiled' or 'numpy'")
        self._kernel = None
        if engine == "compiled":  # numba only where asked for (sdc_unit.law_trapezoid_jit)
            from sdc_unit.law_trapezoid_jit import advance_columns, compiled_rhs

            self._kernel = (advance_columns, compiled_rhs(law.rhs))

    # ------------------------------------------------------------------ the law on columns
    def _rhs(self, x: np.ndarray, m: np.ndarray, cols) -> tuple[np.ndarray, np.ndarray]:
        dx = np.empty_like(x)
        out = np.empty((len(self.law.out_rows), x.shape[1]))
        self.law.rhs(x, m, self.c[:, cols], dx, out)
        return dx, out

    def _publish(self, cols: np.ndarray) -> None:
        out = self.out[:, cols]
        rows = dict(zip(self.law.out_rows, out))
        for k in CTRL_OUTPUTS:
            self.last[k][cols] = self.x[self.wrap[0], cols] if k == "delta" and self.wrap else rows.get(k, 0.0)
        self.last_limited[cols] = rows["limited"] > 0.5

    # ------------------------------------------------------------------ the bank's interface
    def initialise(self, index, meas) -> None:
        """Bumpless start of instances ``index`` at the operating point ``meas`` shows (an object with
        the MEAS_FIELDS as attributes: scalars or one value per instance of ``index``)."""
        cols = np.atleast_1d(np.asarray(index, dtype=np.intp))
        m = np.array([np.broadcast_to(np.asarray(getattr(meas, k), dtype=float), cols.shape) for k in MEAS_FIELDS])
        self._start(cols, m)

    def _start(self, cols: np.ndarray, m: np.ndarray) -> None:
        params = self.law.params_type(**{**self.p.__dict__, **{k: self.rp[k][cols] for k in self.rp}})
        self.x[:, cols] = self.law.initial_state(m, params)
        self.m[:, cols] = m
        self.f[:, cols], self.out[:, cols] = self._rhs(self.x[:, cols], m, cols)
        self._publish(cols)
        self.active[cols] = True
        self.fresh[cols] = True

    def deactivate(self, index) -> None:
        self.active[np.asarray(index, dtype=np.intp)] = False

    def set_params(self, index, **changes) -> None:
        """Change run-time parameters of instances ``index`` (a step of the law's parameter; an
        instance not stepped since its start is started again with them: a bumpless start)."""
        bad = set(changes) - set(self.rp)
        if bad:
            raise KeyError(f"not run-time parameters of law {self.law.name!r}: {sorted(bad)}")
        cols = np.atleast_1d(np.asarray(index, dtype=np.intp))
        for name, value in changes.items():
            self.rp[name][cols] = float(value)
        again = cols[self.fresh[cols]]
        if again.size:
            self._start(again, self.m[:, again].copy())

    def _advance(self, cols: np.ndarray, m: np.ndarray) -> None:
        if self._kernel is not None:
            kernel, rhs = self._kernel
            x, f, out = self.x[:, cols], self.f[:, cols], self.out[:, cols]
            self.iterations = kernel(rhs, x, f, np.ascontiguousarray(m, dtype=float), self.c[:, cols], self.ts,
                                     TOLERANCE, MAX_ITERATIONS, self.wrap[0] if self.wrap else -1, out)
            self.x[:, cols], self.f[:, cols], self.out[:, cols] = x, f, out
            self.m[:, cols] = m
            self.fresh[cols] = False
            return
        x0, f0 = self.x[:, cols], self.f[:, cols]
        half = 0.5 * self.ts
        x = x0 + self.ts * f0  # predictor: forward Euler
        for iteration in range(1, MAX_ITERATIONS + 1):
            f, _ = self._rhs(x, m, cols)
            nxt = x0 + half * (f0 + f)
            done = np.max(np.abs(nxt - x), initial=0.0) <= TOLERANCE
            x = nxt
            self.iterations = iteration
            if done:
                break
        for r in self.wrap:
            x[r] = np.arctan2(np.sin(x[r]), np.cos(x[r]))
        self.x[:, cols] = x
        self.f[:, cols], self.out[:, cols] = self._rhs(x, m, cols)
        self.m[:, cols] = m
        self.fresh[cols] = False

    def track(self, meas, index=None) -> None:
        """Warm standby: advance instances ``index`` on ``meas`` (MEAS_FIELDS attributes, one value
        per instance) without publishing outputs."""
        cols = np.arange(self.n) if index is None else np.atleast_1d(np.asarray(index, dtype=np.intp))
        cols = cols[self.active[cols]]
        if cols.size:
            self._advance(cols, np.array([np.asarray(getattr(meas, k), dtype=float)[cols] for k in MEAS_FIELDS]))

    def advance_slots(self, slots: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One sample of the active instances among ``slots`` (distinct) on ``rows`` (MEAS_FIELDS ×
        len(slots), finite). Returns (valid, outputs as CTRL_OUTPUTS rows, limited) per slot."""
        slots = np.asarray(slots, dtype=np.intp)
        valid = self.active[slots]
        cols = slots[valid]
        if cols.size:
            self._advance(cols, np.asarray(rows, dtype=float)[:, valid])
            self._publish(cols)
        return valid, np.array([self.last[k][slots] for k in CTRL_OUTPUTS]), self.last_limited[slots]

    def state(self, name: str) -> np.ndarray:
        """The state row ``name`` of every instance (a copy)."""
        return self.x[self.law.state_names.index(name)].copy()
