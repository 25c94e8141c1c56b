"""Remove everything a testbed run can leave behind (``sdvisc clean``; also run on every exit path).

Targets: the project's processes (SDN app, plant, SDC, OWFCC, impairment elements, tcpdump started
by a run, Mininet host shells), Open vSwitch bridges a run created (marked ``external-ids:sdvisc=1``, or named like
the testbed's switches), and veth/tap devices named after them (``s1-eth2``, ``sub1``…), and the stand-in
servers of the cluster tests (host_tools/servers.py: namespaces ``sdvisc-srv*``, their daemons, the LAN
namespace ``sdvisc-lan``, the head's veth ``sdvlan0``, the servers' key directory — unless another live process owns them).
``mn -c`` misses the userspace datapath's leftovers; this does not.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import time

from host_tools import cpu_split, ovs_revalidation, servers
from sdvisc.netns import command_line

SWITCH_NAME = r"(?:s\d+|l2|sub\d+|c\d+|t\d+x\d+)"
BRIDGE_RE = re.compile(rf"^{SWITCH_NAME}$")
PEER_NETNS = "sdvisc-peer"
"""The namespace of an emulated external GTNET-SKT peer (scenarios/external.py)."""
LINK_RE = re.compile(rf"^(?:(?:{SWITCH_NAME}|imp\d+)(?:-eth\d+)?|sdvx\d+[md])$")  # imp<n>: impairment elements
# (topologies.base); sdvx<n>m/d: the veths to external devices (veth_names)
PROCESS_MARKERS = ("-m sdn_app", "-m plant.service", "-m sdc_unit.service", "-m sdc_unit.pilot", "-m owfcc.service",
                   "-m impairment.element", "-m plant.gtnet_card",
                   "sdvisc-capture", "mininet:")


def veth_names(index: int) -> tuple[str, str]:
    """A run's veth pair number ``index`` toward an external device: (the Mininet side, the device
    side), named so that :data:`LINK_RE` finds them."""
    return f"sdvx{index}m", f"sdvx{index}d"


def _run(*args: str) -> str:
    try:
        return subprocess.run(args, capture_output=True, text=True, timeout=20).stdout
    except (OSError, subprocess.TimeoutExpired):
        return ""


RUN_MARKER = "SDVISC_RUN_PROCESS=1"
"""In the environment of every process a run starts (scenarios.processes): the services a lab deploys
(:data:`DEPLOYABLE`) are removed only with it, so a clean-up never stops an SDC, SDN app, OWFCC or card
emulator that systemd or a user started on the same machine."""
DEPLOYABLE = ("-m sdn_app", "-m sdc_unit.service", "-m owfcc.service", "-m plant.gtnet_card")


def _started_by_a_run(pid: str) -> bool:
    try:
        with open(f"/proc/{pid}/environ", "rb") as fh:
            return RUN_MARKER.encode() in fh.read().split(b"\0")
    except OSError:
        return False


def project_processes() -> list[tuple[int, str]]:
    """(pid, cmdline) of processes a run starts, except this process and its ancestors (a deployable
    service only if a run started it: :data:`RUN_MARKER`)."""
    own = {os.getpid(), os.getppid()} | servers.protected_pids()  # (another live process's servers)
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit() or int(entry) in own:
            continue
        cmd = command_line(entry)
        if cmd and any(marker in cmd for marker in PROCESS_MARKERS):
            if any(marker in cmd for marker in DEPLOYABLE) and not _started_by_a_run(entry):
                continue
            found.append((int(entry), cmd))
    return found


def kill_processes(grace_s: float = 1.0) -> list[int]:
    procs = project_processes()
    for pid, _ in procs:
        try:
            os.kill(pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
    deadline = time.time() + grace_s
    while time.time() < deadline and any(os.path.exists(f"/proc/{p}") for p, _ in procs):
        time.sleep(0.05)
    for pid, _ in procs:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    return [p for p, _ in procs]


def testbed_bridges() -> list[str]:
    out = []
    for br in _run("ovs-vsctl", "--timeout=5", "list-br").split():
        marked = "sdvisc" in _run("ovs-vsctl", "--timeout=5", "br-get-external-id", br)
        if marked or BRIDGE_RE.match(br):
            out.append(br)
    return out


def testbed_links() -> list[str]:
    names = []
    for line in _run("ip", "-o", "link", "show").splitlines():
        parts = line.split(":")
        if len(parts) < 2:
            continue
        name = parts[1].strip().split("@")[0]
        if LINK_RE.match(name):
            names.append(name)
    return names


def testbed_netns() -> list[str]:
    """Network namespaces the testbed made by name: an emulated peer's (:data:`PEER_NETNS`), a test's
    stand-in lab machines (``sdvisc-lab-*``)."""
    return [n for n in _run("ip", "netns", "list").split() if n == PEER_NETNS or n.startswith("sdvisc-lab-")]


def leftovers() -> dict:
    """What a run left behind, without removing anything."""
    return {"processes": [p for p, _ in project_processes()], "bridges": testbed_bridges(), "links": testbed_links(),
            "netns": testbed_netns(),
            "cpu_split": ["ovs-vswitchd pinned"] if cpu_split.pinned() else [],
            "switch_revalidation": ["max-revalidator changed"] if ovs_revalidation.changed() else [],
            "servers": servers.leftovers()}


def clean(verbose: bool = False) -> dict:
    """Remove all leftovers; returns what was removed."""
    removed_servers = servers.remove_servers(leftovers_only=True)  # first: daemons and sessions, by namespace
    removed = {"processes": kill_processes(), "bridges": [], "links": [], "netns": [], "servers": removed_servers,
               "cpu_split": ["ovs-vswitchd unpinned"] if cpu_split.restore() else [],
               "switch_revalidation": ["max-revalidator restored"] if ovs_revalidation.restore() else []}
    bridges = testbed_bridges()
    if bridges:
        _run("ovs-vsctl", "--timeout=10", *sum((["--", "--if-exists", "del-br", b] for b in bridges), []))
        removed["bridges"] = bridges
    for ns in testbed_netns():
        _run("ip", "netns", "del", ns)
        removed["netns"].append(ns)
    for link in testbed_links():
        _run("ip", "link", "del", link)
        removed["links"].append(link)
    if verbose:
        for kind, items in removed.items():
            print(f"sdvisc clean: removed {len(items)} {kind}" + (f": {' '.join(map(str, items))}" if items else ""))
    return removed
