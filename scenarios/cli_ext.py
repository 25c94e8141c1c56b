"""The Mininet CLI, extended for the testbed (``sdvisc run --cli``).

Mininet's own commands work as usual (``link s1 s3 down``, ``pingall``, ``dpctl dump-flows``…);
the commands below add the testbed's view. Each ``do_*`` docstring is its ``help`` text.
"""

from __future__ import annotations

import json

from mininet.cli import CLI

from scenarios import impairments
from scenarios.cli_session import SessionCommands


def status_header(st: dict, duration: float | None) -> str:
    """``status``'s first line from the plant's live status (:meth:`RunState.progress_status`)."""
    return (f"t_sim={st.get('t_sim', 0):.2f} s (timeline {f'{duration:g} s' if duration else 'open-ended'})"
            f"  late_steps={st.get('late_steps', 0)}  meas_tx={st.get('meas_tx', 0)}  ctrl_rx={st.get('ctrl_rx', 0)}")


class TestbedCLI(SessionCommands, CLI):
    """Mininet CLI with ``status``, ``tables``, ``paths``, ``visc``, ``link`` and ``summary``; in an
    interactive session also ``kill``, ``events``, ``watch`` and feedback (:mod:`scenarios.cli_session`)."""

    prompt = "sdvisc> "

    def __init__(self, net, run=None, session=None, **kwargs):
        self.testbed = run
        self.session = session
        if session is not None:
            session.cli = self
        super().__init__(net, **kwargs)

    def do_status(self, _line):
        """status: simulated time, late steps, packets, ViSC turbines and down links."""
        st = self.testbed.progress_status()  # (a real card's: time from the run's clock, counts n/a)
        sdn = self.testbed.sdn_state() or {}
        tables = sdn.get("tables", {})
        print(status_header(st, self.testbed.scenario.duration_s))
        print(f"ViSC turbines: {', '.join(st.get('streaming', [])) or '-'}   active SDC: {tables.get('active_sdc')}")
        taken = ", ".join(f"{a}-{b}" for a, b in sorted(self.testbed.links_down)) or "-"  # by this run, now
        seen = ", ".join("-".join(link) for link in tables.get("down_links") or []) or "-"  # published every 0.1 s
        print(f"down links: {taken} (seen by the SDN app: {seen})   openflow: {sdn.get('openflow', {})}")
        for impaired in self.testbed.impairments.status_lines():
            print(f"impaired link {impaired}")
        if not self.testbed.controllers_running():
            print("no SDN application is running: switches keep their flows, nothing reacts to failures")
        restarts = {n: len(r) for n, r in self.testbed.restarts.items() if r}
        if restarts:
            print(f"services restarted after a crash: {restarts}")

    def do_tables(self, line):
        """tables [WT]: the SDN app's T1 (address), T2 (mode x/y) and T3 (communication x/y)."""
        tables = (self.testbed.sdn_state() or {}).get("tables", {})
        names = sorted(tables.get("T1", {}))
        if line.strip():
            names = [n for n in names if n == line.strip()]
        print(f"{'turbine':8} {'IP':12} {'MAC':18} {'attach':10} T2   T3")
        for n in names:
            a = tables["T1"][n]
            print(f"{n:8} {a['ip']:12} {a['mac']:18} {a['switch'] + ':' + str(a['port']):10} "
                  f"{tables['T2'].get(n, '?'):4} {tables['T3'].get(n, '?')}")

    def do_paths(self, _line):
        """paths: the installed path of every ViSC turbine (and its second leg with sdn.duplicate_paths)."""
        paths = (self.testbed.sdn_state() or {}).get("tables", {}).get("paths", {})
        for n, p in sorted(paths.items()):
            leg = f"   (copies also via {' -> '.join(p['second_leg'])})" if p.get("second_leg") else ""
            print(f"{n}: {' -> '.join(p['path'])}{leg}")
        if not paths:
            print("no paths installed")

    def do_visc(self, line):
        """visc WT on|off [h=3 m_q=0.02 ...]: ask (as the OWFCC) for turbine WT to run as ViSC, or stop."""
        parts = line.split()
        if len(parts) < 2 or parts[1] not in ("on", "off"):
            print("usage: visc WT on|off [param=value ...]")
            return
        params = {}
        for item in parts[2:]:
            key, _, value = item.partition("=")
            params[key] = float(value)
        if not self.testbed.command("owfcc.owfcc", {"cmd": f"visc_{parts[1]}", "wt": parts[0], "params": params}):
            print("the OWFCC is not running: request not sent")
            return
        if self.session is not None:
            self.testbed.record({"t": round(self.session.now(), 6), "source": "cli", "type": f"visc_{parts[1]}",
                                 "wt": parts[0]})
        print(f"requested visc_{parts[1]} for {parts[0]}")

    def do_link(self, line):
        """link A B up|down: take the link between nodes A and B down or up (timed and recorded
        like a timeline event, so its recovery appears in summary.json).
        link A B impair delay=5ms jitter=0.5ms loss=1% bw=100mbit: change the link's impairment
        (the keys given; bare numbers are ms, a fraction, Mbit/s); link A B clear: remove it.
        Only links with an impairment element (scenario links: or impairable: all) or netem."""
        parts = line.split()
        if len(parts) >= 3 and parts[2] in ("impair", "clear"):
            print(impairments.cli_command(self.testbed, parts[0], parts[1], parts[2:]))
            return
        if len(parts) != 3 or parts[2] not in ("up", "down"):
            print("usage: link A B up|down  |  link A B impair delay=5ms loss=1% ...  |  link A B clear")
            return
        a, b, state = parts
        try:
            t_wall = self.testbed.set_link(a, b, state == "up")
        except Exception as exc:  # noqa: BLE001 - report and keep the CLI alive
            print(f"link {a} {b}: {exc}")
            return
        t = round(t_wall - self.testbed.t0, 6)
        self.testbed.record({"t": t, "t_effective": t, "source": "cli", "type": f"link_{state}", "a": a, "b": b})
        print(f"t={t:.3f} s: link {a}-{b} {state}")

    def do_summary(self, _line):
        """summary: the SDN app's counters as JSON."""
        print(json.dumps((self.testbed.sdn_state() or {}).get("counters", {}), indent=1))
