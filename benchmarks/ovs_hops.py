"""What one bridge hop costs in Open vSwitch's userspace datapath on this machine, per port type.

Usage (root):  .venv/bin/python benchmarks/ovs_hops.py [--bridges 1,2,4,8] [--port-type system]
               [--period-ms 10,0.67] [--count 400] [--pmd-maxsleep-us 0]          (~1 min per type)

A chain of N bridges of the testbed's switch class (s1 — s2 — … — sN, veth links, one flow per
direction and port: ``in_port=a,actions=output:b``), host h1 on s1, host h2 on sN. h1 sends a UDP
packet every ``period`` and h2 answers it at once; h1 takes the round trip from the kernel's receive
stamp of the answer (SO_TIMESTAMPNS) minus the send time. The testbed's farm paths cross 3–7
bridges each way, and a sample at time scale k leaves the switches idle for k·Ts between packets
(10 ms: k = 16), so both an idle and a busy period are measured.

The cost **per bridge hop, one way** is the slope of the round trip's median (and p99) against N,
halved (a least-squares line over the N measured): the endpoints' own costs (Python, the two veths
to the hosts) are in the intercept, not in the slope.

``--port-type``: ``system`` (Mininet's default: the switch sides are AF_PACKET sockets polled by
ovs-vswitchd's main thread, one main-loop iteration per hop), ``afxdp-nonpmd`` (AF_XDP sockets, still
the main thread), ``afxdp`` (AF_XDP polled by a PMD thread: busy polling; ``--pmd-maxsleep-us`` lets
it sleep up to that long when idle, Open vSwitch's ``other_config:pmd-maxsleep``). Also printed:
ovs-vswitchd's CPU per wall second during the measurement (a PMD thread spins a core).
``--links patch`` joins the bridges with Open vSwitch patch ports (Mininet's ``OVSLink``) instead of
veths: a packet then crosses every bridge of the chain in one datapath pass, with no kernel device
between bridges (the hosts' links stay veths of ``--port-type``). Prints one JSON object.
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402
from mininet.link import Link, OVSLink  # noqa: E402
from mininet.net import Mininet  # noqa: E402

from benchmarks.ovs_latency import ofctl, ovs_cpu_s  # noqa: E402
from host_tools import cleanup  # noqa: E402
from scenarios import switch_ports  # noqa: E402
from scenarios.switch_ports import SWITCH_PORT_TYPES as PORT_TYPES  # noqa: E402
from topologies.base import TestbedSwitch, default_datapath  # noqa: E402

ECHO = """
import socket
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.bind(("0.0.0.0", 9998))
while True:
    data, addr = s.recvfrom(64)
    s.sendto(data, addr)
"""

PINGER = """
import json, socket, struct, sys, time
dst, period, count = sys.argv[1], float(sys.argv[2]), int(sys.argv[3])
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.setsockopt(socket.SOL_SOCKET, getattr(socket, "SO_TIMESTAMPNS", 35), 1)  # Linux: 35
s.settimeout(0.5)
rtt, lost = [], 0
t = time.perf_counter()
for n in range(count + 20):  # the first 20 warm the path up (ARP is static, flows are installed)
    t += period
    d = t - time.perf_counter()
    if d > 0:
        time.sleep(d)
    sent = time.clock_gettime_ns(time.CLOCK_REALTIME)
    s.sendto(struct.pack("!I", n), (dst, 9998))
    try:
        while True:
            data, anc, _f, _a = s.recvmsg(64, 64)
            if struct.unpack("!I", data[:4])[0] == n:
                break
    except TimeoutError:
        lost += n >= 20
        continue
    sec, nsec = struct.unpack("qq", anc[0][2][:16]) if anc else divmod(time.clock_gettime_ns(time.CLOCK_REALTIME), 10**9)
    if n >= 20:
        rtt.append((sec * 10**9 + nsec - sent) / 1e6)
print(json.dumps({"rtt_ms": rtt, "lost": lost}))
"""


def chain(n_bridges: int, port_type: str, period_s: float, count: int, links: str = "veth") -> dict:
    """Round trips h1 → s1 … sN → h2 → back, ``count`` of them, one every ``period_s``; bridges joined
    by ``links`` (veth or patch)."""
    cleanup.clean()
    net = Mininet(switch=TestbedSwitch, controller=None, autoSetMacs=True, build=False)
    switches = [net.addSwitch(f"s{k}") for k in range(1, n_bridges + 1)]
    h1, h2 = net.addHost("h1"), net.addHost("h2")
    net.addLink(h1, switches[0])
    for a, b in zip(switches, switches[1:]):
        net.addLink(a, b, cls=OVSLink if links == "patch" else Link)
    net.addLink(switches[-1], h2)
    echo = None
    try:
        net.build()
        for sw in switches:
            sw.start([])
        for h in (h1, h2):
            h.cmd(f"ethtool -K {h.defaultIntf().name} tx off")
        h1.setARP(h2.IP(), h2.MAC())
        h2.setARP(h1.IP(), h1.MAC())
        ports_used = switch_ports.use(switch_ports.port_names(switches), port_type)
        if ports_used.get("refused"):
            raise RuntimeError(f"Open vSwitch did not open the ports as {port_type}: {ports_used['refused']}")
        for sw in switches:  # one flow per direction: the port towards h1 <-> the port towards h2
            ports = [sw.ports[i] for i in sw.intfList() if i.name != "lo"]
            west, east = ports[0], ports[-1]
            ofctl("add-flow", sw.name, f"in_port={west},actions=output:{east}")
            ofctl("add-flow", sw.name, f"in_port={east},actions=output:{west}")
        echo = h2.popen([sys.executable, "-c", ECHO])
        time.sleep(0.3)
        cpu0, wall0 = ovs_cpu_s(), time.time()
        with tempfile.NamedTemporaryFile("w", suffix=".py") as script:
            script.write(PINGER)
            script.flush()
            out = h1.cmd(f"{sys.executable} {script.name} {h2.IP()} {period_s} {count}")
        cpu = (ovs_cpu_s() - cpu0) / (time.time() - wall0)
        got = json.loads(out.strip().splitlines()[-1])
        rtt = np.array(got["rtt_ms"])
        return {"bridges": n_bridges, "links": links, "n": len(rtt), "lost": got["lost"],
                "rtt_p50_ms": round(float(np.percentile(rtt, 50)), 4), "rtt_p99_ms": round(float(np.percentile(rtt, 99)), 4),
                "ovs_cpu_per_wall_s": round(cpu, 3)}
    finally:
        if echo is not None:
            echo.kill()
        net.stop()
        cleanup.clean()


def per_hop(rows: list[dict], key: str) -> float | None:
    """Half the least-squares slope of ``key`` against the bridge count: one bridge hop, one way (ms)."""
    if len({r["bridges"] for r in rows}) < 2:
        return None
    slope = np.polyfit([r["bridges"] for r in rows], [r[key] for r in rows], 1)[0]
    return round(float(slope) / 2, 4)


def set_pmd_maxsleep(us: int | None) -> None:
    if us is None:
        subprocess.run(["ovs-vsctl", "remove", "Open_vSwitch", ".", "other_config", "pmd-maxsleep"], capture_output=True)
    else:
        subprocess.run(["ovs-vsctl", "set", "Open_vSwitch", ".", f"other_config:pmd-maxsleep={us}"], check=True,
                       capture_output=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bridges", default="1,2,4,8", help="bridge counts of the chains (comma-separated)")
    ap.add_argument("--port-type", choices=PORT_TYPES, default="system")
    ap.add_argument("--period-ms", default="10,0.67", help="packet periods (comma-separated): idle and busy")
    ap.add_argument("--count", type=int, default=400)
    ap.add_argument("--links", choices=("veth", "patch"), default="veth", help="how the bridges are joined")
    ap.add_argument("--pmd-maxsleep-us", type=int, default=None, help="with afxdp: other_config:pmd-maxsleep")
    args = ap.parse_args()
    if args.pmd_maxsleep_us is not None:
        set_pmd_maxsleep(args.pmd_maxsleep_us)
    try:
        result = {"benchmark": "ovs_hops", "machine": platform.platform(), "datapath": default_datapath(),
                  "ovs": subprocess.run(["ovs-vswitchd", "--version"], capture_output=True, text=True).stdout.splitlines()[0],
                  "port_type": args.port_type, "links": args.links, "pmd_maxsleep_us": args.pmd_maxsleep_us, "count": args.count,
                  "load_before": Path("/proc/loadavg").read_text().split()[:3], "periods": {}}
        for period_ms in (float(p) for p in args.period_ms.split(",")):
            rows = [chain(int(n), args.port_type, period_ms / 1e3, args.count, args.links)
                    for n in args.bridges.split(",")]
            result["periods"][f"{period_ms:g} ms"] = {
                "chains": rows, "per_hop_one_way_p50_ms": per_hop(rows, "rtt_p50_ms"),
                "per_hop_one_way_p99_ms": per_hop(rows, "rtt_p99_ms")}
        result["load_after"] = Path("/proc/loadavg").read_text().split()[:3]
        print(json.dumps(result, indent=1))
    finally:
        if args.pmd_maxsleep_us is not None:
            set_pmd_maxsleep(None)


if __name__ == "__main__":
    main()
