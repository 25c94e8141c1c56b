"""A fixed-capacity bank of per-turbine controllers addressed by slot, as the service needs it.

Wraps the controllers of one law of :data:`sdc_unit.laws.LAWS` (``law``; for the ViSC
:class:`sdc_unit.discrete.DiscreteVisc`, the Tustin/trapezoid/Euler SDViSC; for a law without a
hand-derived discretisation :class:`sdc_unit.law_trapezoid.TrapezoidControllers`) so that the
service can start, stop, re-parameterise and step any subset of slots. A started slot is
initialised from its first measurement (bumpless start from the turbine's operating point).

The law "hold" (also ``method="hold"``, its former spelling) is a network-only law for studies where the grid does not matter: it answers
every measurement with the converter voltage of the operating point it saw first
(``v + (R_f + jX_f)·i``), so packets flow with realistic sizes and timing at negligible CPU cost.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from sdc_unit.answer import FLAG_BACKUP, SENT, ctrl_bytes, header_time
from sdc_unit.blocks import METHODS as VISC_METHODS
from sdc_unit.laws import get_law
from sdvisc import wire
from sdvisc.vocabulary import CTRL_OUTPUTS, MEAS_FIELDS, params_from_mask

METHODS = VISC_METHODS + ("hold",)
OUT_KEYS = CTRL_OUTPUTS + ("limited",)
"""What :meth:`ControllerBank.step` returns per slot: the CTRL values and the limiter flag."""


class ControllerBank:
    """``capacity`` controller slots stepped in one vectorised call."""

    def __init__(self, capacity: int, step_s: float, method: str = "tustin", dtype: str = "float64",
                 law: str = "visc") -> None:
        if method == "hold":
            law = "hold"
        self.law = get_law(law)
        if self.law.methods and method not in self.law.methods:
            raise ValueError(f"SDC law {law!r}: method must be one of {self.law.methods}, got {method!r}")
        self.capacity = capacity
        self.method = method
        self.started = np.zeros(capacity, dtype=bool)
        self.initialised = np.zeros(capacity, dtype=bool)
        self.pending_params: dict[int, dict] = {}
        self.visc = self.law.bank(capacity, step_s, method, dtype)
        """The law's controllers (DiscreteVisc for the ViSC; the interface: law_trapezoid.TrapezoidControllers)."""
        self.compiled_answers = self.visc.answers_datagrams
        """True where :meth:`answer_datagrams` is available (the compiled Tustin engine)."""
        self._ctrl_size = {True: ctrl_bytes(True), False: ctrl_bytes(False)}
        self._ctrl_out = np.empty(capacity * ctrl_bytes(True), dtype=np.uint8)  # answer_datagrams' (grown when needed)

    def warm_up(self, steps: int = 50) -> None:
        """Run every code path once on the last slot with a synthetic operating point, then reset
        it, so the first real measurement is not slowed by first-call costs."""
        slot = self.capacity - 1
        op = {"v_d": 1.0, "v_q": 0.0, "i_d": 0.5, "i_q": 0.1, "p": 0.5, "q": -0.1, "v_dc": 1.0, "omega_meas": 1.0}
        meas = {k: np.array([v]) for k, v in op.items()}
        self.start(slot, {"mask": 0})
        for _ in range(steps):
            self.step(np.array([slot]), meas)
        self.track(np.array([slot]), meas)
        if self.compiled_answers:
            values = tuple(op[k] for k in MEAS_FIELDS)
            for header in (wire.Header(1, 0, 0), None):
                data = wire.encode(wire.MsgType.MEAS, {"wt": 101, "seq": 1, "t_sim": 0.0, **op}, header=header)
                self.answer_datagrams([slot], [data], [values], np.zeros(self.capacity, dtype=np.int64), False,
                                      header is not None, 0.0)
        self.stop(slot)

    def start(self, slot: int, params: dict) -> None:
        self.started[slot] = True
        self.initialised[slot] = False
        self.pending_params[slot] = self._own(params_from_mask(params))

    def stop(self, slot: int) -> None:
        self.started[slot] = False
        self.initialised[slot] = False
        self.visc.deactivate([slot])

    def set_params(self, slot: int, params: dict) -> None:
        changes = self._own(params_from_mask(params))
        if changes and self.initialised[slot]:
            self.visc.set_params(slot, **changes)
        elif changes:
            self.pending_params.setdefault(slot, {}).update(changes)

    def _own(self, params: dict) -> dict:
        """The parameters of a REQUEST that are the law's run-time ones (a word the law does not have,
        such as h for the droop law, is not its to set and is left out)."""
        own = self.law.runtime_params
        return {k: v for k, v in params.items() if k in own}

    def runtime_params(self, slot: int) -> dict[str, float]:
        """The run-time parameters (h, d, m_q, v_ref, q_ref, supp) ``slot``'s controller steps with now
        ({} for "hold"); a change made before its first measurement is in ``pending_params`` until then."""
        return {name: float(values[slot]) for name, values in self.visc.rp.items()}

    def take_over(self, slot: int) -> None:
        """Become the active controller of ``slot`` (warm state, if tracked, is kept)."""
        self.started[slot] = True

    def _initialise(self, slots: np.ndarray, meas: dict[str, np.ndarray]) -> None:
        for j, slot in enumerate(slots):
            if self.initialised[slot]:
                continue
            one = {k: meas[k][j : j + 1] for k in MEAS_FIELDS}
            self.visc.initialise([slot], SimpleNamespace(**{k: float(a[0]) for k, a in one.items()}))
            if self.pending_params.get(slot):
                self.visc.set_params(slot, **self.pending_params.pop(slot))
            self.initialised[slot] = True

    def track(self, slots: np.ndarray, meas: dict[str, np.ndarray]) -> None:
        """Warm standby: follow ``slots``' measurements (initialise, then advance states) without output."""
        slots = np.asarray(slots)
        finite = np.all([np.isfinite(meas[k]) for k in MEAS_FIELDS], axis=0)
        fresh = finite & ~self.initialised[slots]
        self._initialise(slots[fresh], {k: v[fresh] for k, v in meas.items()})
        follow = finite & ~fresh
        if not follow.any():
            return
        full = {k: np.zeros(self.capacity) for k in MEAS_FIELDS}
        for k in MEAS_FIELDS:
            full[k][slots[follow]] = meas[k][follow]
        self.visc.track(SimpleNamespace(**full), index=slots[follow])

    def step(self, slots: np.ndarray, meas: dict[str, np.ndarray] | np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """Advance the controllers of ``slots`` by one sample; returns (outputs, valid) per given slot.
        ``meas``: the MEAS_FIELDS by name, or a (len(MEAS_FIELDS), len(slots)) matrix in that row order."""
        slots = np.asarray(slots, dtype=np.intp)
        if slots.size == 0:
            return {k: np.zeros(0, dtype=bool if k == "limited" else float) for k in OUT_KEYS}, np.zeros(0, dtype=bool)
        if isinstance(meas, np.ndarray):
            rows = np.asarray(meas, dtype=float)
        else:
            rows = np.array([meas[k] for k in MEAS_FIELDS], dtype=float)
        usable = np.isfinite(rows).all(axis=0) & self.started[slots]
        all_usable = bool(usable.all())
        used = slots if all_usable else slots[usable]
        if not self.initialised[used].all():  # only a fresh slot needs the (per-slot) initialisation
            named = dict(zip(MEAS_FIELDS, rows)) if isinstance(meas, np.ndarray) else meas
            self._initialise(used, {k: v[usable] for k, v in named.items()})
        return self._step_visc(slots, rows, usable, used, all_usable)

    def answer_datagrams(self, slots: list[int], datagrams: list[bytes], values: list[tuple], ctrl_seq: np.ndarray,
                         backup: bool, header: bool, now: float) -> list[bytes | None]:
        """The compiled way (:attr:`compiled_answers`) of :func:`sdc_unit.round.answer`: advance
        ``slots[j]`` on the admitted MEAS datagram ``datagrams[j]`` (its MEAS_FIELDS ``values[j]``),
        in order, and return its CTRL datagram, or None where there is none (not stepped, or not
        encodable: ``ctrl_seq[slot]`` numbers the answers and is advanced in place for every
        stepped sample). A started slot's first sample initialises it first, as :meth:`step` does.
        One kernel call (:func:`sdc_unit.ctrl_jit.meas_to_ctrl`) whatever the number of datagrams."""
        initialised = self.initialised
        for slot in slots:
            if not initialised[slot]:
                self._initialise_first(slots, values)
                break
        n = len(slots)
        size = self._ctrl_size[header]
        if n * size > len(self._ctrl_out):  # the buffer for the largest batch so far
            self._ctrl_out = np.empty(n * size, dtype=np.uint8)
        sec, nsec = header_time(now) if header else (0, 0)
        rows = np.array(slots, dtype=np.int64)  # in: the slots; out: the codes
        self.visc.meas_to_ctrl(rows, np.frombuffer(b"".join(datagrams), dtype=np.uint8), header, self._ctrl_out,
                               ctrl_seq, FLAG_BACKUP if backup else 0, sec, nsec)
        codes = rows.tolist()
        if n == 1:  # (the same answer, without cutting a joined copy)
            return [self._ctrl_out[:size].tobytes() if codes[0] == SENT else None]
        sent = self._ctrl_out[:n * size].tobytes()
        return [sent[j * size:(j + 1) * size] if code == SENT else None for j, code in enumerate(codes)]

    def _initialise_first(self, slots: list[int], values: list[tuple]) -> None:
        """Initialise each started, not yet initialised slot of ``slots`` from its first row of ``values``."""
        first: dict[int, tuple] = {}
        for slot, row in zip(slots, values):
            if not self.initialised[slot] and self.started[slot]:
                first.setdefault(slot, row)
        if first:
            rows = list(first.values())
            self._initialise(np.fromiter(first, dtype=np.intp, count=len(first)),
                             {k: np.array([row[r] for row in rows]) for r, k in enumerate(MEAS_FIELDS)})

    def _step_visc(self, slots, rows, usable, used, all_usable):
        visc = self.visc
        if all_usable:  # the usual case: the step hands back the slots' outputs (rows OUT_FIELDS)
            valid, outputs, limited = visc.advance_slots(used, rows)
        else:
            valid = usable.copy()
            valid[usable] = visc.advance_slots(used, rows[:, usable])[0]
            outputs, limited = np.array([visc.last[k] for k in CTRL_OUTPUTS])[:, slots], visc.last_limited[slots]
        out = dict(zip(CTRL_OUTPUTS, outputs))  # CTRL_OUTPUTS are the first OUT_FIELDS
        out["limited"] = limited
        return out, valid


def precompile() -> None:
    """Compile (or load from numba's on-disk cache) the compiled Tustin step for float64 and float32,
    so that an SDC started in a run does not spend seconds compiling (``./testbed`` and the Docker
    build call this)."""
    for dtype in ("float64", "float32"):
        ControllerBank(2, 0.67e-3, dtype=dtype).warm_up(steps=2)
