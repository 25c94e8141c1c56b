"""Recovery benchmark of the SDN application on real Mininet + Open vSwitch + os-ken, with Open
vSwitch's own floor measured in the same run.

Prints one JSON object. For each (topology, mechanism) run — AK/DR, port status, fast-failover
groups — ``--failures`` link failures on the path of one of the ViSC turbines (every 0.6 s a
switch-to-switch link of the path currently carrying it fails, ``path_link_down``, and is restored
0.3 s later; ``prp`` = 1+1 duplication over node-disjoint legs with fast failover, docs/sdn.md); then ``--failover-runs`` SDC kills and ``--controller-failover-runs`` kills of the
master SDN app (scenarios/controller_failover.yaml). Every fault is measured the same way at the
turbine, whatever reacted (summary.json → ``interruptions``, scenarios/interruptions.py): the longest
pause of its control packets around the fault, with no threshold below which a repair disappears.
Per mechanism: percentiles over *all* faults, the count with no interruption above 2·Ts, the
unrecovered count; what the failed links' returns did, apart (``link_return_interruption_ms``); also the old ``recovery_ms`` (fault → first control packet after a pause that the
summary lists as a recovery).

The floor (benchmarks/ovs_latency.py, same machine, same run): Open vSwitch's fast-failover bucket
switch after port down and flow-mod → first packet. Ratios: ``ff_over_floor`` = FF interruption p95
/ OVS FF p95 (goal ≤ 1.5), ``dr_excess_ms`` = DR interruption p95 − (dr_hold + OVS flow-mod p95 +
the turbines' one-way p99 as the path's delay; goal ≤ 5), per topology. ``failover_p95_ms``: kill →
first control packet from the backup, p95 (goal ≤ 60). The floor in the run itself:
``path_restored_ms`` per mechanism (fault → the first MEAS/CTRL through again, by its send time: what
the network needed on this topology under this load, no endpoint delay) and ``ff_over_run_repair``
= FF interruption p95 / its path-restored p95 (the endpoints' share). ``ff_over_topology_floor`` /
``prp_over_topology_floor``: the same p95 over Open vSwitch's fast failover on the run's own
topology (``ovs_latency.measure_topology``: all its bridges and ports, no other traffic; ``system``
ports), where every link event also makes Open vSwitch reconfigure every bridge on the thread that
forwards (``port_event_stall_ms``). ``--time-scale K|auto`` runs the scenarios in
virtual time (figures in simulated ms; the floor stays wall ms). Needs root; ~10 minutes.

    python benchmarks/recovery.py [--failures 16] [--failover-runs 20] [--controller-failover-runs 5]
                                  [--time-scale K|auto] [--switch-ports system|afxdp] [--out DIR]
    python benchmarks/recovery.py --all-links [--time-scale K]   # every single-link failure, AK/DR
    python benchmarks/recovery.py --l2-uplinks 32                 # FF on the L2 uplinks: data plane or DR?
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import liveness_soak  # benchmarks/liveness_soak.py, beside this file
import numpy as np
import ovs_latency  # benchmarks/ovs_latency.py: the floor
from scenario_runs import ROOT, run_file  # benchmarks/scenario_runs.py
from scenario_runs import run_dict as run

from scenarios.interruptions import aggregate
from scenarios.switch_links import SWITCH_LINK_KINDS
from scenarios.switch_ports import SWITCH_PORT_TYPES
from topologies import topos
from topologies.base import describe

GOALS = {"dr_p95_ms": 50.0, "ff_over_floor": 1.5, "dr_excess_ms": 5.0, "failover_p95_ms": 60.0}
DR_HOLD_MS = 40.0  # the scenarios' dr_hold_s (SdnSpec default)
TOPOLOGIES = {
    "paper": ({"name": "paper", "clusters": 2, "turbines": 2}, ["wt1_1", "wt2_2"]),
    "farm": ({"name": "farm", "clusters": 5, "turbines": 10, "layout": "compact"}, ["wt1_1", "wt4_5"]),
}
MECHANISMS = {
    "dr": {"dynamic_routing": True, "reroute_on_port_status": False},
    "port_status": {"dynamic_routing": True, "reroute_on_port_status": True},
    "ff": {"dynamic_routing": True, "reroute_on_port_status": False, "fast_failover": True},
    # 1+1 duplication over node-disjoint legs (sdn_app/duplication.py), fast failover for what is single
    "prp": {"dynamic_routing": True, "reroute_on_port_status": False, "fast_failover": True, "duplicate_paths": True},
}


def failure_scenario(name: str, topo: dict, turbines: list[str], sdn: dict, failures: int) -> dict:
    timeline = [{"t": 0.5 + 0.1 * i, "do": "visc_on", "wt": wt} for i, wt in enumerate(turbines)]
    t = 1.5
    for i in range(failures):
        wt = turbines[i % len(turbines)]
        hop = (i // len(turbines)) % 3
        timeline.append({"t": round(t, 3), "do": "path_link_down", "wt": wt, "hop": hop})
        timeline.append({"t": round(t + 0.3, 3), "do": "restore_links"})
        t += 0.6
    return {"name": name, "topology": topo, "duration_s": round(t + 0.3, 3), "plant": {"model": "minimal"},
            "sdc": {"method": "tustin", "backup": False}, "sdn": sdn, "timeline": timeline}


ALL_LINKS_TOPOLOGIES = {
    "paper": {"name": "paper", "clusters": 5, "turbines": 2},
    "farm_compact": {"name": "farm", "clusters": 5, "turbines": 10, "layout": "compact"},
    "farm_tower": {"name": "farm", "clusters": 5, "turbines": 10, "layout": "tower"},
}


def all_links_scenario(name: str, topo: dict) -> dict:
    """One ViSC turbine per cluster; every switch-to-switch link of the topology fails in turn
    (0.3 s down, then up again), with AK/DR."""
    params = {k: v for k, v in topo.items() if k != "name"}
    desc = describe(topos[topo["name"]](**params))
    timeline = [{"t": 0.3 + 0.02 * c, "do": "visc_on", "wt": f"wt{c}_1"} for c in range(1, topo["clusters"] + 1)]
    t = 1.0
    for link in desc["links"]:
        timeline += [{"t": round(t, 3), "do": "link_down", "a": link["a"], "b": link["b"]},
                     {"t": round(t + 0.3, 3), "do": "link_up", "a": link["a"], "b": link["b"]}]
        t += 0.6
    return {"name": name, "topology": topo, "duration_s": round(t + 0.2, 3), "plant": {"model": "minimal"},
            "sdc": {"method": "tustin", "backup": False}, "sdn": MECHANISMS["dr"], "timeline": timeline}


def all_links(work: Path, scale: tuple) -> dict:
    """Every single-link failure of each topology: per link the turbines it interrupted, whether
    each got control back, the longest interruption; the unrecovered count (goal 0)."""
    out = {}
    for topo_name, topo in ALL_LINKS_TOPOLOGIES.items():
        summary = run(all_links_scenario(f"all_links_{topo_name}", topo), work, *scale)
        per_link = {}
        for r in summary["interruptions"]:
            entry = per_link.setdefault("-".join(r["link"]), {"turbines": [], "unrecovered": [], "restored_ms": []})
            entry["turbines"].append(r["wt"])
            if r["recovered"]:
                entry["restored_ms"].append(r["restored_ms"])
            else:
                entry["unrecovered"].append(r["wt"])
        faults = [e for e in summary["events"] if e.get("source") == "timeline" and e["type"] == "link_down"]
        for e in faults:
            per_link.setdefault(f"{e['a']}-{e['b']}", {"turbines": [], "unrecovered": [], "restored_ms": []})
        for entry in per_link.values():
            entry["max_restored_ms"] = max(entry.pop("restored_ms"), default=None)
        out[topo_name] = {"links": len(faults), "unrecovered": sum(len(e["unrecovered"]) for e in per_link.values()),
                          "time_scale": summary["time"]["time_scale"], "per_link": per_link}
    out["unrecovered"] = sum(v["unrecovered"] for v in out.values() if isinstance(v, dict))
    return out


def l2_uplinks(work: Path, scale: tuple, failures: int) -> dict:
    """Fast failover on the L2 switch's uplinks only (`paper`): ``failures`` times the uplink of the
    path's current L2 switch fails for 0.3 s. Per fault the longest interruption and whether a DR
    was needed (the data plane did not repair it before the hold)."""
    topo, turbines = TOPOLOGIES["paper"]
    scenario = failure_scenario("recovery_paper_ff_l2", topo, turbines, MECHANISMS["ff"], failures)
    for event in scenario["timeline"]:
        if event["do"] == "path_link_down":
            event["hop"] = 1  # sdc - s1 - s3|s4 - l2 - wt: the second switch-to-switch link is the uplink
    summary = run(scenario, work, *scale)
    drs = [e["t"] for e in summary["events"] if e.get("source") == "sdn_app" and e["type"] == "dr"]
    faults = []
    for e in (e for e in summary["events"] if e.get("source") == "timeline" and e["type"] == "link_down"):
        worst = max((r["interruption_ms"] for r in summary["interruptions"] if r["t_fault"] == e["t_effective"]),
                    default=None)
        faults.append({"t": e["t_effective"], "link": f"{e['a']}-{e['b']}", "interruption_ms": worst,
                       "dr": any(e["t_effective"] <= t < e["t_effective"] + 0.3 for t in drs)})
    return {"faults": len(faults), "repaired_in_data_plane": sum(not f["dr"] for f in faults),
            "fell_through_to_dr": sum(f["dr"] for f in faults),
            "interruptions": aggregate(summary["interruptions"], summary["step_s"]), "per_fault": faults}


def failover_scenario(name: str) -> dict:
    return {"name": name, "topology": {"name": "paper", "clusters": 1, "turbines": 1}, "duration_s": 2.5,
            "plant": {"model": "minimal"}, "sdc": {"method": "tustin", "backup": True},
            "sdn": {"failover": True},
            "timeline": [{"t": 0.5, "do": "visc_on", "wt": "wt1_1"}, {"t": 1.5, "do": "kill", "host": "sdc1",
                                                                        "process": "sdc"}]}


def dr_breakdown(summary: dict) -> dict[str, list[float]]:
    """Each DR of a run, fault → first control packet cut in three: the fault until the app's
    decision, the decision until every switch of the new path acknowledged its flows (``path_ready``),
    and that until the turbine's first control packet (the new path's first round trip)."""
    ready = sorted((e["t"], e["wt"]) for e in summary["events"] if e["type"] == "path_ready")
    parts: dict[str, list[float]] = {"fault_to_decision": [], "decision_to_flows_acknowledged": [],
                                     "flows_acknowledged_to_control": []}
    for r in summary["recoveries"]:
        if r["cause"] != "dr" or r.get("t_detect") is None or r.get("t_restored") is None:
            continue
        t_ready = next((t for t, wt in ready if wt == r["wt"] and t >= r["t_detect"] - 1e-6), None)
        if t_ready is None or t_ready > r["t_restored"]:
            continue
        parts["fault_to_decision"].append((r["t_detect"] - r["t_fault"]) * 1e3)
        parts["decision_to_flows_acknowledged"].append((t_ready - r["t_detect"]) * 1e3)
        parts["flows_acknowledged_to_control"].append((r["t_restored"] - t_ready) * 1e3)
    return parts


def percentiles(values: list[float]) -> dict:
    if not values:
        return {"n": 0}
    a = np.asarray(values)
    return {"n": int(a.size), "p50": float(np.percentile(a, 50)), "p95": float(np.percentile(a, 95)),
            "max": float(a.max()), "min": float(a.min())}


def path_one_way_ms(summary: dict) -> float | None:
    """The largest one-way p99 (ms) of the control packets of the run's turbines: the paths' delay."""
    vals = [(t["one_way_delay_ms"].get("ctrl_to_turbine") or {}).get("p99") for t in summary["turbines"].values()]
    return max((v for v in vals if v is not None), default=None)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--failures", type=int, default=16,
                        help="link failures per (topology, mechanism) run (0: failover runs only)")
    parser.add_argument("--mechanisms", default=",".join(MECHANISMS),
                        help=f"comma-separated subset of {','.join(MECHANISMS)} for the link-failure runs")
    parser.add_argument("--failover-runs", type=int, default=20, help="SDC kills (one per run)")
    parser.add_argument("--controller-failover-runs", type=int, default=5, help="kills of the master SDN app")
    parser.add_argument("--floor-repeat", type=int, default=20, help="repetitions of the Open vSwitch floor")
    parser.add_argument("--time-scale", default="1", help="K or auto: run the scenarios in virtual time")
    parser.add_argument("--switch-ports", choices=SWITCH_PORT_TYPES, default="system",
                        help="the switch side of every link in the runs and in the floor (scenarios/switch_ports.py)")
    parser.add_argument("--switch-links", choices=SWITCH_LINK_KINDS, default="veth",
                        help="switch-to-switch links in the runs and the topology floor (scenarios/switch_links.py)")
    parser.add_argument("--cpu-split", choices=("on", "off"), default="off",
                        help="on: Open vSwitch on a CPU of its own in the runs (host_tools/cpu_split.py)")
    parser.add_argument("--out", help="keep the runs' results here (default: a temporary directory)")
    parser.add_argument("--all-links", action="store_true",
                        help="only the sweep: every single-link failure of paper, farm compact and farm tower, "
                             "one ViSC turbine per cluster, AK/DR; prints the unrecovered count and per-link times")
    parser.add_argument("--l2-uplinks", type=int, default=0, metavar="N",
                        help="only this: N fast-failover repairs of the L2 switch's uplinks on paper, per fault "
                             "whether the data plane repaired it or DR had to")
    parser.add_argument("--soak-runs", type=int, default=0,
                        help="also this many fault-free runs per case of benchmarks/liveness_soak.py (false positives)")
    parser.add_argument("--soak-duration", type=float, default=60.0)
    args = parser.parse_args(argv)
    chosen = [m for m in args.mechanisms.split(",") if m]
    unknown = sorted(set(chosen) - set(MECHANISMS))
    if not chosen or unknown:
        parser.error(f"--mechanisms: unknown {unknown}; a comma-separated subset of {','.join(MECHANISMS)}")
    mechanisms = {m: MECHANISMS[m] for m in chosen}
    if os.geteuid() != 0:
        print("benchmarks/recovery.py needs root (Mininet)", file=sys.stderr)
        return 2
    work = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="sdvisc-recovery-"))
    work.mkdir(parents=True, exist_ok=True)
    scale = ("--time-scale", args.time_scale, "--switch-ports", args.switch_ports, "--switch-links", args.switch_links,
             "--cpu-split", args.cpu_split)
    started = time.time()
    if args.all_links:
        load_before = os.getloadavg()
        result = {"benchmark": "recovery --all-links", "time_scale": args.time_scale,
                  "switch_ports": args.switch_ports, **all_links(work, scale),
                  "machine": {"platform": platform.platform(), "cpus": os.cpu_count(), "load_before": load_before,
                              "load_after": os.getloadavg()}, "wall_s": round(time.time() - started, 1)}
        print(json.dumps(result, indent=1))
        return 0
    if args.l2_uplinks:
        load_before = os.getloadavg()
        result = {"benchmark": "recovery --l2-uplinks", "time_scale": args.time_scale,
                  "switch_ports": args.switch_ports, **l2_uplinks(work, scale, args.l2_uplinks),
                  "machine": {"platform": platform.platform(), "cpus": os.cpu_count(), "load_before": load_before,
                              "load_after": os.getloadavg()}, "wall_s": round(time.time() - started, 1)}
        print(json.dumps(result, indent=1))
        return 0
    load_before = os.getloadavg()
    floor = ovs_latency.measure(args.floor_repeat, port_type=args.switch_ports) if args.floor_repeat else None
    # the same Open vSwitch on each run's own topology (its bridges and ports, no other traffic): fast
    # failover there, and the pause any link event causes on a stream it does not cross (system ports)
    topology_floor = ({t: ovs_latency.measure_topology(topo["name"], args.floor_repeat,
                                                       {k: v for k, v in topo.items() if k != "name"}, args.switch_links)
                       for t, (topo, _) in TOPOLOGIES.items()}
                      if args.floor_repeat and args.failures > 0 and args.switch_ports == "system" else {})
    result: dict = {"benchmark": "recovery", "failures_per_run": args.failures, "time_scale": args.time_scale,
                    "switch_ports": args.switch_ports, "switch_links": args.switch_links, "cpu_split": args.cpu_split,
                    "units": "ms (simulated ms at a time scale above 1; the floor is wall ms)", "floor": floor,
                    "topology_floor": topology_floor,
                    "runs": {}}
    records: dict[str, list[dict]] = {m: [] for m in mechanisms}
    restore_records: dict[str, list[dict]] = {m: [] for m in mechanisms}  # what each link's return did
    by_topology: dict[str, dict] = {}
    recovery_ms: dict[str, list[float]] = {m: [] for m in mechanisms}
    detect: dict[str, list[float]] = {"dr": [], "sdc_failover": []}
    dr_parts: dict[str, list[float]] = {"fault_to_decision": [], "decision_to_flows_acknowledged": [],
                                        "flows_acknowledged_to_control": []}
    step_s = 0.67e-3
    for topo_name, (topo, turbines) in (TOPOLOGIES.items() if args.failures > 0 else ()):
        for mech, sdn in mechanisms.items():
            name = f"recovery_{topo_name}_{mech}"
            summary = run(failure_scenario(name, topo, turbines, sdn, args.failures), work, *scale)
            step_s = summary["step_s"]
            recs, inter = summary["recoveries"], summary["interruptions"]
            records[mech] += inter
            restore_records[mech] += summary.get("restore_interruptions", [])
            recovery_ms[mech] += [r["recovery_ms"] for r in recs if r["recovery_ms"] is not None]
            detect["dr"] += [r["detect_ms"] for r in recs if r["cause"] == "dr" and r["detect_ms"] is not None]
            if mech == "dr":
                for part, values in dr_breakdown(summary).items():
                    dr_parts[part] += values
            by_topology.setdefault(topo_name, {})[mech] = {**aggregate(inter, step_s),
                                                           "path_one_way_p99_ms": path_one_way_ms(summary),
                                                           "time_scale": summary["time"]["time_scale"]}
            result["runs"][name] = {"interruptions": aggregate(inter, step_s),
                                    "causes": sorted({r["cause"] for r in recs}), "late_steps": summary["late_steps"],
                                    "time_scale": summary["time"]["time_scale"]}
    failover, failover_records = [], []
    for i in range(args.failover_runs):
        summary = run(failover_scenario(f"failover_{i}"), work, *scale)
        failover += [r["recovery_ms"] for r in summary["recoveries"] if r["recovery_ms"] is not None]
        failover_records += summary["interruptions"]
        detect["sdc_failover"] += [r["detect_ms"] for r in summary["recoveries"]
                                   if r["cause"] == "sdc_failover" and r["detect_ms"] is not None]
    controller_records = []
    for i in range(args.controller_failover_runs):
        summary = run_file(ROOT / "scenarios" / "controller_failover.yaml", work / f"controller_failover_{i}", *scale)
        controller_records += summary["interruptions"]
    for mech in mechanisms:
        result[mech] = {"interruption_ms": aggregate(records[mech], step_s), "recovery_ms": percentiles(recovery_ms[mech]),
                        "link_return_interruption_ms": aggregate(restore_records[mech], step_s)}
    for mech in mechanisms:
        result[f"{mech}_p95_ms"] = result[mech]["interruption_ms"].get("p95")
    result["by_topology"] = by_topology
    if floor and by_topology:
        ovs_ff = floor["ff_port_down_ms"].get("p95")
        ovs_mod = floor["flow_mod_ms"].get("p95")
        # the floor is wall time; at a time scale k the network looked k times faster: floor / k
        for mech in ("ff", "prp"):  # prp: the same ratios for 1+1 duplication
            result[f"{mech}_over_floor"] = {t: round(m[mech]["p95"] / (ovs_ff / m[mech]["time_scale"]), 2)
                                            if ovs_ff and m.get(mech, {}).get("p95") else None
                                            for t, m in by_topology.items() if mech in m}
            # against fast failover on the run's own topology
            result[f"{mech}_over_topology_floor"] = {
                t: round(m[mech]["p95"] / (topology_floor[t]["ff_port_down_ms"]["p95"] / m[mech]["time_scale"]), 2)
                for t, m in by_topology.items()
                if mech in m and m[mech].get("p95") and topology_floor.get(t, {}).get("ff_port_down_ms", {}).get("p95")}
        result["dr_excess_ms"] = {t: round(m["dr"]["p95"] - (DR_HOLD_MS + ovs_mod / m["dr"]["time_scale"]
                                                             + (m["dr"]["path_one_way_p99_ms"] or 0)), 2)
                                  if ovs_mod is not None and m["dr"].get("p95") is not None else None
                                  for t, m in by_topology.items() if "dr" in m}
    if by_topology:
        # the same faults against what the network itself needed in the same run (the first datagram
        # through after the losses, by its send time: scenarios/interruptions.py): the endpoints' share
        result["ff_over_run_repair"] = {t: round(m["ff"]["p95"] / m["ff"]["path_restored_ms"]["p95"], 2)
                                        if m["ff"].get("p95") and m["ff"].get("path_restored_ms") else None
                                        for t, m in by_topology.items() if "ff" in m}
    result["failover_runs"] = args.failover_runs
    result["failover_ms"] = percentiles(failover)
    result["failover_p95_ms"] = result["failover_ms"].get("p95")
    result["failover_interruption_ms"] = aggregate(failover_records, step_s)
    result["controller_failover_runs"] = args.controller_failover_runs
    result["controller_failover_interruption_ms"] = aggregate(controller_records, step_s)
    result["detect_ms"] = {k: percentiles(v) for k, v in detect.items()}  # fault → the app's decision
    result["dr_breakdown_ms"] = {k: percentiles(v) for k, v in dr_parts.items()}
    if args.soak_runs:
        soak = {}
        for case in ("paper", "farm4"):
            runs = [liveness_soak.count(run(dict(liveness_soak.case(case, args.soak_duration),
                                                 name=f"soak_{case}_{i}"), work, *scale)) for i in range(args.soak_runs)]
            soak[case] = {k: sum(r[k] for r in runs) for k in liveness_soak.FALSE_EVENTS}
        result["false_positives"] = {"runs_per_case": args.soak_runs, "duration_s": args.soak_duration, **soak}
    result["goals"] = GOALS
    result["machine"] = {"platform": platform.platform(), "cpus": os.cpu_count(), "python": platform.python_version(),
                         "load_before": load_before, "load_after": os.getloadavg()}
    result["wall_s"] = round(time.time() - started, 1)
    result["results_dir"] = str(work)
    print(json.dumps(result, indent=1))
    return 0

if __name__ == "__main__":
    sys.exit(main())
