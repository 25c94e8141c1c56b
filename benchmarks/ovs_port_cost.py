"""What an idle host port costs Open vSwitch's userspace datapath: ovs-vswitchd's CPU per forwarded
packet on one netdev bridge with N host ports, of which two carry a paced UDP stream and the rest
are idle — veth ports (Mininet's, ``system``: an AF_PACKET socket each) against internal ports
moved into the hosts' namespaces (tap devices).

Each packet arrives alone (``--gap-us`` apart), so each costs one iteration of the main thread's
loop, which polls every port: the growth with N is the per-port cost of one iteration. Prints one
JSON object. Needs root; makes bridge ``tcost0`` and namespaces ``tcost<i>`` and removes them.

    python benchmarks/ovs_port_cost.py [--ports 3,50] [--kinds veth,tap] [--packets 5000] [--gap-us 400]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

from scenario_runs import finish  # benchmarks/scenario_runs.py

BRIDGE = "tcost0"


def sh(*cmd: str, check: bool = True) -> str:
    return subprocess.run(cmd, check=check, capture_output=True, text=True).stdout


def netns(i: int) -> str:
    return f"tcost{i}"


def teardown(n: int) -> None:
    sh("ovs-vsctl", "--if-exists", "del-br", BRIDGE, check=False)
    for i in range(1, n + 1):
        sh("ip", "netns", "del", netns(i), check=False)
        sh("ip", "link", "del", f"tcv{i}", check=False)


def build(kind: str, n: int) -> None:
    sh("ovs-vsctl", "add-br", BRIDGE, "--", "set", "bridge", BRIDGE, "datapath_type=netdev", "fail_mode=standalone")
    for i in range(1, n + 1):
        ns, dev = netns(i), f"tcp{i}"
        sh("ip", "netns", "add", ns)
        if kind == "tap":
            sh("ovs-vsctl", "add-port", BRIDGE, dev, "--", "set", "interface", dev, "type=internal")
        else:
            sh("ip", "link", "add", f"tcv{i}", "type", "veth", "peer", "name", dev)
            sh("ip", "link", "set", f"tcv{i}", "up")
            sh("ethtool", "-K", f"tcv{i}", "tx", "off", check=False)
            sh("ovs-vsctl", "add-port", BRIDGE, f"tcv{i}")
        sh("ip", "link", "set", dev, "netns", ns)
        sh("ip", "netns", "exec", ns, "ip", "addr", "add", f"10.98.{i // 250}.{i % 250 + 1}/16", "dev", dev)
        sh("ip", "netns", "exec", ns, "ip", "link", "set", dev, "up")
        sh("ip", "netns", "exec", ns, "ethtool", "-K", dev, "tx", "off", check=False)


RECEIVER = """
import socket
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); s.bind(("0.0.0.0", 9999)); s.settimeout(3); n = 0
try:
    while True:
        s.recv(2048); n += 1
except OSError:
    pass
print(n)
"""

SENDER = """
import socket, sys, time
n, gap = int(sys.argv[1]), float(sys.argv[2])
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); t = time.perf_counter()
for i in range(n):
    s.sendto(b"x" * 100, ("10.98.0.3", 9999))
    while time.perf_counter() < t + (i + 1) * gap:
        pass
"""


def ovs_cpu_s() -> float:
    pid = sh("pidof", "ovs-vswitchd").split()[0]
    fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def measure(kind: str, n: int, packets: int, gap_s: float) -> dict:
    teardown(n)
    try:
        build(kind, n)
        time.sleep(2)  # the ports settle
        receiver = subprocess.Popen(["ip", "netns", "exec", netns(2), sys.executable, "-c", RECEIVER],
                                    stdout=subprocess.PIPE, text=True)
        time.sleep(0.5)
        cpu0 = ovs_cpu_s()
        sh("ip", "netns", "exec", netns(1), sys.executable, "-c", SENDER, str(packets), str(gap_s))
        cpu1 = ovs_cpu_s()
        received = int(receiver.communicate(timeout=30)[0].strip() or 0)
    finally:
        teardown(n)
    return {"kind": kind, "ports": n, "packets": packets, "received": received,
            "ovs_cpu_us_per_packet": round((cpu1 - cpu0) / packets * 1e6, 1)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ports", default="3,50")
    ap.add_argument("--kinds", default="veth,tap")
    ap.add_argument("--packets", type=int, default=5000)
    ap.add_argument("--gap-us", type=float, default=400.0)
    args = ap.parse_args()
    if os.geteuid() != 0:
        raise SystemExit("needs root")
    result = {"benchmark": "ovs_port_cost", "load_before": os.getloadavg(), "cases": []}
    for kind in args.kinds.split(","):
        for n in (int(x) for x in args.ports.split(",")):
            result["cases"].append(measure(kind, n, args.packets, args.gap_us * 1e-6))
    return finish(result)


if __name__ == "__main__":
    sys.exit(main())
