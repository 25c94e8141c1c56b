"""Remove everything a testbed run can leave behind (``sdvisc clean``; also run on every exit path).

Targets: the processes a run started — found by the run's marker in their environment
(:data:`RUN_MARKER`, in /proc/PID/environ), never by words in their command line: a user's
``tcpdump -r results/x/sdvisc-capture-sdc1.pcap`` or an editor on that file is no run's — Open vSwitch bridges a run created (marked ``external-ids:sdvisc=1``, or named like
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
from collections.abc import Callable

from host_tools import cpu_split, ovs_revalidation, servers
from sdvisc.netns import command_line

SWITCH_NAME = r"(?:s\d+|l2|sub\d+|c\d+|t\d+x\d+)"
BRIDGE_RE = re.compile(rf"^{SWITCH_NAME}$")
PEER_NETNS = "sdvisc-peer"
"""The namespace of an emulated external GTNET-SKT peer (scenarios/external.py)."""
LINK_RE = re.compile(rf"^(?:(?:{SWITCH_NAME}|imp\d+)(?:-eth\d+)?|sdvx\d+[md])$")  # imp<n>: impairment elements
# (topologies.base); sdvx<n>m/d: the veths to external devices (veth_names)


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
"""In the environment of every process a run starts: the services (scenarios.processes) and, through
:func:`mark_children`, everything else the run's process starts while it runs (Mininet's host shells,
which ``mnexec`` starts with the parent's environment; the calibration's pilot SDC; tcpdump). The
clean-up stops a process only with it, so it never stops an SDC, SDN app, OWFCC or card emulator that
systemd or a user started on the same machine, nor a user's process that merely names a run's file."""


def mark_children() -> Callable[[], None]:
    """Put :data:`RUN_MARKER` in this process's environment, which every child inherits; returns
    the function that takes it out again (a process that runs several things, e.g. a benchmark,
    does not mark what it starts after the run)."""
    key, value = RUN_MARKER.split("=")
    before = os.environ.get(key)
    os.environ[key] = value

    def unmark() -> None:
        if before is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = before
    return unmark


def _started_by_a_run(pid: str) -> bool:
    try:
        with open(f"/proc/{pid}/environ", "rb") as fh:
            return RUN_MARKER.encode() in fh.read().split(b"\0")
    except OSError:
        return False


def _ancestors() -> set[int]:
    """This process and every process above it (a run's service may call the clean-up)."""
    out, pid = set(), os.getpid()
    while pid > 1 and pid not in out:
        out.add(pid)
        try:
            with open(f"/proc/{pid}/status") as fh:
                pid = int(next(line for line in fh if line.startswith("PPid:")).split()[1])
        except (OSError, StopIteration, ValueError):
            break
    return out


def project_processes() -> list[tuple[int, str]]:
    """(pid, cmdline) of the processes a run started (:data:`RUN_MARKER` in their environment),
    except this process and its ancestors, and the stand-in servers another live process uses."""
    own = _ancestors() | servers.protected_pids()
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit() and int(entry) not in own and _started_by_a_run(entry):
            found.append((int(entry), command_line(entry) or ""))
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
