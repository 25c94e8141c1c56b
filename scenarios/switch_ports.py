"""The switch side of every link: Open vSwitch ``system`` ports (Mininet's default) or AF_XDP.

On the userspace datapath a ``system`` port is an AF_PACKET socket that ovs-vswitchd's main thread
polls: every bridge a packet crosses costs one iteration of that loop (measured here, benchmarks/
ovs_hops.py: 0.09–0.13 ms one way per bridge, so 2–3.6 ms for a MEAS → CTRL round trip across
the farm). An ``afxdp`` port is an AF_XDP socket polled by a PMD thread that spins one core: 0.006–0.01
ms per bridge, at the price of that core (``ovs-vswitchd`` at 1.0 CPU whenever such a port exists).
``afxdp-nonpmd`` keeps the main thread (0.067 ms per bridge). Scenario key ``switch_ports``, CLI
``--switch-ports``.

Switching needs the BPF file system (mounted here when missing) and an XDP program per port (about
0.15 s each: 16 s for the farm's ~110 ports). Where Open vSwitch refuses a port (no AF_XDP in the
kernel, no libxdp), every port goes back to ``system`` and the run says why (``summary.json``:
``switch_ports``); nothing else changes.
"""

from __future__ import annotations

import json
import subprocess
import time

from scenarios.switch_links import is_patch

SWITCH_PORT_TYPES = ("system", "afxdp", "afxdp-nonpmd")
READY_TIMEOUT_S = 60.0


def port_names(switches) -> list[str]:
    """The switch side of every veth of ``switches`` (Mininet switch nodes; a patch link's ends are
    no kernel device, :mod:`scenarios.switch_links`)."""
    return [intf.name for sw in switches for intf in sw.intfList() if intf.name != "lo" and not is_patch(intf)]


def set_type_command(names: list[str], kind: str) -> list[str]:
    """One ovs-vsctl transaction giving every port of ``names`` the type ``kind`` (the empty type
    is a ``system`` port)."""
    value = '""' if kind == "system" else kind
    cmd = ["ovs-vsctl"]
    for name in names:
        cmd += ["--", "set", "Interface", name, f"type={value}"]
    return cmd


def not_ready(listing: dict, names: list[str], kind: str) -> dict[str, str]:
    """Ports of ``names`` not (yet) open as ``kind`` in an ``ovs-vsctl --format=json
    --columns=name,type,error,ofport list Interface`` listing -> what Open vSwitch says of each
    (its error column, else the state)."""
    rows = {row[0]: row for row in listing["data"]}
    out = {}
    for name in names:
        row = rows.get(name)
        if row is None:
            out[name] = "not in the Interface table"
            continue
        _name, kind_now, error, ofport = row
        error = "" if error == ["set", []] else error
        if error:
            out[name] = str(error)
        elif (kind_now or "system") != kind:
            out[name] = f"type {kind_now or 'system'}"
        elif not isinstance(ofport, int) or ofport < 1:
            out[name] = "no OpenFlow port number yet"
    return out


def _listing() -> dict:
    return json.loads(subprocess.run(["ovs-vsctl", "--format=json", "--columns=name,type,error,ofport", "list",
                                      "Interface"], check=True, capture_output=True, text=True, timeout=60).stdout)


def _ensure_bpffs() -> None:
    if subprocess.run(["mountpoint", "-q", "/sys/fs/bpf"]).returncode != 0:
        subprocess.run(["mount", "-t", "bpf", "bpf", "/sys/fs/bpf"], check=True, capture_output=True, timeout=30)


def use(names: list[str], kind: str, timeout_s: float = READY_TIMEOUT_S) -> dict:
    """Make every port of ``names`` a ``kind`` port and wait until Open vSwitch has opened them all.
    Refused (an error on any port, or not open within ``timeout_s``): every port back to ``system``.
    Returns what a summary records: ``requested``, ``used``, ``ports``, ``wall_s`` and, on a fall-back,
    ``refused`` (a port and Open vSwitch's words)."""
    if kind not in SWITCH_PORT_TYPES:
        raise ValueError(f"switch ports must be one of {', '.join(SWITCH_PORT_TYPES)}, not {kind!r}")
    started = time.perf_counter()
    record = {"requested": kind, "used": kind, "ports": len(names)}
    if kind == "system" or not names:
        return record
    problem = None
    try:
        _ensure_bpffs()
        subprocess.run(set_type_command(names, kind), check=True, capture_output=True, text=True, timeout=60)
        deadline = time.perf_counter() + timeout_s
        while True:
            waiting = not_ready(_listing(), names, kind)
            errors = {n: why for n, why in waiting.items() if not why.startswith(("type ", "no OpenFlow"))}
            if not waiting:
                break
            if errors or time.perf_counter() > deadline:
                name, why = next(iter((errors or waiting).items()))
                problem = f"{name}: {why}"
                break
            time.sleep(0.2)
    except (subprocess.SubprocessError, OSError) as exc:
        problem = str(exc).strip() or type(exc).__name__
    if problem is not None:
        subprocess.run(set_type_command(names, "system"), capture_output=True, timeout=60)
        record.update(used="system", refused=problem)
    record["wall_s"] = round(time.perf_counter() - started, 3)
    return record
