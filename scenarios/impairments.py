"""Link impairments during a run: which links get one, how (netem or an impairment element), changes
from the timeline and the CLI, link failures through an element, and ``summary.json`` → ``impairments``.

**Mechanism.** Where ``tc qdisc add … netem`` works (checked once, in a throw-away network
namespace), a link's impairment is a netem qdisc on both switch ports of the link (delay and
jitter scaled by the time scale k, rate divided by k). Where it does not (these machines), each
impairable link gets an *impairment element*: a Mininet host ``imp<n>`` wired between the two
switches (topologies.base.TestbedTopo) running :mod:`impairment.element`. ``SDVISC_IMPAIR=netem``
or ``element`` overrides the detection.

**Which links.** Those in the scenario's ``links``, those named by an ``impair`` action, and, with
``impairable: all``, every switch-to-switch link (or the links ``impairable`` lists). An element
costs one Python process and adds its forwarding time (tens of µs) to the link even when clear,
so links nobody impairs get none; the CLI says so when asked to impair such a link.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

from impairment.element import status_path
from impairment.queue import KEYS, Impairment
from scenarios.processes import RunError
from scenarios.schema import Scenario
from sdvisc.config import ImpairNodeConfig, write_config
from topologies.base import describe

ENV = "SDVISC_IMPAIR"
_netem: bool | None = None


def netem_available() -> bool:
    """True where the kernel has the netem qdisc (tried on ``lo`` of a throw-away namespace)."""
    global _netem
    if _netem is None:
        try:
            res = subprocess.run(["unshare", "--net", "tc", "qdisc", "add", "dev", "lo", "root", "netem", "delay", "1ms"],
                                 capture_output=True, timeout=10, check=False)
            _netem = res.returncode == 0
        except (OSError, subprocess.TimeoutExpired):
            _netem = False
    return _netem


def mechanism() -> str:
    """``netem`` where the kernel has it, else ``element`` (``SDVISC_IMPAIR`` overrides)."""
    forced = os.environ.get(ENV)
    if forced in ("netem", "element"):
        return forced
    return "netem" if netem_available() else "element"


def netem_args(ifname: str, imp: Impairment, time_scale: float) -> list[str]:
    """The ``tc`` command giving ``ifname``'s egress ``imp`` (in simulated time: delays × k,
    rate / k), or removing it when ``imp`` is clear."""
    if imp.clear:
        return ["tc", "qdisc", "del", "dev", ifname, "root"]
    args = ["tc", "qdisc", "replace", "dev", ifname, "root", "netem", "limit", "100000"]
    if imp.delay_ms or imp.jitter_ms:
        args += ["delay", f"{imp.delay_ms * time_scale:g}ms"] + ([f"{imp.jitter_ms * time_scale:g}ms"] if imp.jitter_ms else [])
    if imp.loss:
        args += ["loss", f"{imp.loss * 100:g}%"]
    if imp.bw_mbps is not None:
        args += ["rate", f"{int(imp.bw_mbps * 1e6 / time_scale)}bit"]
    return args


_UNITS = {"delay": ("delay_ms", {"ms": 1.0, "s": 1e3, "us": 1e-3, "": 1.0}),
          "jitter": ("jitter_ms", {"ms": 1.0, "s": 1e3, "us": 1e-3, "": 1.0}),
          "loss": ("loss", {"%": 1e-2, "": 1.0}),
          "bw": ("bw_mbps", {"mbit": 1.0, "gbit": 1e3, "kbit": 1e-3, "": 1.0})}


def parse_cli_values(words: list[str]) -> dict:
    """``["delay=5ms", "loss=1%", "jitter=0.5ms", "bw=100mbit"]`` → ``{"delay_ms": 5.0, "loss": 0.01, …}``
    (bare numbers: ms, a fraction, Mbit/s); ValueError naming what is wrong."""
    out = {}
    for word in words:
        key, _, text = word.partition("=")
        if key not in _UNITS or not text:
            raise ValueError(f"expected key=value with key one of {', '.join(_UNITS)}, got {word!r}")
        field, units = _UNITS[key]
        match = re.fullmatch(r"([0-9.eE+-]+)\s*([a-z%]*)", text.strip().lower())
        if not match or match.group(2) not in units:
            raise ValueError(f"{key}: cannot read {text!r} (units: {', '.join(u or 'none' for u in units)})")
        try:
            out[field] = float(match.group(1)) * units[match.group(2)]
        except ValueError as exc:
            raise ValueError(f"{key}: {text!r} is not a number") from exc
    if not out:
        raise ValueError("nothing to set: give delay=, jitter=, loss= or bw=")
    return out


def _pair(a: str, b: str) -> frozenset:
    return frozenset((a, b))


class Impairments:
    """The impaired links of one run (see the module docstring); ``run`` is the
    :class:`scenarios.runner.Run` (its clock, processes, network and description)."""

    def __init__(self, scenario: Scenario, out: Path) -> None:
        self.scenario = scenario
        self.out = Path(out)
        # patch links have no kernel device for netem: an impaired link gets an element (veths) there
        self.mechanism = ("element" if scenario.switch_links == "patch" else mechanism()) if self._wanted() else None
        self.initial = {_pair(lk.a, lk.b): Impairment.of(lk)
                        for lk in scenario.links}
        self.seeds = {_pair(lk.a, lk.b): lk.seed for lk in scenario.links}
        self.current: dict[frozenset, Impairment] = {}
        self.links: dict[frozenset, dict] = {}  # pair -> {"a", "b", "element", "ends"} once started
        self.history: dict[frozenset, list[dict]] = {}
        self.netem_stats: dict[frozenset, dict] = {}
        self.run = None

    def _wanted(self) -> bool:
        sc = self.scenario
        return bool(sc.links or sc.impairable != "listed" or any(e.do == "impair" for e in sc.timeline))

    def element_links(self, desc_links: list[dict]) -> list[tuple[str, str]]:
        """The switch-to-switch links that get an element (none with netem)."""
        return self.impairable(desc_links) if self.mechanism == "element" else []

    def build_topology(self, topo_cls, params: dict):
        """The scenario's topology with an element on every link that gets one."""
        topo = topo_cls(**params)
        impaired = self.element_links(describe(topo)["links"])
        return topo_cls(**params, impaired=impaired) if impaired else topo

    def impairable(self, desc_links: list[dict]) -> list[tuple[str, str]]:
        """The switch-to-switch links this run can impair (see the module docstring)."""
        if self.mechanism is None:
            return []
        sc = self.scenario
        if sc.impairable == "all":
            return [(lk["a"], lk["b"]) for lk in desc_links]
        wanted = {_pair(lk.a, lk.b) for lk in sc.links}
        wanted |= {_pair(e.a, e.b) for e in sc.timeline if e.do == "impair"}
        if isinstance(sc.impairable, list):
            wanted |= {_pair(lk.a, lk.b) for lk in sc.impairable}
        return [(lk["a"], lk["b"]) for lk in desc_links if _pair(lk["a"], lk["b"]) in wanted]

    # ------------------------------------------------------------------ start
    def start(self, run) -> None:
        """After the network is up: start an element on every link that has one (or apply netem
        to the links with an initial impairment)."""
        self.run = run
        if self.mechanism is None:
            return
        impairable = {_pair(a, b) for a, b in self.impairable(run.desc["links"])}
        for lk in run.desc["links"]:
            pair = _pair(lk["a"], lk["b"])
            if pair not in impairable:
                continue
            self.links[pair] = {"a": lk["a"], "b": lk["b"], "element": lk.get("element")}
            imp = self.initial.get(pair, Impairment())
            self.current[pair] = imp
            self.history[pair] = [{"t": 0.0, "source": "scenario", **imp.as_dict()}]
        for pair, link in self.links.items():
            if link["element"]:
                self._start_element(pair, link)
            elif not self.current[pair].clear:
                self._netem(pair)
        for link in self.links.values():
            if link["element"]:
                name = link["element"]
                run.processes.wait_ready(f"{name}.impair", status_path(self.out, name).name, f"impairment element {name}")

    def _start_element(self, pair: frozenset, link: dict) -> None:
        run, name = self.run, link["element"]
        imp = self.current[pair]
        cfg = ImpairNodeConfig(**run.clock_settings, name=name, a=link["a"], b=link["b"], intf_a=f"{name}-eth0",
                               intf_b=f"{name}-eth1", out_dir=str(self.out), seed=self.seeds.get(pair, 1), **imp.as_dict())
        path = write_config(cfg, self.out / f"impair_{name}_config.json")
        run.processes.start(f"{name}.impair", [sys.executable, "-m", "impairment.element", "--config", str(path)],
                            host=run.net.get(name), stdin=subprocess.PIPE)

    def set_clock(self, clock_settings: dict) -> None:
        """The run's clock changed before t = 0 (``time_scale: auto``): tell every element."""
        for link in self.links.values():
            if link["element"]:
                self.run.processes.send(f"{link['element']}.impair", {"cmd": "clock", **clock_settings})

    # ------------------------------------------------------------------ changes
    def _find(self, a: str, b: str) -> frozenset:
        pair = _pair(a, b)
        if pair not in self.links:
            known = ", ".join(sorted(f"{lk['a']}-{lk['b']}" for lk in self.links.values())) or "none"
            how = ("list it under links: or set impairable: all in the scenario" if self.mechanism != "netem"
                   else "list it under links: or set impairable: all")
            raise RunError(f"link {a}-{b} cannot be impaired in this run (impairable links: {known}); {how}")
        return pair

    def set(self, a: str, b: str, t: float | None, source: str, clear: bool = False, **changes) -> Impairment:
        """Change link a–b's impairment (the keys given; ``clear``: back to none); returns the new one."""
        pair = self._find(a, b)
        imp = Impairment() if clear else self.current[pair].merged(**{k: changes.get(k) for k in KEYS})
        self.current[pair] = imp
        self.history[pair].append({"t": t, "source": source, **imp.as_dict()})
        link = self.links[pair]
        if link["element"]:
            if not self.run.processes.send(f"{link['element']}.impair", {"cmd": "set", "impairment": imp.as_dict()}):
                raise RunError(f"the impairment element of {a}-{b} is not running")
        else:
            self._netem(pair)
        return imp

    def clear_all(self, t: float | None, source: str) -> list[str]:
        done = []
        for pair, link in self.links.items():
            if not self.current[pair].clear:
                self.set(link["a"], link["b"], t, source, clear=True)
                done.append(f"{link['a']}-{link['b']}")
        return done

    def _netem(self, pair: frozenset) -> None:
        link, imp = self.links[pair], self.current[pair]
        for intf in self._switch_ports(link):  # the two switch ports
            args = netem_args(intf.name, imp, self.run.clock.time_scale)
            res = subprocess.run(args, capture_output=True, text=True, check=False)
            if res.returncode != 0 and not imp.clear:
                raise RunError(f"{' '.join(args)} failed: {res.stderr.strip()}")

    def _switch_ports(self, link: dict) -> list:
        ends = self.link_ends(self.run.net, link["a"], link["b"])
        return [ends[0], ends[-1]]

    # ------------------------------------------------------------------ link failures
    def link_ends(self, net, a: str, b: str) -> list:
        """The interfaces of link a–b, a's end first; with an element: a's port, the element's two
        interfaces, b's port (a link failure takes all of them down, so both switches see it)."""
        node_a, node_b = net.get(a), net.get(b)
        direct = net.linksBetween(node_a, node_b)
        if direct:
            lk = direct[0]
            return [lk.intf1, lk.intf2] if lk.intf1.node is node_a else [lk.intf2, lk.intf1]
        link = self.links.get(_pair(a, b))
        if not link or not link["element"]:
            return []
        node_e = net.get(link["element"])
        ends = []
        for near, far in ((node_a, node_e), (node_e, node_b)):
            lk = net.linksBetween(near, far)[0]
            ends += [lk.intf1, lk.intf2] if lk.intf1.node is near else [lk.intf2, lk.intf1]
        return ends

    # ------------------------------------------------------------------ reporting
    def status_lines(self) -> list[str]:
        """One line per impairable link for the CLI's ``status``."""
        lines = []
        for pair, link in sorted(self.links.items(), key=lambda item: (item[1]["a"], item[1]["b"])):
            measured = ""
            if link["element"]:
                st = _read(status_path(self.out, link["element"]))
                if st:
                    fwd = sum(p["forwarded"] for p in st["phases"])
                    lost = sum(p["dropped_loss"] for p in st["phases"])
                    measured = f"  (element {link['element']}: forwarded {fwd}, lost {lost})"
            lines.append(f"{link['a']}-{link['b']}: {self.current[pair].describe()}{measured}")
        return lines

    def finish(self) -> None:
        """Before the network is torn down: read netem's counters (elements write their own)."""
        if self.mechanism != "netem" or self.run is None or self.run.net is None:
            return
        for pair, link in self.links.items():
            stats = {}
            for intf in self._switch_ports(link):
                try:  # teardown goes on whatever tc says
                    out = subprocess.run(["tc", "-s", "-j", "qdisc", "show", "dev", intf.name], capture_output=True,
                                         text=True, check=False, timeout=10).stdout
                    qdisc = next((q for q in json.loads(out) if q.get("kind") == "netem"), {})
                except (OSError, ValueError, subprocess.TimeoutExpired):
                    qdisc = {}
                stats[intf.name] = {"packets": qdisc.get("packets"), "drops": qdisc.get("drops")}
            self.netem_stats[pair] = stats

    def summary(self, t0: float | None) -> dict:
        """``summary.json`` → ``impairments``: per impairable link what was configured when
        (``configured``, scenario seconds and source) and what the element measured per
        configured period (``phases``: counters per direction, loss rate, added delay p50/p95 and
        its error against the configured delay, the element's own lateness)."""
        out = []
        for pair, link in self.links.items():
            entry = {"a": link["a"], "b": link["b"], "element": link["element"], "configured": self.history[pair]}
            if link["element"]:
                st = _read(status_path(self.out, link["element"]))
                phases = []
                for phase in st.get("phases", []):
                    phase = dict(phase)
                    for key in ("t_from", "t_to"):
                        if phase.get(key) is not None and t0 is not None:
                            phase[key] = round(max(0.0, phase[key] - t0), 6)
                    phases.append(phase)
                entry.update(phases=phases, cpu_s=st.get("cpu_s"), scheduling=st.get("scheduling"),
                             complete=bool(st.get("final")), tc_errors=st.get("tc_errors", []))
            else:
                entry["netem"] = self.netem_stats.get(pair, {})
            out.append(entry)
        return {"mechanism": self.mechanism, "links": out}


def _read(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}


def summary_section(run) -> dict:
    """``summary.json`` → ``impairments`` of ``run`` (empty when nothing was impairable)."""
    imp = getattr(run, "impairments", None)
    return imp.summary(getattr(run, "t0", None)) if imp is not None else {"mechanism": None, "links": []}


def cli_command(run, a: str, b: str, words: list[str]) -> str:
    """``link A B impair delay=5ms loss=1%`` / ``link A B clear`` from the CLI: applied now,
    recorded like a timeline action (source ``cli``); returns the line to print."""
    t = round(run.clock.now() - run.t0, 6) if run.t0 is not None else None
    try:
        if words[0] == "clear":
            if len(words) > 1:
                raise ValueError("usage: link A B clear")
            imp = run.impairments.set(a, b, t, "cli", clear=True)
        else:
            imp = run.impairments.set(a, b, t, "cli", **parse_cli_values(words[1:]))
    except (ValueError, RunError) as exc:
        return f"link {a} {b}: {exc}"
    run.record({"t": t, "source": "cli", "type": "impair" if words[0] == "impair" else "clear_impairments",
                "a": a, "b": b, "now": imp.as_dict()})
    return f"t={t if t is not None else 0:.3f} s: link {a}-{b} {imp.describe()}"
