"""Assemble ``summary.json`` and ``events.jsonl`` from what the run's processes wrote.

``summary.json`` is a contract other tools read: ``scenario``, ``duration_s``, ``step_s``, ``steps``,
``late_steps``, ``turbines`` (per turbine ``packets`` with ``meas_tx``, ``meas_rx_sdc``,
``ctrl_tx_sdc``, ``ctrl_rx``, ``ak_tx`` and the measured one-way delays), ``events`` (each ``t``,
``type`` and details), ``recoveries`` (each ``wt``, ``cause``, ``t_fault``, ``t_detect``,
``t_restored``, ``recovery_ms``), ``openflow`` (controller↔switch message counts) and
``impairments`` (impaired links: configured values over time, what each element measured;
:mod:`scenarios.impairments`). The per-turbine rows add up the same way whatever the plant was
(:mod:`scenarios.summary_turbines`: ``meas_rx_sdc``/``ctrl_tx_sdc`` over every SDC, a killed SDC's
counts from its last snapshot, ``sdc_stats_partial``); with a real card (the run did not start it)
its side is counted from the capture on its cable (:mod:`scenarios.peer_tap`, ``peer`` says how and to
what resolution) and what nobody counted is ``null``, never 0.
"""

from __future__ import annotations

import json
import platform
import time
from pathlib import Path

from scenarios import peer_tap
from scenarios.impairments import summary_section as impairments_section
from scenarios.interruptions import FAULT_TYPES, RESTORE_TYPES, interruptions
from scenarios.summary_turbines import (  # noqa: F401 - round_trip: part of this module's interface
    NOT_COUNTED,
    long_gaps,
    meas_resumed,
    peer_as_plant,
    round_trip,
    sdc_stats_missing,
    sdc_stats_partial,
    turbine_rows,
)

SUMMARY_VERSION = 1


def _read_json(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError):
        return {}


def _read_jsonl(path: Path) -> list[dict]:
    try:
        return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    except (OSError, json.JSONDecodeError):
        return []


CLOCK_KEYS = ("t_loss", "t_detect", "t_last_heartbeat", "t_last_peer")  # in events with t_wall: clock readings


def on_run_clock(e: dict, t0: float) -> dict:
    """A component's event with its clock readings (``t_wall`` and the SDN app's :data:`CLOCK_KEYS`)
    as seconds from t = 0, ``t_wall`` becoming ``t`` (changes and returns ``e``)."""
    if "t_wall" in e:
        e["t"] = round(e.pop("t_wall") - t0, 6)
        for key in CLOCK_KEYS:
            if isinstance(e.get(key), (int, float)):
                e[key] = round(e[key] - t0, 6)
    return e


def _wall_to_t(events: list[dict], t0: float | None, source: str) -> list[dict]:
    out = []
    for e in events:
        e = dict(e)
        if t0 is not None:
            on_run_clock(e, t0)
        e.setdefault("source", source)
        out.append(e)
    return out


DETECT_TYPES = ("dr", "port_status", "sdc_failover", "no_path", "path_restored")
GAP_MATCH_S = 0.010
MIN_INTERRUPTION_S = 0.020  # shorter gaps without an SDN reaction are jitter, not a fault's effect  # a control-packet gap belongs to a fault if it starts at most this long after it


def recoveries(faults: list[dict], plant_turbines: dict, events: list[dict], t0: float | None,
               duration_s: float, no_controller: list | None = None) -> list[dict]:
    """One record per (fault, turbine whose control packets it interrupted).

    ``t_fault`` is the timeline event, ``t_detect`` the SDN app's first reaction for that turbine
    (DR, port status or SDC failover), ``t_restored`` the first control packet the turbine received
    after the interruption; ``recovery_ms = t_restored − t_fault``. A turbine whose control packets
    stopped and never came back has ``t_restored`` and ``recovery_ms`` None. Where nothing reacted
    because no SDN application was running at the fault (``no_controller``: [from, to or None]
    intervals), ``cause`` says so.
    """
    down = [(a, b if b is not None else float("inf")) for a, b in (no_controller or [])]
    if t0 is None:
        return []
    out = []
    for fault in faults:
        t_f = fault.get("t_effective", fault["t"])
        for wt, stats in sorted(plant_turbines.items()):
            gaps = [(a - t0, b - t0) for a, b in long_gaps(stats)]
            last = stats.get("last_ctrl_wall")
            last_t = last - t0 if last is not None else None
            # control packets stopped for good shortly after the fault (a few may still arrive in flight)
            stopped = (last_t is not None and t_f - GAP_MATCH_S <= last_t <= t_f + 0.1
                       and last_t < duration_s - 0.05)
            window = [(a, b) for a, b in gaps if t_f - GAP_MATCH_S <= a <= t_f + 0.1 and b >= t_f]
            gap = None if stopped or not window else max(window, key=lambda g: g[1] - g[0])
            if gap is None and not stopped:
                continue
            latest = (gap[1] + 0.005) if gap else t_f + 1.0
            reaction = next((e for e in events if e.get("type") in DETECT_TYPES
                             and t_f - 1e-3 <= e.get("t", -1) <= latest
                             and (e.get("wt") == wt or wt in e.get("turbines", []))), None)
            if gap is not None and reaction is None and gap[1] - gap[0] < MIN_INTERRUPTION_S:
                continue  # ordinary delay jitter, not an interruption caused by this fault
            t_restored = gap[1] if gap else None
            out.append({
                "wt": wt,
                "fault": {k: v for k, v in fault.items() if k not in ("source",)},
                "cause": reaction["type"] if reaction else (
                    "no_controller" if any(a <= t_f <= b for a, b in down) else "none"),
                "t_fault": round(t_f, 6),
                "t_loss": round(gap[0], 6) if gap else round(last_t, 6),
                "t_detect": round(reaction["t"], 6) if reaction else None,
                "t_restored": round(t_restored, 6) if t_restored is not None else None,
                "recovery_ms": round((t_restored - t_f) * 1e3, 3) if t_restored is not None else None,
                "detect_ms": round((reaction["t"] - t_f) * 1e3, 3) if reaction else None,
            })
    return out


def rejections(plant: dict, sdcs: dict, sdn: dict, owfcc: dict) -> dict:
    """What each service dropped, by reason (wire-level reasons included), and the total."""
    out = {"plant": dict(plant.get("rx_rejected", {})),
           **{s: dict(d.get("rejected", {})) for s, d in sdcs.items()},
           "sdn_app": {k.removeprefix("drop_"): v for k, v in sdn.get("counters", {}).items()
                       if k.startswith("drop_") and ":" not in k},
           "owfcc": {k.removeprefix("rx_reject_"): v for k, v in owfcc.items() if k.startswith("rx_reject_")}}
    for wire_reason, n in (sdn.get("wire") or {}).items():
        if wire_reason not in ("ok", "rejected") and n:
            out["sdn_app"][wire_reason] = n
    out["total"] = sum(sum(v.values()) for v in out.values())
    return out


NOT_SCALED = ("Open vSwitch: packet forwarding, revalidation (not within 5 ms of the previous round), "
              "port-down detection, inactivity probes, MAC ageing, the reconfiguration of every bridge at any link "
              "event (forwarding pauses meanwhile)", "kernel: socket and qdisc queues, veths",
              "OpenFlow message handling inside ovs-vswitchd")


def time_section(run) -> dict:
    """What the run's clock was: every time a user reads is in simulated seconds; at a time scale
    k > 1 the network looked k times faster than this machine's (what is not scaled)."""
    clock = getattr(run, "clock", None)
    k = clock.time_scale if clock is not None else 1.0
    started = getattr(run, "wall_started", None)
    ended = getattr(run, "wall_ended", None)
    out = {"time_scale": k, "units": "simulated seconds",
           "wall_duration_s": round(ended - started, 3) if started and ended else None,
           "not_scaled": list(NOT_SCALED) if k != 1 else []}
    for phases in ("setup_wall_s", "teardown_wall_s"):
        if getattr(run, phases, None):
            out[phases] = dict(getattr(run, phases))
    calibration = getattr(run, "calibration", None)
    if calibration is not None:
        out["calibration"] = calibration
    return out


LATE_ADVICE_FRACTION = 0.01
ADVICE_VERDICT = ": this machine could not keep up; "
"""Between what was late and what to do in :func:`time_advice` (the CLI keeps only the first part
when the calibration cache already holds the larger k)."""


def time_advice(k: float, steps: int, late_steps: int, within_one: dict[str, float] | None = None) -> str | None:
    """What to do when more than 1 % of the plant's steps were late at time scale ``k``, or more
    than 1 % of a turbine's control answers came a sample or more late (``within_one``: the share
    within one sample per turbine)."""
    said = []
    if steps and late_steps > LATE_ADVICE_FRACTION * steps:
        said.append(f"{late_steps / steps:.1%} of the plant's steps were late")
    slow = {wt: share for wt, share in (within_one or {}).items() if share < 1 - LATE_ADVICE_FRACTION}
    if slow:
        worst = min(slow, key=slow.get)
        said.append(f"MEAS->CTRL took more than one sample for {1 - slow[worst]:.1%} of {worst}'s answers")
    if not said:
        return None
    return (f"{'; '.join(said)} at time scale {k:g}{ADVICE_VERDICT}"
            f"run again with --time-scale {2 * k:g}")


def cpu_section(run, steps: int, plant_cpu_s: float | None = None) -> dict:
    """CPU seconds each process used from t = 0 to the end (/proc), and per plant step in µs."""
    used = dict(getattr(run, "cpu_used", {}) or {})
    if plant_cpu_s is not None:
        used["plant"] = plant_cpu_s  # measured by the plant itself (it has ended when the runner looks)
    return {name: {"cpu_s": s, "us_per_step": round(s / steps * 1e6, 2) if steps else None}
            for name, s in sorted(used.items())}


def build_summary(run, *, completed: bool, source: str | None = None) -> dict:
    out: Path = run.out
    sc = run.scenario
    card = _read_json(out / "gtnet_card_stats.json")
    plant = _read_json(out / "plant_stats.json")
    sdcs = {p.stem.split("_")[0]: _read_json(p) for p in sorted(out.glob("sdc*_stats.json"))}
    tap = peer_tap.read(run) if sc.plant.model == "external" else None  # a real card: its cable's capture
    if sc.plant.model == "external":
        plant = peer_as_plant(card, sdcs, tap)
    owfcc = _read_json(out / "owfcc_stats.json")
    sdn_states = [st for st in (_read_json(out / "sdn_state.json"), _read_json(out / "sdn2_state.json")) if st]
    in_charge = [st for st in sdn_states if st.get("role") in ("master", "equal", None)]
    sdn = max(in_charge or sdn_states, key=lambda st: (st.get("generation", 0), st.get("t_wall", 0)), default={})
    events = list(run.timeline_events)
    events += _wall_to_t(_read_jsonl(out / "sdn_events.jsonl"), run.t0, "sdn_app")
    events += _wall_to_t(_read_jsonl(out / "sdn2_events.jsonl"), run.t0, "sdn_app2")
    events += _wall_to_t(_read_jsonl(out / "owfcc_events.jsonl"), run.t0, "owfcc")
    events += [dict(e, source="plant") for e in plant.get("events", [])]
    for name, sdc in sdcs.items():
        events += _wall_to_t(sdc.get("events", []), run.t0, name)
    events.sort(key=lambda e: e.get("t", -1e9))
    faults = [e for e in run.timeline_events if e["type"] in FAULT_TYPES]
    restores = [e for e in run.timeline_events if e["type"] in RESTORE_TYPES]
    duration = sc.duration_s if sc.duration_s is not None else float("inf")
    resumed = meas_resumed(sdcs)
    for e in events:  # decisions taken while the run was being stopped (the plant's last packets)
        if e.get("source", "").startswith("sdn_app") and e.get("t", 0) > sc.duration_s:
            e["after_end"] = True
    with open(out / "events.jsonl", "w") as fh:
        for e in events:
            fh.write(json.dumps(e) + "\n")

    turbines = turbine_rows(plant, sdcs, run.t0)
    return {
        "summary_version": SUMMARY_VERSION,
        "scenario": sc.name,
        "source": source,
        "completed": completed,
        "topology": {"name": sc.topology.name, **sc.topology.params(), "datapath": run.datapath,
                     "switches": len((run.desc or {}).get("switches", {})),
                     "hosts": len((run.desc or {}).get("hosts", {}))},
        "duration_s": sc.duration_s,
        "time": time_section(run),
        "cpu": cpu_section(run, plant.get("steps", 0), plant.get("cpu_s")),
        "step_s": sc.step_s,
        "steps": plant.get("steps", 0),
        "late_steps": plant.get("late_steps", 0),
        "advice": time_advice(run.clock.time_scale if getattr(run, "clock", None) else 1.0, plant.get("steps", 0),
                              plant.get("late_steps", 0),
                              {wt: t["round_trip_samples"]["within_one"] for wt, t in turbines.items()
                               if t["round_trip_samples"]}),
        "max_lateness_ms": plant.get("max_lateness_ms"),
        "converter_trips": plant.get("converter_trips", {}),
        "fallbacks": plant.get("fallbacks", {}),
        "frequency_hz": plant.get("frequency_hz", {}),
        "batteries": plant.get("batteries", {}),
        "peer": ({k: card.get(k) for k in ("framing", "stream", "steps", "late_steps", "totals", "wire")} if card
                 else real_peer_section(run, tap)),
        "external": run.external.describe() if getattr(run, "external", None) else None,  # scenarios/external.py
        "cluster": run.cluster.describe() if getattr(run, "cluster", None) else None,  # scenarios/cluster_run.py
        "t0_wall": run.t0,
        "turbines": turbines,
        "events": events,
        "recoveries": recoveries(faults,
                                 plant.get("turbines", {}), [e for e in events if not e.get("shadow")], run.t0,
                                 sc.duration_s, getattr(run, "no_controller", None)),
        "interruptions": interruptions(faults, plant.get("turbines", {}), run.t0, sc.step_s, duration,
                                       sdc_turbines=resumed,
                                       boundaries=[e.get("t_effective", e["t"]) for e in restores]),
        "restore_interruptions": interruptions(restores, plant.get("turbines", {}), run.t0, sc.step_s, duration,
                                               sdc_turbines=resumed,
                                               boundaries=[e.get("t_effective", e["t"]) for e in faults]),
        "restarts": {n: len(r) for n, r in getattr(run, "restarts", {}).items() if r},
        "no_controller": getattr(run, "no_controller", []),
        "rejected": rejections(plant, sdcs, sdn, owfcc),
        "fuzz": {p.stem: _read_json(p) for pattern in ("fuzz*_*.json", "spoof_ak*_*.json")
                 for p in sorted(out.glob(pattern)) if not p.stem.endswith("_config")},
        "processes_exited_early": {n: c for n, c in run.exited_early.items() if n not in run.killed},
        "processes_killed": sorted(run.killed),
        "sdc_stats_missing": sdc_stats_missing(run, sdcs),
        "sdc_stats_partial": sdc_stats_partial(run, sdcs),
        "openflow": openflow_section(sdn),
        "controllers": {f"instance{st.get('instance', 1)}": {"role": st.get("role"), "generation": st.get("generation"),
                                                            "openflow": st.get("openflow", {})} for st in sdn_states},
        "sdn_counters": sdn.get("counters", {}),
        "tables": {k: sdn.get("tables", {}).get(k, {}) for k in ("T1", "T2", "T3")},
        "wire_rejected": {"plant": plant.get("rx_wire", {}), **{s: d.get("rx_wire", {}) for s, d in sdcs.items()},
                          "sdn_app": sdn.get("wire", {})},
        "sdc": {s: {"role": d.get("role"), "heartbeats_tx": d.get("heartbeats_tx")} for s, d in sdcs.items()},
        "impairments": impairments_section(run),
        "switch_ports": getattr(run, "switch_ports", None) or None,  # scenarios.switch_ports.use
        "switch_links": run.scenario.switch_links,  # scenarios.switch_links
        "cpu_split": getattr(run, "cpu_split", None),  # host_tools.cpu_split.apply
        "switch_revalidation": getattr(run, "switch_revalidation", None),  # host_tools.ovs_revalidation.apply
        "machine": {"python": platform.python_version(), "platform": platform.platform(),
                    "written": time.strftime("%Y-%m-%dT%H:%M:%S%z")},
    }


def openflow_section(sdn: dict) -> dict:
    """The SDN app's controller↔switch message counts, and apart from them what the user asks about:
    ``by_cause`` (flow-mods, packet-outs and other messages a request, a switch's connection, … cost;
    ``per_request``: those of the requests divided by their number) and ``keepalive`` (echo requests
    and connections: they grow with wall time, i.e. with the time scale, not with what happens)."""
    of, counters = dict(sdn.get("openflow", {})), sdn.get("counters", {})
    by_cause: dict[str, dict] = {}
    for key, n in counters.items():
        if key.startswith("of:") and key.count(":") == 2:
            _, cause, kind = key.split(":")
            by_cause.setdefault(cause, {})[kind] = n
    requests = by_cause.get("request", {}).pop("requests", 0)
    if requests:
        of["per_request"] = {kind: round(n / requests, 2) for kind, n in by_cause["request"].items()} | {"requests": requests}
    of["by_cause"] = by_cause
    of["keepalive"] = {"echo_requests_rx": of.get("rx_echo_keepalive", 0), "switch_connects": counters.get("switch_connects", 0)}
    return of


def real_peer_section(run, tap: dict | None) -> dict | None:
    """summary.json ``peer`` for a real card (the run did not start it): where its counts come from,
    to what resolution, and what nobody counted (``None`` in the rows: :data:`NOT_COUNTED`)."""
    peer = run.scenario.plant.peer
    if peer is None or peer.emulate:
        return None
    return {"emulated": False, "framing": peer.framing, "counted_at": (
                f"capture on {peer.interface} (tcpdump; scenarios/peer_tap.py)" if tap else
                "nothing of the card's side (no capture): MEAS and CTRL as the SDCs counted them"),
            "captured": tap["captured"] if tap else None,
            "resolution": {"ctrl_gaps": "capture timestamps (kernel, 1 us) on the run clock, at the card's cable",
                           "ak_zero": f"one AK period ({run.scenario.plant.ak_period_s * 1e3:g} ms)",
                           "time": "the run's clock (t = 0 when the services were ready)"},
            "not_counted": ["steps", "late_steps", "ctrl_stale", "rx_rejected", "round_trip_samples"]}
