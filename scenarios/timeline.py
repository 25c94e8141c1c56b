"""Carrying out a scenario's timeline actions: requests through the OWFCC, link failures and
impairments, kills and crashes, plant commands, hostile traffic. Each action is recorded (``events.jsonl``, source
``timeline``) with what actually happened (e.g. ``t_effective`` of a link failure)."""

from __future__ import annotations

import json
import sys
import threading

from sdvisc import wire
from sdvisc.config import CONTROLLER_VIP, CONTROLLER_VMAC

PLANT_COMMANDS = {"set": lambda e: {"type": "set", "param": e.param,
                                     **({"value": e.value} if e.delta is None else {"delta": e.delta})},
                  "load_step": lambda e: {"type": "load_step", "mw": e.mw},
                  "scr": lambda e: {"type": "scr", "value": e.value}}


def affected_by_link(sdn_state: dict | None, a: str, b: str) -> list[str]:
    """The ViSC turbines whose installed path (as the SDN app last published it) crosses a–b."""
    paths = ((sdn_state or {}).get("tables") or {}).get("paths") or {}
    return sorted(wt for wt, p in paths.items()
                  if any({x, y} == {a, b} for x, y in zip(p.get("path", []), p.get("path", [])[1:])))


def affected_by_kill(sdn_state: dict | None, host: str, process: str) -> list[str]:
    """The ViSC turbines a kill interrupts: those served by a killed SDC, every one for the SDN app
    (its loss interrupts nothing by itself, but the turbines are what to watch)."""
    paths = ((sdn_state or {}).get("tables") or {}).get("paths") or {}
    if process == "sdc":
        return sorted(wt for wt, p in paths.items() if p.get("sdc") == host)
    return sorted(paths)


def affected_by_nodes(sdn_state: dict | None, nodes: list[str]) -> list[str]:
    """The ViSC turbines a lost server interrupts: those whose installed path crosses one of its
    ``nodes`` or whose SDC is one of them."""
    paths = ((sdn_state or {}).get("tables") or {}).get("paths") or {}
    return sorted(wt for wt, p in paths.items() if p.get("sdc") in nodes or set(p.get("path", [])) & set(nodes))


class Timeline:
    """Acts on a running :class:`scenarios.runner.Run` (its processes, network and SDN state)."""

    def __init__(self, run) -> None:
        self.run = run

    def dispatch(self, event, t: float) -> dict:
        """Carry out one timeline event now (``t``: scenario time); returns its record."""
        run, kind = self.run, event.do
        record = {"t": round(t, 6), "source": "timeline", "type": kind, **event.model_dump(exclude={"t", "do"})}
        run.record(record)
        if kind in ("visc_on", "visc_off", "set_params"):
            run.processes.send("owfcc.owfcc", {"cmd": kind, "wt": event.wt, "params": getattr(event, "params", {})})
        elif kind in ("link_down", "link_up"):
            if kind == "link_down":
                record["affected"] = affected_by_link(run.sdn_state(), event.a, event.b)
            record["t_effective"] = round(run.set_link(event.a, event.b, kind == "link_up") - run.t0, 6)
        elif kind == "path_link_down":
            link = run.current_path_link(event.wt, event.hop)
            if link is None:
                record.update(type="path_link_down_skipped",
                              reason=f"{event.wt} has no installed path with switch-to-switch links")
            else:
                record.update(type="link_down", a=link[0], b=link[1], requested="path_link_down",
                              affected=affected_by_link(run.sdn_state(), *link))
                record["t_effective"] = round(run.set_link(link[0], link[1], False) - run.t0, 6)
        elif kind == "restore_links":
            down = sorted(run.links_down)
            times = [run.set_link(a, b, True) for a, b in down]
            record["links"] = down
            if times:
                record["t_effective"] = round(times[0] - run.t0, 6)
        elif kind == "kill":
            name = event.process if event.process.startswith("controller") else f"{event.host}.{event.process}"
            record["affected"] = affected_by_kill(run.sdn_state(), event.host, event.process)
            run.processes.kill(name, crash=event.crash)
        elif kind in ("fuzz", "spoof_ak"):
            record["out"] = self.start_fuzzer(event, sum(e["type"] == kind for e in run.timeline_events))
        elif kind in PLANT_COMMANDS:
            run.processes.send("plant", PLANT_COMMANDS[kind](event))
        elif kind == "impair":
            values = {k: getattr(event, k) for k in ("delay_ms", "jitter_ms", "loss", "bw_mbps")}
            record["now"] = run.impairments.set(event.a, event.b, round(t, 6), "timeline", **values).as_dict()
        elif kind == "clear_impairments":
            if event.a is None:
                record["links"] = run.impairments.clear_all(round(t, 6), "timeline")
            else:
                run.impairments.set(event.a, event.b, round(t, 6), "timeline", clear=True)
        elif kind == "server_down":
            nodes = run.cluster.nodes_on(event.server)
            record["affected"] = affected_by_nodes(run.sdn_state(), nodes)  # (as the app saw it before)
            for name in run.processes.procs:  # its services die with it: not crashes to restart
                if name.split(".")[0] in nodes:
                    run.processes.killed.add(name)
            record["nodes"] = run.cluster.server_down(event.server, t)
        elif kind == "fault":
            run.processes.send("plant", {"type": "fault", "on": True})
            timer = threading.Timer(max(0.0, run.clock.wall_s(run.t0 + t + event.duration_s - run.clock.now())),
                                    run.processes.send, args=("plant", {"type": "fault", "on": False}))
            timer.daemon = True
            timer.start()
        return record

    def start_fuzzer(self, event, number: int) -> str:
        """Start :mod:`host_tools.fuzz` in ``event.host``'s namespace: hostile datagrams at
        ``event.targets`` (``fuzz``) or AKs for another turbine (``spoof_ak``)."""
        run = self.run
        hosts = run.desc["hosts"]
        me = hosts[event.host]
        name = f"{event.do}{number}_{event.host}"
        # the fuzzer runs on the wall clock: its duration and pace are the scenario's, scaled
        cfg = {"count": event.count, "duration_s": run.clock.wall_s(event.duration_s), "out": str(run.out / f"{name}.json")}
        if event.do == "spoof_ak":
            victim = hosts[event.victim]
            who = victim if event.impersonate else me
            cfg.update(mode="spoof_ak", victim_wid=wire.turbine_id(victim["cluster"], victim["number"]), ak=event.ak,
                       src_ip=who["ip"], src_mac=who["mac"], dst_ip=CONTROLLER_VIP, dst_mac=CONTROLLER_VMAC,
                       iface=run.net.get(event.host).defaultIntf().name, seq0=event.seq0,
                       ctrl_rx=event.ctrl_rx)
        else:
            def port(target: str) -> int:
                if hosts[target]["role"] == "turbine":
                    return hosts[target].get("udp_port", wire.PORT_TURBINE)
                return wire.PORT_OWFCC if target == "owfcc" else wire.PORT_SDC

            cfg.update(targets=[[CONTROLLER_VIP, wire.PORT_CONTROLLER] if t == "controller" else [hosts[t]["ip"], port(t)]
                                for t in event.targets], seed=event.seed, step_s=run.clock.wall_s(run.scenario.step_s),
                       wid=wire.turbine_id(me["cluster"], me["number"]) if me["role"] == "turbine" else 101,
                       # a turbine sends from its own port (the plant holds it): its SDC path's flows match it
                       src_port=me.get("udp_port", wire.PORT_TURBINE) if me["role"] == "turbine" else None)
        path = run.out / f"{name}_config.json"
        path.write_text(json.dumps(cfg, indent=1))
        run.processes.start(f"{name}.fuzz", [sys.executable, "-m", "host_tools.fuzz", "--config", str(path)],
                            host=run.net.get(event.host))
        return f"{name}.json"
