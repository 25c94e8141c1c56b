"""The SDN app's own cost per AK or heartbeat taken from its intake socket: ``Controller.delivered``
on batches as a wake-up of the 50-ViSC farm brings them (50 AKs and a heartbeat), no switch, no
socket, no thread — the logic's part of the app's CPU per report.

Prints one JSON object: µs per datagram, the median of ``--repeats`` timings of ``--bursts`` batches
each (50 ViSC paths acknowledged first). No root needed.

    python benchmarks/sdn_intake_cost.py [--bursts 200] [--repeats 5]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from scenario_runs import machine  # noqa: E402  (benchmarks/scenario_runs.py)

from sdn_app import flows as fl  # noqa: E402
from sdn_app.logic import Controller  # noqa: E402
from sdvisc import wire  # noqa: E402
from sdvisc.config import CONTROLLER_VIP, CONTROLLER_VMAC, AppConfig  # noqa: E402
from sdvisc.vocabulary import BLANK_REQUEST_PARAMS  # noqa: E402
from topologies import topos  # noqa: E402
from topologies.base import describe  # noqa: E402


def farm_controller() -> Controller:
    topo = topos["farm"](clusters=5, turbines=10, layout="compact")
    topo.add_intake(CONTROLLER_VIP, CONTROLLER_VMAC)
    return Controller(AppConfig.model_validate({"topology": describe(topo), "backup_sdc": None,
                                                "intake_socket": {"netns_pid": None}}), 0.0)


def request(wt: str, req_id: int) -> bytes:
    values = {"req_id": req_id, "cmd": int(wire.Command.VISC_ON), "wt": wire.turbine_id(*wire.parse_turbine(wt)),
              "sdc_ip": 0, **BLANK_REQUEST_PARAMS}
    return wire.encode(wire.MsgType.REQUEST, values, header=wire.Header(req_id, 0, 0))


def ak(wt: str, seq: int) -> bytes:
    return wire.encode(wire.MsgType.AK, {"wt": wire.turbine_id(*wire.parse_turbine(wt)), "seq": seq, "ak": 1,
                                         "ctrl_rx": seq, "ctrl_age_ms": 0.5}, header=wire.Header(seq, 0, 0))


def heartbeat(seq: int) -> bytes:
    return wire.encode(wire.MsgType.HEARTBEAT, {"sdc_id": 1, "seq": seq, "n_instances": 50, "t_wall": 0.0},
                       header=wire.Header(seq, 0, 0))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bursts", type=int, default=200)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    ctl = farm_controller()
    hosts = ctl.config.topology.hosts
    wts = [n for n, h in hosts.items() if h.role == "turbine"]
    for i, wt in enumerate(wts):
        for action in ctl.delivered([(hosts["owfcc"].ip, request(wt, i + 1))], 0.1):
            if isinstance(action, fl.Barrier):
                ctl.barrier_reply(action.dpid, action.tag, 0.1)
    per_datagram, seq, now = [], 0, 1.0
    for _ in range(args.repeats):
        bursts = []
        for _ in range(args.bursts):
            seq += 1
            bursts.append([(hosts[wt].ip, ak(wt, seq)) for wt in wts] + [(hosts["sdc1"].ip, heartbeat(seq))])
        t0 = time.perf_counter()
        for burst in bursts:
            now += 0.01
            ctl.delivered(burst, now)
        per_datagram.append((time.perf_counter() - t0) / sum(map(len, bursts)) * 1e6)
    result = {"benchmark": "sdn_intake_cost", "visc_paths": len(ctl.paths), "batch": len(wts) + 1,
              "us_per_datagram": round(statistics.median(per_datagram), 2),
              "runs_us": [round(x, 2) for x in per_datagram], "ak_rx": ctl.counters["ak_rx"],
              "heartbeats": ctl.counters["heartbeats"], "machine": machine()}
    print(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
