"""Real devices in a run (issue 29; keys in :mod:`scenarios.external_spec`): the external GTNET-SKT
peer that replaces the plant, and the topology's OpenFlow switches that Mininet does not build.

What the run does with them, in order:

1. :meth:`ExternalDevices.detach` (before Mininet builds): takes the external switches and the peer's
   turbine hosts out of the Mininet topology, and gives the SDN app's description of the whole network:
   the same switches, datapath ids, ports and links as before (the app cannot tell a hardware switch
   from an emulated one), the peer's turbines as hosts that share the card's IP, MAC and switch port,
   each with its own UDP port.
2. :meth:`make` (emulation only): a veth pair per link to a device; each external switch as a plain
   Open vSwitch bridge made with ovs-vsctl (its own datapath id, OpenFlow 1.3, fail-mode secure, the
   run's SDN app as controller, the topology's port numbers), the peer's end in a namespace of its own
   (:data:`host_tools.cleanup.PEER_NETNS`) with the card's addresses.
3. :meth:`attach` (after Mininet builds, before it starts): the Mininet side of each such link is an
   ``Intf`` on its switch at the topology's port (on a lab machine: the NIC cabled to the device).
4. :meth:`prepare_hosts`: the card's address in every Mininet host's neighbour table (the testbed's
   hosts resolve no address dynamically) and the hosts' and the controller's in the card's.
5. :meth:`peer_config`: the card emulator's configuration (the runner starts it as the run's
   ``plant`` process, in the peer's namespace).

:meth:`link_ends` names the root-namespace interfaces of a link to a device (``link_down s4 s1``
takes both down, so both switches see the port go down); :meth:`remove` undoes 2 (the clean-up
also finds everything by name).
"""

from __future__ import annotations

import json
import subprocess
from dataclasses import dataclass, field

from host_tools.cleanup import PEER_NETNS, veth_names
from scenarios import peer_tap
from scenarios.netprep import CONTROLLER_MAX_BACKOFF_MS
from scenarios.schema import Scenario
from sdvisc import wire
from sdvisc.config import CONTROLLER_VIP, CONTROLLER_VMAC
from topologies.base import NET_PREFIX_LEN, default_datapath

START_MARGIN_S = 0.5  # a real peer: t = 0 this long (run clock) after the services are ready


def _sh(*args: str) -> str:
    done = subprocess.run(args, capture_output=True, text=True, timeout=60)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(args)}: {done.stderr.strip() or done.stdout.strip()}")
    return done.stdout


@dataclass
class _Bridge:
    name: str
    dpid: int
    ports: dict[int, str] = field(default_factory=dict)  # OpenFlow port -> interface (the device side)


@dataclass
class ExternalDevices:
    """The run's external devices (see the module docstring); inactive without any."""

    scenario: Scenario
    bridges: dict[str, _Bridge] = field(default_factory=dict)
    attachments: list[tuple[str, int, str]] = field(default_factory=list)  # (Mininet switch, port, interface)
    links: dict[frozenset, list[str]] = field(default_factory=dict)  # {a, b} -> root-namespace interfaces
    veths: list[tuple[str, str]] = field(default_factory=list)  # emulation: (Mininet side, device side)
    peer_port: int | None = None  # the peer's port on its switch
    peer_intf: str | None = None  # the peer's interface in its namespace (emulation)
    made: bool = False

    @property
    def peer(self):
        return self.scenario.plant.peer

    @property
    def active(self) -> bool:
        return bool(self.scenario.topology.external_switches) or self.peer is not None

    def _next_veth(self) -> tuple[str, str]:
        pair = veth_names(len(self.veths) + 1)
        self.veths.append(pair)
        return pair

    # ------------------------------------------------------------------ 1. the topology
    def detach(self, topo, desc: dict) -> dict:
        """Take the devices out of ``topo`` (in place); returns the SDN app's description (``desc``:
        :func:`topologies.base.describe` of the whole topology, not changed)."""
        desc = {k: (dict(v) if isinstance(v, dict) else list(v)) for k, v in desc.items()}
        external = self.scenario.topology.external_switches
        for name in external:
            self.bridges[name] = _Bridge(name, desc["switches"][name]["dpid"])
        for lk in desc["links"]:
            a, b = lk["a"], lk["b"]
            if a not in external and b not in external:
                continue
            inner = [(n, lk[f"{s}_port"]) for n, s in ((a, "a"), (b, "b")) if n not in external]
            if len(inner) == 2 or not inner:  # two external switches: a veth between their bridges
                m_end, d_end = self._next_veth()
                self.bridges[a].ports[lk["a_port"]] = m_end
                self.bridges[b].ports[lk["b_port"]] = d_end
                self.links[frozenset((a, b))] = [m_end, d_end]
                continue
            (mn_switch, mn_port), = inner
            ext, ext_port = (b, lk["b_port"]) if a == mn_switch else (a, lk["a_port"])
            nic = external[ext].interfaces.get(mn_switch)
            if external[ext].emulate:
                m_end, d_end = self._next_veth()
                self.bridges[ext].ports[ext_port] = d_end
                self.links[frozenset((a, b))] = [m_end, d_end]
            else:
                m_end = nic
                self.links[frozenset((a, b))] = [m_end]
            self.attachments.append((mn_switch, mn_port, m_end))
        for name in external:
            desc.get("intake_ports", {}).pop(name, None)  # the app's packet-ins serve a hardware switch
            _remove_node(topo, name)
        if self.peer is not None:
            for turbine in self.peer.turbines:
                desc["hosts"].pop(turbine, None)
                if turbine in topo.g.node:
                    _remove_node(topo, turbine)
            self.peer_port = max([0, *topo.ports.get(self.peer.switch, {})]) + 1
            if self.peer.emulate:
                m_end, self.peer_intf = self._next_veth()
            else:
                m_end = self.peer.interface
            self.attachments.append((self.peer.switch, self.peer_port, m_end))
            for turbine, udp_port in self.peer.turbines.items():
                cluster, number = wire.parse_turbine(turbine)
                desc["hosts"][turbine] = {"ip": self.peer.ip, "mac": self.peer.mac, "role": "turbine",
                                          "switch": self.peer.switch, "port": self.peer_port,
                                          "cluster": cluster, "number": number, "udp_port": udp_port}
        if "intake_ports" in desc and not desc["intake_ports"]:
            desc.pop("intake_ports")
        return desc

    # ------------------------------------------------------------------ 2. the emulated devices
    def make(self, ofp_port: int) -> None:
        """Create the emulated devices (root namespace; before Mininet starts its switches)."""
        self.made = True
        for m_end, d_end in self.veths:
            _sh("ip", "link", "add", m_end, "type", "veth", "peer", "name", d_end)
            for end in (m_end, d_end):
                _sh("ip", "link", "set", end, "up")
        datapath = "netdev" if default_datapath() == "user" else "system"
        for br in self.bridges.values():
            if not self.scenario.topology.external_switches[br.name].emulate:
                continue
            args = ["ovs-vsctl", "--", "--if-exists", "del-br", br.name, "--", "add-br", br.name,
                    "--", "set", "bridge", br.name, f"datapath_type={datapath}",
                    f"other-config:datapath-id={br.dpid:016x}", "protocols=OpenFlow13", "fail_mode=secure",
                    "external-ids:sdvisc=1",
                    "--", "--id=@c", "create", "controller", f'target="tcp:127.0.0.1:{ofp_port}"',
                    f"max_backoff={CONTROLLER_MAX_BACKOFF_MS}", "--", "set", "bridge", br.name, "controller=@c"]
            for port, intf in sorted(br.ports.items()):
                args += ["--", "add-port", br.name, intf, "--", "set", "interface", intf, f"ofport_request={port}"]
            _sh(*args)
        if self.peer is not None and self.peer.emulate:
            ns, intf = PEER_NETNS, self.peer_intf
            _sh("ip", "netns", "add", ns)
            _sh("ip", "link", "set", intf, "netns", ns)
            _sh("ip", "-n", ns, "link", "set", intf, "address", self.peer.mac)
            _sh("ip", "-n", ns, "addr", "add", f"{self.peer.ip}/{NET_PREFIX_LEN}", "dev", intf)
            _sh("ip", "-n", ns, "link", "set", intf, "up")
            _sh("ip", "-n", ns, "link", "set", "lo", "up")
            _sh("ip", "netns", "exec", ns, "ethtool", "-K", intf, "tx", "off")  # the userspace datapath needs it

    def bridge_names(self) -> list[str]:
        """The emulated external switches (their controller connection is renewed with the run's)."""
        external = self.scenario.topology.external_switches
        return [name for name in self.bridges if external[name].emulate]

    # ------------------------------------------------------------------ 3. 4. Mininet's side
    def attach(self, net) -> None:
        """Each link to a device: an ``Intf`` on its Mininet switch at the topology's port."""
        from mininet.link import Intf

        for switch, port, intf in self.attachments:
            Intf(intf, node=net.get(switch), port=port)

    def prepare_hosts(self, net, desc: dict) -> None:
        """Neighbour entries both ways between the Mininet hosts and the peer (static, as the run's
        hosts have for each other)."""
        if self.peer is None:
            return
        for host in net.hosts:
            if host.IP() and host.name not in self.peer.turbines:
                host.cmd(f"ip neigh replace {self.peer.ip} lladdr {self.peer.mac} dev {host.defaultIntf().name} "
                         f"nud permanent")
        if not self.peer.emulate:
            return
        entries = {(h["ip"], h["mac"]) for n, h in desc["hosts"].items() if h["ip"] != self.peer.ip}
        entries.add((CONTROLLER_VIP, CONTROLLER_VMAC))
        for ip, mac in sorted(entries):
            _sh("ip", "-n", PEER_NETNS, "neigh", "replace", ip, "lladdr", mac, "dev", self.peer_intf, "nud", "permanent")

    # ------------------------------------------------------------------ 5. the emulated card
    def peer_config(self, sdc_ip: str, out_dir: str, clock: dict, duration_s: float | None) -> dict:
        """The card emulator's configuration (:mod:`plant.card`), as the lab would set up a card."""
        sc = self.scenario
        return {**clock, "out_dir": out_dir, "step_s": sc.step_s, "bind_ip": self.peer.ip,
                "framing": self.peer.framing, "controller_vip": CONTROLLER_VIP, "stream": self.peer.stream,
                "sdc": {"ip": sdc_ip, "port": wire.PORT_SDC}, "duration_s": duration_s,
                "ak_period_s": sc.plant.ak_period_s, "ak_window_s": sc.plant.ak_window_s,
                "remote_loss_fallback_s": sc.plant.remote_loss_fallback_s,
                "misbehave": [m.model_dump() for m in self.peer.misbehave],
                "turbines": [{"name": n, "wid": wire.turbine_id(*wire.parse_turbine(n)), "port": p}
                             for n, p in self.peer.turbines.items()]}

    def start_peer(self, run, sdc_ip: str) -> float:
        """Start the emulated card as the run's ``plant`` process (in the peer's namespace); returns t = 0
        (the run clock's reading when the card is ready). A real peer is already sending: t = 0 is now,
        and the run captures its traffic on the interface cabled to it (:mod:`scenarios.peer_tap`)."""
        if not self.peer.emulate:
            peer_tap.start(run, self.peer.interface, self.peer.ip)
            return run.clock.now() + START_MARGIN_S
        duration = None if run.session is not None else self.scenario.duration_s
        path = run.out / "peer_config.json"
        path.write_text(json.dumps(self.peer_config(sdc_ip, str(run.out), run.clock_settings, duration), indent=1))
        run.processes.start("plant", ["ip", "netns", "exec", PEER_NETNS, run.python, "-m", "plant.card.emulator",
                                      "--config", str(path)])
        ready = run.processes.wait_ready("plant", "gtnet_card_ready.json", "the GTNET-SKT card emulator")
        return float(ready.get("t0_wall") or run.clock.now())

    def describe(self) -> dict | None:
        """What the run had outside Mininet (summary.json ``external``): each external switch's datapath
        id, whether it was emulated, and its ports (interface names), the peer's addresses, switch port,
        turbines (UDP ports) and framing."""
        if not self.active:
            return None
        external = self.scenario.topology.external_switches
        out: dict = {"switches": {b.name: {"dpid": b.dpid, "emulated": external[b.name].emulate,
                                           "ports": {str(p): i for p, i in sorted(b.ports.items())}}
                                  for b in self.bridges.values()}}
        if self.peer is not None:
            out["peer"] = {"ip": self.peer.ip, "mac": self.peer.mac, "switch": self.peer.switch, "port": self.peer_port,
                           "framing": self.peer.framing, "turbines": dict(self.peer.turbines),
                           "emulated": self.peer.emulate, "interface": self.peer.interface or self.peer_intf}
        return out

    # ------------------------------------------------------------------ while it runs, and after
    def link_ends(self, a: str, b: str) -> list[str] | None:
        """The root-namespace interfaces of the link a–b if it leads to a device, else None."""
        return self.links.get(frozenset((a, b)))

    def remove(self) -> None:
        """Remove what :meth:`make` created (bridges, veths, the peer's namespace); never raises."""
        if not self.made:
            return
        for name in self.bridge_names():
            subprocess.run(["ovs-vsctl", "--if-exists", "del-br", name], capture_output=True, timeout=60)
        if self.peer is not None and self.peer.emulate:
            subprocess.run(["ip", "netns", "del", PEER_NETNS], capture_output=True, timeout=60)
        for m_end, _ in self.veths:
            subprocess.run(["ip", "link", "del", m_end], capture_output=True, timeout=60)


def _remove_node(topo, name: str) -> None:
    """Take a node and its links out of a Mininet ``Topo`` (which has no such method)."""
    topo.g.node.pop(name, None)
    for other in topo.g.edge.pop(name, {}):
        topo.g.edge.get(other, {}).pop(name, None)
    for _port, (other, other_port) in topo.ports.pop(name, {}).items():
        topo.ports.get(other, {}).pop(other_port, None)
