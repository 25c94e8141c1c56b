"""How the switches are joined: veth pairs (Mininet's default) or Open vSwitch patch ports.

Scenario key ``switch_links`` (CLI ``--switch-links``). With ``patch`` every switch-to-switch link is a
pair of patch ports (Mininet's ``OVSLink``): a packet crosses all the bridges of its path in one pass
of the userspace datapath, with no kernel device, socket or main-loop iteration between bridges
(``benchmarks/ovs_hops.py --links patch``: ≈ 0 ms per hop against 0.10–0.14 ms for a veth, and
ovs-vswitchd's CPU no longer grows with the bridges a packet crosses). The hosts' links stay veths
(``switch_ports`` applies to them), and so does every link that has an impairment element.

A patch port cannot be set down: Open vSwitch ignores OFPPC_PORT_DOWN on it and a missing peer
leaves it LIVE. A failed patch link is therefore *removed* — both ports deleted in one ovs-vsctl
transaction, which returns once ovs-vswitchd has applied it — and restored by adding them again
with their OpenFlow port numbers. The switches report the ports deleted and added (OFPPR_DELETE /
OFPPR_ADD), fast-failover buckets watching them go dead and live, as for a veth taken down.
"""

from __future__ import annotations

import subprocess
import time

from mininet.link import OVSIntf

from sdvisc.netns import set_link_up

SWITCH_LINK_KINDS = ("veth", "patch")


def is_patch(intf) -> bool:
    """True for the end of a patch link (Mininet's ``OVSIntf``)."""
    return isinstance(intf, OVSIntf)


def patch_link_command(ends: list, up: bool) -> list[str]:
    """The one ovs-vsctl transaction that removes (``up`` False) or restores the patch link whose two
    ends are ``ends`` (Mininet interfaces of two OVS switches: ``name``, ``node.name``,
    ``node.ports[end]`` its OpenFlow port number, kept when the port returns)."""
    a, b = ends
    cmd = ["ovs-vsctl"]
    for end, peer in ((a, b), (b, a)):
        if len(cmd) > 1:
            cmd.append("--")
        if up:
            cmd += ["--may-exist", "add-port", end.node.name, end.name, "--", "set", "Interface", end.name,
                    "type=patch", f"options:peer={peer.name}", f"ofport_request={end.node.ports[end]}"]
        else:
            cmd += ["--if-exists", "del-port", end.node.name, end.name]
    return cmd


def set_patch_link(ends: list, up: bool) -> None:
    """Run :func:`patch_link_command`; raises OSError if Open vSwitch refuses it."""
    cmd = patch_link_command(ends, up)
    res = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if res.returncode != 0:
        raise OSError(f"{' '.join(cmd)}: {res.stderr.strip()}")


def set_link(ends: list, up: bool, switches) -> float:
    """Set a link's ends up or down; returns the wall time just before the first end was changed
    (taken before the command, not after it returns 1–3 ms later, so a recovery time measured from
    it can only be over-, never under-estimated).

    ``ends``: Mininet interfaces (with an impairment element: its interfaces too), or names of
    root-namespace interfaces (a link to an external device, scenarios/external.py). Patch ports are
    removed and restored (:func:`set_patch_link`); every other end is set with one ioctl in its
    namespace (switch ends: the root namespace) — a veth whose peer is down has no carrier, so the
    first end takes the link down at once."""
    if all(is_patch(intf) for intf in ends):
        t = time.time()
        set_patch_link(ends, up)
        return t
    t_first = None
    for intf in ends:
        if isinstance(intf, str):
            t = set_link_up(intf, up, None)
        else:
            t = set_link_up(intf.name, up, None if intf.node in switches else intf.node.pid)
        t_first = t_first or t
    return t_first
