"""What Open vSwitch itself needs on this machine to move a packet stream, without the testbed.

Usage (root):  .venv/bin/python benchmarks/ovs_latency.py [--repeat 20] [--load 0]   (~1 min)
               .venv/bin/python benchmarks/ovs_latency.py --topology paper|farm [--layout tower] [--repeat 20]

One bridge of the testbed's switch class (the userspace datapath where the kernel has no Open
vSwitch module), host h1 sending a 1500 packet/s UDP stream (the testbed's rate at Ts = 0.67 ms)
that the bridge forwards to h2; a raw socket on h3 timestamps the first frame that reaches h3.
Two measurements, ``--repeat`` times each:

* ``flow_mod_ms``: the stream's flow is changed to output to h3 (``ovs-ofctl mod-flows``, which
  returns after the barrier, i.e. when the switch has the new flow); time from that return to the
  first frame at h3. This is the data-plane part of every reroute (DR, port status, failover).
* ``ff_port_down_ms``: the stream goes through an OpenFlow fast-failover group (bucket 1 watches
  and uses h2's port, bucket 2 h3's); h2's link is set down (one ioctl, the instant is known);
  time to the first frame at h3. This is the whole of a fast-failover repair.

``--load K`` adds K more 1500 packet/s streams through the same bridge (between extra hosts), the
kind of load a farm with K ViSC turbines puts on the switch process.

``--topology NAME`` (paper or farm) measures instead, on the testbed's own topology, what *any* link
event costs a stream that does not cross it (``port_event_stall_ms``) and the fast-failover bucket
switch when a switch-to-switch link of the stream's switch goes down (``ff_port_down_ms``; the
bridge set and its port count as in a run, no other traffic). For the stall: the testbed's topology is built (its bridges and ports, no
controller), a 1500 packet/s stream runs between two hosts on one switch, and a switch-to-switch
link elsewhere is taken down and brought up ``--repeat`` times; per event, the stream's longest
pause in the 0.3 s after it, less one period; ``baseline_pause_ms`` the same over quiet windows.
Every link event in the system makes this Open vSwitch reconfigure all its bridges on its main
thread (coverage counter ``bridge_reconfigure``), the thread that also forwards every ``system``
port: no protection of the failed path can avoid that pause.
Prints one JSON object (p50/p95/max per measurement, the machine, the datapath).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402
from mininet.link import Link, OVSLink  # noqa: E402
from mininet.net import Mininet  # noqa: E402

from host_tools import cleanup  # noqa: E402
from scenarios import switch_ports  # noqa: E402
from scenarios.switch_links import set_patch_link  # noqa: E402
from scenarios.switch_ports import SWITCH_PORT_TYPES  # noqa: E402
from sdvisc.netns import set_link_up  # noqa: E402
from topologies import topos  # noqa: E402
from topologies.base import TestbedSwitch, default_datapath  # noqa: E402
from topologies.options import options_of  # noqa: E402

SENDER = """
import socket, sys, time
dst, rate = sys.argv[1], float(sys.argv[2])
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
period, t = 1.0 / rate, time.perf_counter()
while True:
    s.sendto(b"x" * 60, (dst, 9999))
    t += period
    d = t - time.perf_counter()
    if d > 0:
        time.sleep(d)
"""

EVERY_ARRIVAL = """
import socket, sys, time
s = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(0x0800))
s.bind((sys.argv[1], 0))
while True:
    frame = s.recv(2048)
    if len(frame) >= 38 and frame[23] == 17 and frame[36:38] == (9999).to_bytes(2, "big"):
        print(repr(time.time()), flush=True)
"""

RECEIVER = """
import socket, sys, time
s = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(0x0800))
s.bind((sys.argv[1], 0))
last = 0.0
while True:
    frame = s.recv(2048)
    now = time.time()
    if len(frame) >= 38 and frame[23] == 17 and frame[36:38] == (9999).to_bytes(2, "big"):
        if now - last > 0.05:
            print(repr(now), flush=True)
        last = now
"""


def ofctl(*args: str) -> None:
    res = subprocess.run(["ovs-ofctl", "-O", "OpenFlow13", *args], capture_output=True, text=True)
    if res.returncode:
        raise RuntimeError(f"ovs-ofctl {' '.join(args)}: {res.stderr.strip()}")


def first_arrival(receiver, timeout_s: float = 2.0) -> float | None:
    import select  # noqa: PLC0415

    ready, _, _ = select.select([receiver.stdout], [], [], timeout_s)
    return float(receiver.stdout.readline()) if ready else None


def stats(values: list[float]) -> dict:
    v = np.array([x for x in values if x is not None])
    return {"n": len(values), "lost": len(values) - len(v),
            **({"p50": round(float(np.percentile(v, 50)), 3), "p95": round(float(np.percentile(v, 95)), 3),
                "max": round(float(v.max()), 3), "min": round(float(v.min()), 3)} if len(v) else {})}


PORT_TYPES = SWITCH_PORT_TYPES


def measure(repeat: int = 20, load: int = 0, port_type: str = "system") -> dict:
    """Open vSwitch's own flow-mod and fast-failover times on this machine (see the module docstring)."""
    if port_type not in PORT_TYPES:
        raise ValueError(f"port type must be one of {PORT_TYPES}")
    cleanup.clean()
    net = Mininet(switch=TestbedSwitch, controller=None, autoSetMacs=True, build=False)
    s1 = net.addSwitch("s1")
    hosts = [net.addHost(f"h{k}") for k in range(1, 4 + 2 * load)]
    for h in hosts:
        net.addLink(h, s1)
    procs = []
    try:
        net.build()
        s1.start([])
        for h in hosts:
            h.cmd(f"ethtool -K {h.defaultIntf().name} tx off")
        port = {h.name: s1.ports[s1.connectionsTo(h)[0][0]] for h in hosts}
        ports_used = switch_ports.use(switch_ports.port_names([s1]), port_type)
        if ports_used.get("refused"):
            raise RuntimeError(f"Open vSwitch did not open the ports as {port_type}: {ports_used['refused']}")
        cpu_before = ovs_cpu_s()
        ofctl("add-flow", "s1", "priority=1,arp,actions=FLOOD")
        for k in range(load):  # background streams h(4+2k) -> h(5+2k)
            a, b = hosts[3 + 2 * k], hosts[4 + 2 * k]
            ofctl("add-flow", "s1", f"priority=10,in_port={port[a.name]},udp,actions=output:{port[b.name]}")
            procs.append(a.popen([sys.executable, "-c", SENDER, b.IP(), "1500"]))
        h1, h2, h3 = hosts[:3]
        receiver = h3.popen([sys.executable, "-u", "-c", RECEIVER, h3.defaultIntf().name], text=True)
        procs.append(receiver)
        procs.append(h1.popen([sys.executable, "-c", SENDER, h2.IP(), "1500"]))
        time.sleep(0.5)
        flow = f"in_port={port['h1']},udp"
        flow_mod, ff = [], []
        for _ in range(repeat):
            ofctl("add-flow", "s1", f"priority=20,{flow},actions=output:{port['h2']}")
            time.sleep(0.3)
            ofctl("mod-flows", "s1", f"{flow},actions=output:{port['h3']}")
            t_done = time.time()
            t = first_arrival(receiver)
            flow_mod.append((t - t_done) * 1e3 if t else None)
        ofctl("del-flows", "s1", flow)
        ofctl("add-group", "s1", f"group_id=1,type=ff,bucket=watch_port:{port['h2']},output:{port['h2']},"
                                 f"bucket=watch_port:{port['h3']},output:{port['h3']}")
        ofctl("add-flow", "s1", f"priority=20,{flow},actions=group:1")
        sw_end = s1.connectionsTo(h2)[0][0].name
        for _ in range(repeat):
            set_link_up(sw_end, True)
            time.sleep(0.5)
            first_arrival(receiver, 0.05)  # drain
            t_down = set_link_up(sw_end, False)
            t = first_arrival(receiver)
            ff.append((t - t_down) * 1e3 if t else None)
        result = {"benchmark": "ovs_latency", "machine": platform.platform(), "cpus": len(__import__("os").sched_getaffinity(0)),
                  "datapath": default_datapath(), "ovs": subprocess.run(["ovs-vswitchd", "--version"], capture_output=True,
                                                                         text=True).stdout.splitlines()[0],
                  "port_type": port_type, "stream_pps": 1500, "extra_streams": load, "repeat": repeat,
                  "flow_mod_ms": stats(flow_mod), "ff_port_down_ms": stats(ff),
                  "ovs_vswitchd_cpu_s": round(ovs_cpu_s() - cpu_before, 3),
                  "ovs_vswitchd_cpu_note": "CPU of ovs-vswitchd over the whole measurement (both parts)"}
        return result
    finally:
        for p in procs:
            p.kill()
        net.stop()
        cleanup.clean()


class PatchLinks:
    """Switch-to-switch links as Open vSwitch patch ports (``--links patch``): a link fails and returns
    as in a run (:func:`scenarios.switch_links.set_patch_link`, one ovs-vsctl transaction that returns
    once ovs-vswitchd has applied it). ``set`` returns the wall time before the command and records how
    long the command took (``took``)."""

    def __init__(self) -> None:
        self.took: list[float] = []

    def set(self, a, b, up: bool) -> float:
        t = time.time()
        set_patch_link([a, b], up)
        self.took.append((time.time() - t) * 1e3)
        return t


def measure_topology(topology: str, repeat: int = 20, params: dict | None = None, links: str = "veth") -> dict:
    """``port_event_stall_ms`` and ``ff_port_down_ms`` on the testbed's ``topology`` (module docstring);
    ``links="patch"``: switch-to-switch links as patch ports (:class:`PatchLinks`)."""
    params = options_of(topos[topology]).model_validate(params or {}).model_dump()  # its defaults: paper 5 x 2, farm 5 x 10
    cleanup.clean()
    net = Mininet(topo=topos[topology](**params), switch=TestbedSwitch, controller=None, build=False,
                  link=OVSLink if links == "patch" else Link)
    patch = PatchLinks() if links == "patch" else None

    def set_link(a, b, up: bool) -> float:
        if patch is not None:
            return patch.set(a, b, up)
        t = set_link_up(a.name, up)
        set_link_up(b.name, up)
        return t
    procs, arrivals = [], []
    try:
        net.build()
        net.start()  # no controller: the stream's flow is added below
        for h in net.hosts:
            h.cmd(f"ethtool -K {h.defaultIntf().name} tx off")
        src, dst = net.get("owfcc"), net.get("sdc1")  # on one OpenFlow switch in both topologies
        link = src.defaultIntf().link
        switch = (link.intf2 if link.intf1.node is src else link.intf1).node
        port = {h.name: switch.ports[switch.connectionsTo(h)[0][0]] for h in (src, dst)}
        ofctl("add-flow", switch.name, "priority=1,arp,actions=FLOOD")
        ofctl("add-flow", switch.name, f"priority=10,in_port={port[src.name]},udp,actions=output:{port[dst.name]}")
        receiver = dst.popen([sys.executable, "-u", "-c", EVERY_ARRIVAL, dst.defaultIntf().name], text=True)
        procs += [receiver, src.popen([sys.executable, "-c", SENDER, dst.IP(), "1500"])]

        def read():
            for line in receiver.stdout:
                arrivals.append(float(line))
        threading.Thread(target=read, daemon=True).start()
        others = [(a, b) for a, b in ((lk.intf1, lk.intf2) for lk in net.links)
                  if a.node in net.switches and b.node in net.switches and switch not in (a.node, b.node)]
        a_end, b_end = others[0]
        time.sleep(1.0)
        events, quiet = [], []
        for _ in range(repeat):
            quiet.append(time.time())
            time.sleep(0.3)
            for up in (False, True):
                events.append(set_link(a_end, b_end, up))
                time.sleep(0.3)
        time.sleep(0.2)
        period_ms = 1e3 / 1500
        stamps = np.array(arrivals)

        def pause(t0: float) -> float | None:
            window = stamps[(stamps >= t0 - 0.002) & (stamps <= t0 + 0.3)]
            return float(np.diff(window).max() * 1e3 - period_ms) if len(window) > 2 else None
        stall, baseline = stats([pause(t) for t in events]), stats([pause(t) for t in quiet])
        # fast failover on this topology: the stream goes through a group whose first bucket watches and
        # uses a switch-to-switch link of its switch (into the neighbour, which drops it: no flow there),
        # the second sdc1's port; that link goes down: time to the first packet at sdc1
        own_end, far_end = next((a, b) if a.node is switch else (b, a) for a, b in
                                ((lk.intf1, lk.intf2) for lk in net.links)
                                if switch in (a.node, b.node) and {a.node, b.node} <= set(net.switches))
        uplink = switch.ports[own_end]
        ofctl("add-group", switch.name, f"group_id=1,type=ff,bucket=watch_port:{uplink},output:{uplink},"
                                        f"bucket=watch_port:{port[dst.name]},output:{port[dst.name]}")
        ofctl("add-flow", switch.name, f"priority=20,in_port={port[src.name]},udp,actions=group:1")
        ff = []
        for _ in range(repeat):
            time.sleep(0.3)
            t_down = set_link(own_end, far_end, False)
            time.sleep(0.3)
            after = [t for t in list(arrivals[-1000:]) if t > t_down]
            ff.append((after[0] - t_down) * 1e3 if after else None)
            set_link(own_end, far_end, True)
        return {"benchmark": "ovs_latency --topology", "topology": topology, "params": params,
                "bridges": len(net.switches), "ports": sum(len(s.intfList()) - 1 for s in net.switches),
                "link_toggled": [a_end.name, b_end.name], "stream_switch": switch.name, "repeat": repeat,
                "port_event_stall_ms": stall, "baseline_pause_ms": baseline,
                "ff_link": [own_end.name, far_end.name], "ff_port_down_ms": stats(ff), "links": links,
                **({"link_command_ms": stats(patch.took)} if patch else {})}
    finally:
        for p in procs:
            p.kill()
        net.stop()
        cleanup.clean()


def ovs_cpu_s() -> float:
    """CPU seconds ovs-vswitchd has used (user + system, /proc)."""
    pid = subprocess.run(["pidof", "ovs-vswitchd"], capture_output=True, text=True).stdout.split()[0]
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=20)
    ap.add_argument("--load", type=int, default=0, help="extra 1500 packet/s streams through the bridge")
    ap.add_argument("--port-type", choices=PORT_TYPES, default="system",
                    help="the switch side of the veths: system (Mininet's default) or AF_XDP")
    ap.add_argument("--topology", choices=tuple(topos),
                    help="instead: the port-event stall and fast failover on this testbed topology")
    ap.add_argument("--layout", choices=("compact", "tower"), default="compact", help="farm's layout (--topology farm)")
    ap.add_argument("--links", choices=("veth", "patch"), default="veth",
                    help="--topology: switch-to-switch links as veths (Mininet's default) or patch ports")
    args = ap.parse_args()
    if args.topology:
        params = {"clusters": 5, "turbines": 10, "layout": args.layout} if args.topology == "farm" else None
        print(json.dumps(measure_topology(args.topology, args.repeat, params, args.links), indent=1))
        return
    print(json.dumps(measure(args.repeat, args.load, args.port_type), indent=1))


if __name__ == "__main__":
    main()
