"""What followed an action, in words: the interactive session's feedback (``sdvisc run --cli``).

Pure: :class:`Feedback` reads the run's events (the records of ``events.jsonl``: each a dict with
``t`` in simulated seconds from t = 0, ``type``, ``source`` and details) as they arrive and returns
the lines to show a person, e.g.::

    wt1_1: control lost at 14.81 s; DR at 14.85 s; new path sdc1-s1-s4-l2-wt1_1; restored after 63 ms

A loss of a ViSC turbine's control packets (the plant's ``ctrl_lost``/``ctrl_restored``,
:mod:`plant.service.live`) is followed from its start to its end, with the SDN app's reactions in between
(``dr``, ``port_status``, ``sdc_failover``, ``no_path``, ``path_restored``, ``dr_not_acted``);
``restored after`` counts from the action that caused it (a ``link_down``, ``kill`` or
``impair`` just before), else from the loss. A loss still open after ``follow_s`` is reported
as such. An SDN reaction to a turbine whose control packets the plant never saw stop (its
acknowledgements went missing, e.g. on a busy machine, and the reroute was hitless) is reported
``quiet_s`` after the reaction as exactly that, not as a loss. An action after which no turbine
lost its control packets within ``quiet_s`` says so; a ``visc_on`` is followed until the turbine's first control packet (or its refusal).
Also: :func:`event_line` (one event as a line, the CLI's ``events``), :func:`watch_line` (one
turbine's live numbers, the CLI's ``watch``) and :func:`progress_line` (a run's progress on the terminal).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from plant.service.live import LOSS_REPORT_S

FOLLOW_S = 2.0  # a loss not restored this long after it started is reported as such
QUIET_S = 0.5  # an action followed by no loss for this long is reported as harmless
FAULT_ACTIONS = ("link_down", "kill", "impair")  # actions that can interrupt control packets
ACTION_SOURCES = ("cli", "timeline")
REACTIONS = {"dr": "DR", "port_status": "rerouted on port status"}


def path_text(path) -> str:
    return "-".join(path) if path else "?"


def _s(t: float) -> str:
    return f"{t:.2f} s"


def action_text(e: dict) -> str:
    """A user's or the timeline's action in a few words (``link s1-s3 down``)."""
    kind = e.get("type", "?")
    if kind in ("link_down", "link_up"):
        return f"link {e.get('a')}-{e.get('b')} {kind.removeprefix('link_')}"
    if kind == "kill":
        process = e.get("process", "?")
        name = process if process.startswith("controller") else f"{process} on {e.get('host')}"
        return f"{'crash of' if e.get('crash') else 'kill'} {name}"
    if kind in ("visc_on", "visc_off", "set_params"):
        return f"{kind} {e.get('wt')}"
    if kind == "impair":  # the CLI records the link's impairment as it now is ("now"), the timeline the keys set
        values = e["now"] if isinstance(e.get("now"), dict) else e
        settings = " ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in sorted(values.items())
                            if k not in ("t", "t_effective", "type", "source", "a", "b", "now") and v not in (None, 0, 0.0))
        return f"link {e.get('a')}-{e.get('b')} impair {settings}".rstrip()
    details = " ".join(f"{k}={v}" for k, v in e.items() if k not in ("t", "type", "source", "t_effective"))
    return f"{kind} {details}".rstrip()


@dataclass
class _Loss:
    """One turbine's interruption of control packets, from loss to restoration."""

    wt: str
    t_loss: float
    cause: dict | None  # the action just before it
    steps: list[str] = field(default_factory=list)
    reported_open: bool = False
    seen_by_plant: bool = False  # the plant reported the loss (ctrl_lost), not only an SDN reaction
    t_reaction: float | None = None  # the SDN app's first reaction to it

    def text(self) -> str:
        return "; ".join([f"{self.wt}: control lost at {_s(self.t_loss)}", *self.steps])

    def text_without_loss(self) -> str:
        return "; ".join([f"{self.wt}: acknowledgements missing from {_s(self.t_loss)}", *self.steps,
                          f"its control packets did not stop (no pause of {LOSS_REPORT_S * 1e3:.0f} ms "
                          f"or more at the turbine)"])


@dataclass
class _Pending:
    """An action whose consequences are awaited."""

    action: dict
    t: float
    wt: str | None = None
    info: dict = field(default_factory=dict)
    caused_loss: bool = False


class Feedback:
    """See the module docstring; ``feed`` returns the lines to show now."""

    def __init__(self, follow_s: float = FOLLOW_S, quiet_s: float = QUIET_S) -> None:
        self.follow_s = follow_s
        self.quiet_s = quiet_s
        self.losses: dict[str, _Loss] = {}
        self.pending: list[_Pending] = []
        self.faults: list[dict] = []  # fault actions so far (for causes)
        self.impaired: dict[tuple, dict] = {}  # links with an impairment now (their last impair action)
        self.pauses: dict[str, tuple[float, int]] = {}  # per turbine: last pause line shown, pauses not shown since
        self.no_controller = False  # no SDN application runs (the runner's no_controller, until one restarts)

    def feed(self, events: list[dict], now: float) -> list[str]:
        """Take the events that arrived since the last call (any order); ``now``: scenario time."""
        out: list[str] = []
        for e in sorted(events, key=lambda e: e.get("t", 0.0)):
            if e.get("shadow"):
                continue  # decided by a slave SDN app, never sent
            out += self._event(e)
        return out + self._expire(now)

    # ------------------------------------------------------------------ events
    def _event(self, e: dict) -> list[str]:
        kind, source, t = e.get("type"), e.get("source", ""), float(e.get("t", 0.0))
        if source in ACTION_SOURCES:
            return self._action(e, t)
        handler = getattr(self, f"_on_{kind}", None)
        return handler(e, t) if handler else []

    def _action(self, e: dict, t: float) -> list[str]:
        kind = e.get("type")
        t_act = float(e.get("t_effective", t))
        out = [] if e.get("source") == "cli" else [f"t={t_act:.3f} s: timeline: {action_text(e)}"]
        if kind in FAULT_ACTIONS:
            self.faults.append(dict(e, t=t_act))
            self.pending.append(_Pending(e, t_act))
        if kind == "impair":
            self.impaired[tuple(sorted((e.get("a"), e.get("b"))))] = e
        elif kind == "clear_impairments":
            if e.get("a") is None:
                self.impaired.clear()
            else:
                self.impaired.pop(tuple(sorted((e.get("a"), e.get("b")))), None)
        elif kind in ("visc_on", "visc_off"):
            self.pending.append(_Pending(e, t_act, wt=e.get("wt")))
        return out

    def _cause(self, t_loss: float) -> dict | None:
        """The latest fault action at most 10 ms after ``t_loss`` and at most 1 s before it."""
        before = [f for f in self.faults if t_loss - 1.0 <= f["t"] <= t_loss + 0.01]
        return before[-1] if before else None

    def _loss(self, wt: str, t_loss: float) -> _Loss:
        loss = self.losses.get(wt)
        if loss is None:
            loss = self.losses[wt] = _Loss(wt, t_loss, self._cause(t_loss))
            if self.no_controller:
                loss.steps.append("no SDN application running to react")
            for p in self.pending:
                if p.action.get("type") in FAULT_ACTIONS and p.t <= t_loss + 0.01:
                    p.caused_loss = True
        return loss

    def _on_ctrl_lost(self, e: dict, t: float) -> list[str]:
        loss = self._loss(e["wt"], float(e.get("t_loss", t)))
        loss.t_loss = float(e.get("t_loss", loss.t_loss))  # the plant knows the last packet exactly
        loss.seen_by_plant = True
        loss.cause = loss.cause or self._cause(loss.t_loss)
        return []

    def _reaction(self, e: dict, t: float, text: str) -> list[str]:
        t_loss = e.get("t_loss")
        loss = self._loss(e["wt"], float(t_loss) if t_loss is not None else t)
        loss.steps.append(text)
        if loss.t_reaction is None:
            loss.t_reaction = t
        return []

    def _on_dr(self, e: dict, t: float) -> list[str]:
        return self._reaction(e, t, f"DR at {_s(t)}; new path {path_text(e.get('new_path'))}")

    def _on_port_status(self, e: dict, t: float) -> list[str]:
        return self._reaction(e, t, f"rerouted on port status at {_s(t)}; new path {path_text(e.get('new_path'))}")

    def _on_dr_not_acted(self, e: dict, t: float) -> list[str]:
        return self._reaction(e, t, f"DR at {_s(t)} not acted on ({e.get('reason', '')})")

    def _on_no_path(self, e: dict, t: float) -> list[str]:
        return self._reaction(e, t, f"no path to its SDC at {_s(t)} (cut off)")

    def _on_path_restored(self, e: dict, t: float) -> list[str]:
        return self._reaction(e, t, f"path restored at {_s(t)}: {path_text(e.get('new_path'))}")

    def _on_sdc_failover(self, e: dict, t: float) -> list[str]:
        for wt in e.get("turbines", []):
            self._reaction({"wt": wt, "t_loss": e.get("t_loss")}, t,
                           f"SDC failover {e.get('sdc')} -> {e.get('backup')} at {_s(t)}")
        return []

    def _on_ctrl_restored(self, e: dict, t: float) -> list[str]:
        wt = e["wt"]
        loss = self.losses.pop(wt, None)
        if loss is None:
            loss = _Loss(wt, float(e.get("t_loss", t)), self._cause(float(e.get("t_loss", t))))
        if loss.reported_open:
            return [f"{wt}: control restored at {_s(t)}, {t - loss.t_loss:.2f} s after it was lost"]
        if loss.cause is None and not loss.steps:  # nothing done and nothing reacted
            return self._pause(wt, loss.t_loss, t)
        since = loss.cause["t"] if loss.cause else loss.t_loss
        after = f"restored after {(t - since) * 1e3:.0f} ms"
        if loss.cause:
            after += f" ({action_text(loss.cause)} at {_s(loss.cause['t'])})"
        return [f"{loss.text()}; {after}"]

    def _pause(self, wt: str, t_loss: float, t: float) -> list[str]:
        """A gap no action caused and nothing reacted to: an impaired link's loss or delay, or a busy
        machine. At most one line per turbine and second; the ones left out are counted."""
        shown, hidden = self.pauses.get(wt, (float("-inf"), 0))
        if t - shown < 1.0:
            self.pauses[wt] = (shown, hidden + 1)
            return []
        self.pauses[wt] = (t, 0)
        why = (f"link {', '.join('-'.join(k) for k in sorted(self.impaired))} impaired" if self.impaired
               else "no fault, no SDN reaction: this machine was busy?")
        more = f"; {hidden} more such pause{'s' if hidden > 1 else ''} before" if hidden else ""
        return [f"{wt}: control packets paused {(t - t_loss) * 1e3:.0f} ms at {_s(t_loss)} ({why}){more}"]

    def _on_visc_on(self, e: dict, t: float) -> list[str]:
        for p in self.pending:
            if p.wt == e.get("wt") and p.action.get("type") == "visc_on":
                p.info.update(sdc=e.get("sdc"), path=e.get("path"), t_on=t)
        return []

    def _on_ctrl_started(self, e: dict, t: float) -> list[str]:
        wt = e["wt"]
        p = next((p for p in self.pending if p.wt == wt and p.action.get("type") == "visc_on"), None)
        if p is not None:
            self.pending.remove(p)
        info = p.info if p else {}
        where = f" via {path_text(info['path'])} (SDC {info.get('sdc')})" if info.get("path") else ""
        return [f"{wt}: ViSC on{where}; first control packet at {_s(t)}, {e.get('after_ms', 0):.0f} ms after its stream started"]

    def _on_request_refused(self, e: dict, t: float) -> list[str]:
        self.pending = [p for p in self.pending if p.wt != e.get("wt")]
        return [f"{e.get('wt')}: {e.get('cmd', 'request')} refused by the SDN app at {_s(t)}: {e.get('reason')}"]

    def _on_stream_stop(self, e: dict, t: float) -> list[str]:
        wt = e.get("wt")
        self.pending = [p for p in self.pending if not (p.wt == wt and p.action.get("type") == "visc_off")]
        self.losses.pop(wt, None)
        return [f"{wt}: ViSC off; its stream stopped at {_s(t)}"]

    def _on_link_down(self, e: dict, t: float) -> list[str]:
        return [f"link {'-'.join(e.get('link', []))}: down, seen by the SDN app at {_s(t)} (port status)"]

    def _on_link_up(self, e: dict, t: float) -> list[str]:
        return [f"link {'-'.join(e.get('link', []))}: up, seen by the SDN app at {_s(t)} (port status)"]

    def _on_sdc_dead(self, e: dict, t: float) -> list[str]:
        return [f"{e.get('sdc')}: declared dead by the SDN app at {_s(t)} (no heartbeat)"]

    def _on_failover_unavailable(self, e: dict, t: float) -> list[str]:
        return [f"{e.get('sdc')}: no backup SDC to fail over to; {', '.join(e.get('turbines', [])) or 'no turbine'} left without"]

    def _on_sdc_alive(self, e: dict, t: float) -> list[str]:
        return [f"{e.get('sdc')}: heartbeats again at {_s(t)}"]

    def _on_no_controller(self, e: dict, t: float) -> list[str]:
        self.no_controller = True
        return [f"no SDN application running since {_s(t)}: switches keep their flows, nothing reacts to failures"]

    def _on_service_restarted(self, e: dict, t: float) -> list[str]:
        if str(e.get("process", "")).startswith("controller"):
            self.no_controller = False
        return [f"{e.get('process')}: exited with {e.get('exit_code')}; restarted at {_s(t)} (restart {e.get('restart')})"]

    def _on_controller_takeover(self, e: dict, t: float) -> list[str]:
        return [f"SDN app instance {e.get('instance')} took over as master at {_s(t)}"]

    # ------------------------------------------------------------------ time passing
    def _expire(self, now: float) -> list[str]:
        out = []
        for wt, loss in list(self.losses.items()):
            if (not loss.seen_by_plant and loss.t_reaction is not None
                    and now - max(loss.t_reaction, loss.t_loss + LOSS_REPORT_S) >= self.quiet_s):
                del self.losses[wt]  # the plant would have reported a loss by now
                out.append(loss.text_without_loss())
            elif not loss.reported_open and now - loss.t_loss >= self.follow_s:
                loss.reported_open = True
                out.append(f"{loss.text()}; not restored {self.follow_s:.1f} s later")
        keep = []
        for p in self.pending:
            kind = p.action.get("type")
            if kind in FAULT_ACTIONS and now - p.t >= self.quiet_s:
                if not p.caused_loss:
                    out.append(f"{action_text(p.action)}: no ViSC turbine lost its control packets "
                               f"in the {self.quiet_s:.1f} s after it")
            elif kind in ("visc_on", "visc_off") and now - p.t >= self.follow_s:
                out.append(f"{p.wt}: {kind} asked at {_s(p.t)}; no {'control packet' if kind == 'visc_on' else 'stream stop'} "
                           f"{self.follow_s:.1f} s later")
            else:
                keep.append(p)
        self.pending = keep
        return out


# ---------------------------------------------------------------------- the CLI's events and watch
HIDDEN_KEYS = ("t", "type", "source", "t_wall")


def event_line(e: dict) -> str:
    """One event of ``events.jsonl`` as one line: time, source, type, details."""
    details = []
    for k, v in e.items():
        if k in HIDDEN_KEYS:
            continue
        if isinstance(v, list) and v and all(isinstance(x, str) for x in v):
            v = "-".join(v) if k.endswith("path") or k == "link" else ",".join(v)
        elif isinstance(v, float):
            v = f"{v:.4g}"
        details.append(f"{k}={v}")
    return f"{e.get('t', 0.0):10.3f} s  {e.get('source', '?'):10} {e.get('type', '?'):18} {' '.join(details)}"


def watch_line(wt: str, status: dict, previous: dict | None, tables: dict) -> str:
    """One turbine's live numbers: packets/s (from two plant status readings), the control packets'
    one-way delay, V, Q, f, T2/T3 and the installed path."""
    row = status.get("turbines", {}).get(wt)
    if row is None:
        return f"{wt}: not a turbine of this run"
    t = status.get("t_sim", 0.0)
    rates = "meas -/s  ctrl -/s"
    prev_row = (previous or {}).get("turbines", {}).get(wt)
    dt = t - (previous or {}).get("t_sim", t)
    if prev_row is not None and dt > 0:
        rates = (f"meas {(row['meas_tx'] - prev_row['meas_tx']) / dt:5.0f}/s  "
                 f"ctrl {(row['ctrl_rx'] - prev_row['ctrl_rx']) / dt:5.0f}/s")
    delay = row.get("ctrl_delay_ms")
    grid = (f"V={row['v']:.4f} Q={row['q']:+.4f} f={row['f_hz']:.3f} Hz" if row.get("streaming") and "v" in row
            else "not streaming (no ViSC)")
    path = tables.get("paths", {}).get(wt, {}).get("path")
    return (f"t={t:8.2f} s  {wt}  {rates}  one-way {f'{delay:.2f} ms' if delay is not None else '-'}  {grid}  "
            f"T2 {tables.get('T2', {}).get(wt, '?')} T3 {tables.get('T3', {}).get(wt, '?')}  path {path_text(path) if path else '-'}")


def progress_line(status: dict, duration_s: float, width: int = 30) -> str:
    """A run's progress from the plant's live status (``plant_status.json``; empty before it starts):
    a bar over the scenario's duration, late steps, packets sent and received, the ViSC turbines."""
    t = min(status.get("t_sim", 0.0), duration_s)
    filled = int(width * t / duration_s) if duration_s else width
    return (f"[{'#' * filled}{'.' * (width - filled)}] t={t:6.2f}/{duration_s:.2f} s  late={status.get('late_steps', 0)}"
            f"  meas_tx={status.get('meas_tx', 0)}  ctrl_rx={status.get('ctrl_rx', 0)}"
            f"  visc={','.join(status.get('streaming', [])) or '-'}")
