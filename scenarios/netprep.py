"""Preparing a built Mininet network for a run, with one command per host and one for all the
switches: TX checksum offload off on every host interface (the userspace datapath needs it), a
permanent ARP entry on every addressed host for every other addressed host (what Mininet's
``staticArp`` does with one ``arp -s`` shell round trip per pair: 2,652 on the 52-host farm) and
for the controller's virtual IP, and the bridges marked as the testbed's (``sdvisc`` external id,
for the clean-up)."""

from __future__ import annotations

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


def mark_switches(switches) -> None:
    """Every bridge of the run gets the external id ``sdvisc=1`` (one ovs-vsctl transaction)."""
    args = ["ovs-vsctl"]
    for sw in switches:
        args += ["--", "br-set-external-id", sw.name, "sdvisc", "1"]
    if len(args) > 1:
        subprocess.run(args, check=True, capture_output=True, timeout=60)
