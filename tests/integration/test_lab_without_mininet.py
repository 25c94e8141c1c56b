"""A lab without Mininet (issue 29, items 2-4): every service started from its own configuration file
with the ``sdvisc`` subcommands a lab's machines would run (docs/real-devices.md) — the SDN app on the
"controller PC" (root namespace), the SDC and the OWFCC on their "PCs" (network namespaces), the
project's GTNET-SKT card emulator on the "RTDS" (one IP, two turbines on two UDP ports, VILLASnode's
framing; the external-peer scenario covers the card's native one) — and three Open vSwitch bridges
made with ovs-vsctl as hardware switches would be (own datapath ids, OpenFlow 1.3, fail-mode secure,
no Mininet object), described to the SDN app by the deployment file alone. The OWFCC's schedule asks
for both turbines; a cable (the x1-x2 veth) is pulled; DR reroutes both over x3. Virtual time k = 4
for every service (one clock epoch)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from host_tools.cleanup import veth_names
from sdvisc.config import CONTROLLER_VIP, CONTROLLER_VMAC
from sdvisc.netns import set_link_up
from tests.integration.helpers import ROOT, assert_no_leftovers

pytestmark = pytest.mark.network

K = 4.0
STEP_S = 0.00067
CARD = ("10.0.9.1", "02:00:00:00:09:01")
SDC1 = ("10.0.0.21", "02:00:00:00:00:15")
OWFCC = ("10.0.0.10", "02:00:00:00:00:0a")
NS = {"sdc1": "sdvisc-lab-sdc1", "owfcc": "sdvisc-lab-owfcc", "card": "sdvisc-lab-card"}
BRIDGES = {"x1": 0xA1, "x2": 0xA2, "x3": 0xA3}
# (bridge, port) <-> (bridge, port): the cables between the "hardware" switches
CABLES = [(("x1", 3), ("x2", 3)), (("x1", 4), ("x3", 4)), (("x2", 5), ("x3", 5))]
HOSTS = {"sdc1": ("x1", 1), "owfcc": ("x1", 2), "card": ("x2", 1)}  # machine -> its switch port


def sh(*args: str) -> None:
    subprocess.run(args, check=True, capture_output=True, timeout=60)


def deployment(ofp_port: int, state_dir: Path, epoch: float) -> dict:
    """The SDN app's deployment file: switches, links and hosts as a lab would write them."""
    def host(machine: str, ip_mac, role: str, **extra) -> dict:
        switch, port = HOSTS[machine]
        return {"ip": ip_mac[0], "mac": ip_mac[1], "role": role, "switch": switch, "port": port, **extra}
    return {
        "time_scale": K, "clock_epoch": epoch, "header": True, "backup_sdc": None, "turbine_fallback_s": 0.1,
        "intake": "packet_in", "failover": False, "mirror_to_backup": False, "state_dir": str(state_dir),
        "topology": {
            "switches": {name: {"dpid": dpid} for name, dpid in BRIDGES.items()},
            "links": [{"a": a, "a_port": pa, "b": b, "b_port": pb} for (a, pa), (b, pb) in CABLES],
            "hosts": {"sdc1": host("sdc1", SDC1, "service"), "owfcc": host("owfcc", OWFCC, "service"),
                      "wt1_1": host("card", CARD, "turbine", cluster=1, number=1, udp_port=50101),
                      "wt1_2": host("card", CARD, "turbine", cluster=1, number=2, udp_port=50102)},
        },
    }


class Lab:
    """The stand-in machines and switches (made and removed by the test; the clean-up knows them by name)."""

    def __init__(self, out: Path) -> None:
        self.out = out
        self.procs: dict[str, subprocess.Popen] = {}
        self.veths: dict = {}
        self.index = 20

    def _veth(self) -> tuple[str, str]:
        self.index += 1
        return veth_names(self.index)

    def build(self, ofp_port: int) -> None:
        ports: dict[str, list[tuple[int, str]]] = {b: [] for b in BRIDGES}
        for (a, pa), (b, pb) in CABLES:
            ea, eb = self._veth()
            sh("ip", "link", "add", ea, "type", "veth", "peer", "name", eb)
            ports[a].append((pa, ea))
            ports[b].append((pb, eb))
            self.veths[frozenset((a, b))] = (ea, eb)
        addresses = {"sdc1": SDC1, "owfcc": OWFCC, "card": CARD}
        for machine, (switch, port) in HOSTS.items():
            ns, (ip, mac) = NS[machine], addresses[machine]
            on_switch, in_host = self._veth()
            sh("ip", "netns", "add", ns)
            sh("ip", "link", "add", on_switch, "type", "veth", "peer", "name", in_host)
            sh("ip", "link", "set", in_host, "netns", ns)
            sh("ip", "-n", ns, "link", "set", in_host, "address", mac)
            sh("ip", "-n", ns, "addr", "add", f"{ip}/16", "dev", in_host)
            sh("ip", "-n", ns, "link", "set", in_host, "up")
            sh("ip", "-n", ns, "link", "set", "lo", "up")
            sh("ip", "netns", "exec", ns, "ethtool", "-K", in_host, "tx", "off")  # the userspace datapath needs it
            for other_ip, other_mac in [*(v for k, v in addresses.items() if k != machine), (CONTROLLER_VIP, CONTROLLER_VMAC)]:
                sh("ip", "-n", ns, "neigh", "replace", other_ip, "lladdr", other_mac, "dev", in_host, "nud", "permanent")
            ports[switch].append((port, on_switch))
        for ends in self.veths.values():
            for end in ends:
                sh("ip", "link", "set", end, "up")
        for _, ports_of in ports.items():
            for _, intf in ports_of:
                sh("ip", "link", "set", intf, "up")
        for name, dpid in BRIDGES.items():
            args = ["ovs-vsctl", "--", "--if-exists", "del-br", name, "--", "add-br", name, "--", "set", "bridge", name,
                    "datapath_type=netdev", f"other-config:datapath-id={dpid:016x}", "protocols=OpenFlow13",
                    "fail_mode=secure", "external-ids:sdvisc=1", "--", "--id=@c", "create", "controller",
                    f'target="tcp:127.0.0.1:{ofp_port}"', "max_backoff=1000", "--", "set", "bridge", name,
                    "controller=@c"]
            for port, intf in ports[name]:
                args += ["--", "add-port", name, intf, "--", "set", "interface", intf, f"ofport_request={port}"]
            sh(*args)

    def start(self, name: str, args: list[str], ns: str | None = None) -> None:
        cmd = [sys.executable, "-m", "scenarios.cli", *args]
        if ns:
            cmd = ["ip", "netns", "exec", ns, *cmd]
        self.procs[name] = subprocess.Popen(cmd, cwd=ROOT, start_new_session=True, stdout=subprocess.DEVNULL,
                                            stderr=open(self.out / f"{name}.stderr", "w"))  # noqa: SIM115

    def wait_for(self, what: str, check, timeout_s: float = 60.0):
        deadline = time.time() + timeout_s
        while time.time() < deadline:
            for name, proc in self.procs.items():
                assert proc.poll() is None, f"{name} exited ({proc.returncode}) while waiting for {what}: " \
                                            f"{(self.out / f'{name}.stderr').read_text()}"
            try:
                found = check()
            except (OSError, ValueError, KeyError):
                found = None
            if found:
                return found
            time.sleep(0.05)
        raise AssertionError(f"no {what} within {timeout_s:.0f} s")

    def stop(self) -> dict[str, int]:
        for proc in self.procs.values():
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        codes = {}
        for name, proc in self.procs.items():
            try:
                codes[name] = proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                proc.kill()
                codes[name] = proc.wait()
        return codes

    def remove(self) -> None:
        self.stop()
        for name in BRIDGES:
            subprocess.run(["ovs-vsctl", "--if-exists", "del-br", name], capture_output=True, timeout=60)
        for ns in NS.values():
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=60)
        for ends in self.veths.values():
            subprocess.run(["ip", "link", "del", ends[0]], capture_output=True, timeout=60)


def write_yaml(path: Path, data: dict) -> str:
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return str(path)


def free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_the_services_from_their_files_control_switches_mininet_never_saw(tmp_path):
    epoch = time.time()
    ofp = free_port()
    clock = {"time_scale": K, "clock_epoch": epoch}
    app = write_yaml(tmp_path / "sdn-app.yaml", deployment(ofp, tmp_path / "app", epoch))
    sdc = write_yaml(tmp_path / "sdc1.yaml", {**clock, "step_s": STEP_S, "out_dir": str(tmp_path / "sdc1"),
                                               "sdc_id": 1, "header": True, "realtime_priority": False, "capacity": 4})
    card = write_yaml(tmp_path / "card.yaml", {
        **clock, "step_s": STEP_S, "out_dir": str(tmp_path / "card"), "bind_ip": CARD[0], "framing": "villas",
        "turbines": [{"name": "wt1_1", "wid": 101, "port": 50101}, {"name": "wt1_2", "wid": 102, "port": 50102}],
        "remote_loss_fallback_s": 0.1})
    owfcc = write_yaml(tmp_path / "owfcc.yaml", {
        **clock, "out_dir": str(tmp_path / "owfcc"), "header": True, "stdin_commands": False,
        "schedule": [{"t_s": 0.2, "cmd": "visc_on", "wt": "wt1_1", "params": {"h": 3.0}},
                     {"t_s": 0.3, "cmd": "visc_on", "wt": "wt1_2", "params": {"h": 3.0}}]})
    lab = Lab(tmp_path)
    try:
        lab.build(ofp)
        lab.start("sdn-app", ["sdn-app", "--config", app, "--ofp-port", str(ofp), "--listen-host", "127.0.0.1"])
        state = tmp_path / "app" / "sdn_state.json"
        lab.wait_for("switch connections", lambda: set(BRIDGES.values())
                     <= set(json.loads(state.read_text())["tables"]["connected"]))
        lab.start("sdc1", ["sdc", "--config", sdc], NS["sdc1"])
        lab.wait_for("SDC ready", lambda: (tmp_path / "sdc1" / "sdc1_ready.json").exists())
        lab.start("card", ["gtnet-card", "--config", card], NS["card"])
        lab.wait_for("card ready", lambda: (tmp_path / "card" / "gtnet_card_ready.json").exists())
        lab.start("owfcc", ["owfcc", "--config", owfcc], NS["owfcc"])

        def paths():
            tables = json.loads(state.read_text())["tables"]
            return tables if all(tables["T3"].get(w) == "1/1" for w in ("wt1_1", "wt1_2")) else None
        before = lab.wait_for("both turbines' paths acknowledged", paths)
        assert all("x2" in before["paths"][w]["path"] and "x3" not in before["paths"][w]["path"]
                   for w in ("wt1_1", "wt1_2"))
        time.sleep(0.5 * K)  # half a simulated second of ViSC control
        t_pull = (time.time() - epoch) / K + epoch  # the services' clock: epoch + (wall - epoch) / k
        for end in lab.veths[frozenset(("x1", "x2"))]:  # the cable x1-x2 pulled: both switches see it
            set_link_up(end, False)

        def rerouted():
            tables = json.loads(state.read_text())["tables"]
            return all("x3" in tables["paths"][w]["path"] and tables["T3"].get(w) == "1/1" for w in ("wt1_1", "wt1_2"))
        lab.wait_for("DR over x3", rerouted)
        time.sleep(0.5 * K)
        codes = lab.stop()
    finally:
        lab.remove()
    assert codes == {"sdn-app": 0, "sdc1": 0, "card": 0, "owfcc": 0}, codes
    events = [json.loads(line) for line in (tmp_path / "app" / "sdn_events.jsonl").read_text().splitlines()]
    for wt in ("wt1_1", "wt1_2"):
        (dr,) = [e for e in events if e["type"] == "dr" and e["wt"] == wt]
        assert "x3" not in dr["old_path"] and "x3" in dr["new_path"] and dr["t_detect"] - dr["t_loss"] >= 0.039
    cards = json.loads((tmp_path / "card" / "gtnet_card_stats.json").read_text())
    assert cards["totals"]["rejected_total"] == 0 and cards["totals"]["commands_rx"] == 2
    for wt in ("wt1_1", "wt1_2"):
        t = cards["turbines"][wt]
        assert t["mode"] == "remote" and t["fallbacks"] == 0
        assert t["meas_tx"] > 1.0 / STEP_S and t["ctrl_rx"] > 0.9 * t["meas_tx"] - 0.1 / STEP_S
        assert t["last_ctrl_wall"] > t_pull + 0.4  # control came back after the pull
    sdc_stats = json.loads((tmp_path / "sdc1" / "sdc1_stats.json").read_text())
    assert sorted(sdc_stats["turbines"]) == ["wt1_1", "wt1_2"]
    owfcc_stats = json.loads((tmp_path / "owfcc" / "owfcc_stats.json").read_text())
    assert owfcc_stats["replies_rx"] == 2
    for log in ("sdc1/sdc1.log", "card/gtnet-card.log", "owfcc/owfcc.log", "app/sdn-app.log"):
        assert (tmp_path / log).exists(), f"no log {log}"
    assert_no_leftovers()
    assert not any(os.path.exists(f"/var/run/netns/{ns}") for ns in NS.values())
