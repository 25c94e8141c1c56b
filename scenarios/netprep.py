"""Preparing a built Mininet network for a run, with one command per host and one for all the
switches: TX checksum offload off on every host interface (the userspace datapath needs it), a
permanent ARP entry on every addressed host for every other addressed host (what Mininet's
``staticArp`` does with one ``arp -s`` shell round trip per pair: 2,652 on the 52-host farm) and
for the controller's virtual IP, and the bridges marked as the testbed's (``sdvisc`` external id,
for the clean-up), their controller connections retrying every second at most."""

from __future__ import annotations

import json
import subprocess
import tempfile
from pathlib import Path


def neighbour_lines(host_name: str, dev: str, peers: list[tuple[str, str, str]], extra: list[tuple[str, str]]) -> list[str]:
    """``ip -batch`` lines for ``host_name``: a permanent entry on ``dev`` for every peer (name, IP,
    MAC) other than itself and for each (IP, MAC) of ``extra``."""
    entries = [(ip, mac) for name, ip, mac in peers if name != host_name] + list(extra)
    return [f"neigh replace {ip} lladdr {mac} dev {dev} nud permanent" for ip, mac in entries]


def prepare_hosts(hosts, controller_vip: str, controller_vmac: str) -> None:
    """Offload off on every interface of every host; static ARP among the addressed hosts (those
    with an IP: not the impairment elements) and to the controller's virtual IP."""
    addressed = [h for h in hosts if h.IP()]
    peers = [(h.name, h.IP(), h.MAC()) for h in addressed]
    with tempfile.TemporaryDirectory(prefix="sdvisc-arp-") as tmp:
        for host in hosts:
            commands = [f"ethtool -K {intf.name} tx off > /dev/null" for intf in host.intfList() if intf.name != "lo"]
            if host.IP():
                lines = neighbour_lines(host.name, host.defaultIntf().name, peers, [(controller_vip, controller_vmac)])
                if getattr(host, "isRemote", False):  # another server: no file of this machine's there
                    commands += remote_batches(lines)
                else:
                    batch = Path(tmp) / f"{host.name}.batch"
                    batch.write_text("\n".join(lines) + "\n")
                    commands.append(f"ip -force -batch {batch}")
            for chunk in _groups(commands, 2, SHELL_LINE_MAX):
                host.cmd("; ".join(chunk))


SHELL_LINE_MAX = 3000
"""Characters per command line sent to a node's shell: a Mininet shell reads from a terminal in
canonical mode, whose lines end at 4095 characters."""


def remote_batches(lines: list[str]) -> list[str]:
    """``ip -batch`` on a server without a file: ``printf`` piped into ``ip -force -batch -``, as many
    commands as keep each under :data:`SHELL_LINE_MAX`."""
    quoted = [f"'{line}'" for line in lines]
    return [f"printf '%s\\n' {' '.join(group)} | ip -force -batch -" for group in _groups(quoted, 1, SHELL_LINE_MAX - 40)]


def _groups(items: list[str], sep: int, limit: int) -> list[list[str]]:
    """``items`` in order, grouped so that each group joined by ``sep`` characters stays within ``limit``
    (an item longer than that goes alone)."""
    groups: list[list[str]] = []
    size = 0
    for item in items:
        if groups and size + sep + len(item) <= limit:
            groups[-1].append(item)
            size += sep + len(item)
        else:
            groups.append([item])
            size = len(item)
    return groups


CONTROLLER_MAX_BACKOFF_MS = 1000  # Open vSwitch's default, 8 s, made every auto-time-scale run wait ~5 s for
# its switches after the calibration (they had backed off while no SDN app listened)


def _uuids(ref: list) -> list[str]:
    """The UUIDs of an OVSDB reference column (one as ["uuid", U], several as ["set", [...]])."""
    return [uuid for _kind, uuid in (ref[1] if ref[0] == "set" else [ref])]


def controller_uuids(listing: dict, bridges: set[str]) -> list[str]:
    """The Controller records of ``bridges`` in ``ovs-vsctl --format=json --columns=name,controller
    list bridge`` output."""
    return [uuid for name, ref in listing["data"] if name in bridges for uuid in _uuids(ref)]


def local_vsctl(args: list[str]) -> str:
    """``ovs-vsctl ARGS`` on this machine (stdout); raises on failure."""
    return subprocess.run(["ovs-vsctl", *args], check=True, capture_output=True, text=True, timeout=60).stdout


def mark_switches(switches, vsctl=local_vsctl) -> None:
    """Every bridge of the run gets the external id ``sdvisc=1``, and its controller connections a
    1 s reconnection back-off (one ovs-vsctl transaction; ``vsctl``: where the bridges are)."""
    names = {sw.name for sw in switches}
    if not names:
        return
    listing = vsctl(["--format=json", "--columns=name,controller", "list", "bridge"])
    args = []
    for name in sorted(names):
        args += ["--", "br-set-external-id", name, "sdvisc", "1"]
    for uuid in controller_uuids(json.loads(listing), names):
        args += ["--", "set", "controller", uuid, f"max_backoff={CONTROLLER_MAX_BACKOFF_MS}"]
    vsctl(args)


def _bridge_controllers(vsctl) -> dict[str, list[str]]:
    """Each bridge that has controllers -> their targets (in the Controller table's order)."""
    def listing(*args: str) -> dict:
        return json.loads(vsctl(["--format=json", *args]))
    bridges = listing("--columns=name,controller", "list", "bridge")
    controllers = listing("--columns=_uuid,target", "list", "controller")
    target = {row[0][1]: row[1] for row in controllers["data"]}
    out = {}
    for name, ref in bridges["data"]:
        if uuids := _uuids(ref):
            out[name] = [target[u] for u in uuids if u in target]
    return out


def reconnect_controllers(switches, vsctl=local_vsctl) -> None:
    """Make the run's switches connect to their controllers now: after ``time_scale: auto``'s
    calibration (no SDN app listened meanwhile) Open vSwitch had backed off to 8 s between attempts
    whatever max_backoff said (measured: switches connected 5–10 s after the app listened). The
    controllers are removed and created again (two transactions: one would keep the old
    connections), with the same targets and back-off."""
    names = {sw.name for sw in switches}
    current = {b: t for b, t in _bridge_controllers(vsctl).items() if b in names}
    if not current:
        return
    remove = []
    create = []
    for i, (bridge, targets) in enumerate(sorted(current.items())):
        remove += ["--", "del-controller", bridge]
        ids = []
        for j, tgt in enumerate(targets):
            ids.append(f"@c{i}_{j}")
            create += ["--", f"--id=@c{i}_{j}", "create", "controller", f'target="{tgt}"',
                       f"max_backoff={CONTROLLER_MAX_BACKOFF_MS}"]
        create += ["--", "set", "bridge", bridge, f"controller=[{','.join(ids)}]"]
    vsctl(remove)
    vsctl(create)

