"""Assemble ``summary.json`` and ``events.jsonl`` from what the run's processes wrote.

``summary.json`` is a contract other tools read: ``scenario``, ``duration_s``, ``step_s``, ``steps``,
``late_steps``, ``turbines`` (per turbine ``packets`` with ``meas_tx``, ``meas_rx_sdc``,
``ctrl_tx_sdc``, ``ctrl_rx``, ``ak_tx`` and the measured one-way delays), ``events`` (each ``t``,
``type`` and details), ``recoveries`` (each ``wt``, ``cause``, ``t_fault``, ``t_detect``,
``t_restored``, ``recovery_ms``) and ``openflow`` (controller↔switch message counts).
"""

from __future__ import annotations

import json
import platform
import time
from pathlib import Path

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


def _wall_to_t(events: list[dict], t0: float | None, source: str) -> list[dict]:
    out = []
    for e in events:
        e = dict(e)
        if "t_wall" in e and t0 is not None:
            e["t"] = round(e.pop("t_wall") - t0, 6)
        e.setdefault("source", source)
        out.append(e)
    return out


def build_summary(run, *, completed: bool, source: str | None = None) -> dict:
    out: Path = run.out
    sc = run.scenario
    plant = _read_json(out / "plant_stats.json")
    sdcs = {p.stem.split("_")[0]: _read_json(p) for p in sorted(out.glob("sdc*_stats.json"))}
    sdn = _read_json(out / "sdn_state.json")
    events = list(run.timeline_events)
    events += _wall_to_t(_read_jsonl(out / "sdn_events.jsonl"), run.t0, "sdn_app")
    events += _wall_to_t(_read_jsonl(out / "owfcc_events.jsonl"), run.t0, "owfcc")
    events += [dict(e, source="plant") for e in plant.get("events", [])]
    for name, sdc in sdcs.items():
        events += _wall_to_t(sdc.get("events", []), run.t0, name)
    events.sort(key=lambda e: e.get("t", -1e9))
    with open(out / "events.jsonl", "w") as fh:
        for e in events:
            fh.write(json.dumps(e) + "\n")

    turbines = {}
    for name, stats in sorted(plant.get("turbines", {}).items()):
        sdc_rows = {s: d.get("turbines", {}).get(name, {}) for s, d in sdcs.items()}
        meas_rx = sum(r.get("meas_rx", 0) for r in sdc_rows.values())
        ctrl_tx = sum(r.get("ctrl_tx", 0) for r in sdc_rows.values())
        if not (stats.get("meas_tx") or stats.get("ctrl_rx") or meas_rx or ctrl_tx or stats.get("requests_rx")):
            continue  # a turbine that never took part is left out to keep the summary readable
        turbines[name] = {
            "packets": {"meas_tx": stats.get("meas_tx", 0), "meas_rx_sdc": meas_rx, "ctrl_tx_sdc": ctrl_tx,
                        "ctrl_rx": stats.get("ctrl_rx", 0), "ak_tx": stats.get("ak_tx", 0),
                        "ctrl_stale": stats.get("ctrl_stale", 0), "rx_rejected": stats.get("rx_rejected", 0)},
            "per_sdc": {s: {k: r.get(k, 0) for k in ("meas_rx", "ctrl_tx", "meas_lost", "meas_stale",
                                                       "meas_inactive")} | {
                            "first_meas_rx_t": r.get("first_meas_rx_t")} for s, r in sdc_rows.items() if r},
            "first_meas_tx_t": stats.get("first_meas_tx_t"),
            "first_ctrl_rx_t": stats.get("first_ctrl_rx_t"),
            "last_ctrl_rx_t": stats.get("last_ctrl_rx_t"),
            "ak_ones": stats.get("ak_ones", 0),
            "one_way_delay_ms": {
                "meas_to_sdc": next((r.get("meas_one_way_ms") for r in sdc_rows.values() if r.get("meas_one_way_ms")), None),
                "ctrl_to_turbine": stats.get("ctrl_one_way_ms"),
            },
        }
    return {
        "summary_version": SUMMARY_VERSION,
        "scenario": sc.name,
        "source": source,
        "completed": completed,
        "topology": {"name": sc.topology.name, **sc.topology.params(), "datapath": run.datapath,
                     "switches": len((run.desc or {}).get("switches", {})),
                     "hosts": len((run.desc or {}).get("hosts", {}))},
        "duration_s": sc.duration_s,
        "step_s": sc.step_s,
        "steps": plant.get("steps", 0),
        "late_steps": plant.get("late_steps", 0),
        "max_lateness_ms": plant.get("max_lateness_ms"),
        "t0_wall": run.t0,
        "turbines": turbines,
        "events": events,
        "recoveries": [],
        "processes_exited_early": dict(run.exited_early),
        "openflow": sdn.get("openflow", {}),
        "sdn_counters": sdn.get("counters", {}),
        "tables": {k: sdn.get("tables", {}).get(k, {}) for k in ("T1", "T2", "T3")},
        "wire_rejected": {"plant": plant.get("rx_wire", {}), **{s: d.get("rx_wire", {}) for s, d in sdcs.items()},
                          "sdn_app": sdn.get("wire", {})},
        "sdc": {s: {"role": d.get("role"), "heartbeats_tx": d.get("heartbeats_tx")} for s, d in sdcs.items()},
        "machine": {"python": platform.python_version(), "platform": platform.platform(),
                    "written": time.strftime("%Y-%m-%dT%H:%M:%S%z")},
    }
