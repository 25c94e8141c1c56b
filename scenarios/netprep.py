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
                batch = Path(tmp) / f"{host.name}.batch"
                batch.write_text("\n".join(neighbour_lines(host.name, host.defaultIntf().name, peers,
                                                           [(controller_vip, controller_vmac)])) + "\n")
                commands.append(f"ip -force -batch {batch}")
            if commands:
                host.cmd("; ".join(commands))


CONTROLLER_MAX_BACKOFF_MS = 1000  # Open vSwitch's default, 8 s, made every auto-time-scale run wait ~5 s for
# its switches after the calibration (they had backed off while no SDN app listened)


def _uuids(ref: list) -> list[str]:
    """The UUIDs of an OVSDB reference column (one as ["uuid", U], several as ["set", [...]])."""
    return [uuid for _kind, uuid in (ref[1] if ref[0] == "set" else [ref])]


def controller_uuids(listing: dict, bridges: set[str]) -> list[str]:
    """The Controller records of ``bridges`` in ``ovs-vsctl --format=json --columns=name,controller
    list bridge`` output."""
    return [uuid for name, ref in listing["data"] if name in bridges for uuid in _uuids(ref)]


def mark_switches(switches) -> None:
    """Every bridge of the run gets the external id ``sdvisc=1``, and its controller connections a
    1 s reconnection back-off (one ovs-vsctl transaction)."""
    names = {sw.name for sw in switches}
    if not names:
        return
    listing = subprocess.run(["ovs-vsctl", "--format=json", "--columns=name,controller", "list", "bridge"],
                             check=True, capture_output=True, text=True, timeout=60).stdout
    args = ["ovs-vsctl"]
    for name in sorted(names):
        args += ["--", "br-set-external-id", name, "sdvisc", "1"]
    for uuid in controller_uuids(json.loads(listing), names):
        args += ["--", "set", "controller", uuid, f"max_backoff={CONTROLLER_MAX_BACKOFF_MS}"]
    subprocess.run(args, check=True, capture_output=True, timeout=60)


def _bridge_controllers() -> dict[str, list[str]]:
    """Each bridge that has controllers -> their targets (in the Controller table's order)."""
    def listing(*args: str) -> dict:
        return json.loads(subprocess.run(["ovs-vsctl", "--format=json", *args], check=True, capture_output=True,
                                         text=True, timeout=60).stdout)
    bridges = listing("--columns=name,controller", "list", "bridge")
    controllers = listing("--columns=_uuid,target", "list", "controller")
    target = {row[0][1]: row[1] for row in controllers["data"]}
    out = {}
    for name, ref in bridges["data"]:
        if uuids := _uuids(ref):
            out[name] = [target[u] for u in uuids if u in target]
    return out


def reconnect_controllers(switches) -> None:
    """Make the run's switches connect to their controllers now: after ``time_scale: auto``'s
    calibration (no SDN app listened meanwhile) Open vSwitch had backed off to 8 s between attempts
    whatever max_backoff said (measured: switches connected 5–10 s after the app listened). The
    controllers are removed and created again (two transactions: one would keep the old
    connections), with the same targets and back-off."""
    names = {sw.name for sw in switches}
    current = {b: t for b, t in _bridge_controllers().items() if b in names}
    if not current:
        return
    remove = ["ovs-vsctl"]
    create = ["ovs-vsctl"]
    for i, (bridge, targets) in enumerate(sorted(current.items())):
        remove += ["--", "del-controller", bridge]
        ids = []
        for j, tgt in enumerate(targets):
            ids.append(f"@c{i}_{j}")
            create += ["--", f"--id=@c{i}_{j}", "create", "controller", f'target="{tgt}"',
                       f"max_backoff={CONTROLLER_MAX_BACKOFF_MS}"]
        create += ["--", "set", "bridge", bridge, f"controller=[{','.join(ids)}]"]
    subprocess.run(remove, check=True, capture_output=True, timeout=60)
    subprocess.run(create, check=True, capture_output=True, timeout=60)

