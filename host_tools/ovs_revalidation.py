"""Open vSwitch's periodic flow revalidation, spaced out for a run (``other_config:max-revalidator``).

Scenario key ``switch_revalidation_ms``. ovs-vswitchd's revalidator threads dump and re-examine every
datapath flow once per ``max-revalidator`` milliseconds (default 500) whether or not anything changed.
On the userspace datapath of this 2-core machine, with Open vSwitch on a CPU of its own
(:mod:`host_tools.cpu_split`), those rounds share that CPU with the main thread that forwards every
packet: all_visc_50 at k = 16 had 92.9–93.7 % of its worst turbine's answers within one sample at the
default and 99.4 % with rounds every 10 s (docs/architecture.md "Time";
benchmarks/measured/switch-revalidation-2026-12-03.json). What a run needs from revalidation is not
the periodic round: a change of the flow tables or of a port (a flow-mod, a port going down) starts
a round at once (``ofproto-dpif-upcall.c``: the revalidators also wait on ``reval_seq``), so paths,
DR, fast failover and restoration behave the same; only idle datapath flows expire and flow
statistics refresh later (Open vSwitch takes the smaller of ``max-idle``, 10 s, and this value).

:func:`apply` writes the previous value to :data:`MARKER` before changing it; :func:`restore` puts it
back and removes the marker; :func:`host_tools.cleanup.clean` calls :func:`restore`, so a run that
was killed leaves no changed switch behind once any later run or ``sdvisc clean`` starts.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

MARKER = Path("/run/sdvisc-ovs-revalidator.json")
KEY = "max-revalidator"


def _vsctl(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["ovs-vsctl", "--timeout=10", *args], capture_output=True, text=True)


def current() -> str | None:
    """Open vSwitch's ``other_config:max-revalidator`` now (None: not set, its default of 500 ms)."""
    res = _vsctl("--if-exists", "get", "Open_vSwitch", ".", f"other_config:{KEY}")
    value = res.stdout.strip().strip('"')
    return value or None


def apply(ms: int) -> dict:
    """Revalidate every ``ms`` milliseconds until :func:`restore`; what summary.json reports."""
    if not MARKER.exists():  # a second apply keeps the value from before the first
        MARKER.write_text(json.dumps({"previous": current()}))
    res = _vsctl("set", "Open_vSwitch", ".", f"other_config:{KEY}={int(ms)}")
    if res.returncode != 0:
        restore()
        return {"applied": False, "why": res.stderr.strip() or f"ovs-vsctl exited with {res.returncode}"}
    return {"applied": True, "max_revalidator_ms": int(ms),
            "previous": json.loads(MARKER.read_text())["previous"]}


def changed() -> bool:
    """Whether a run's value is in force (the marker exists)."""
    return MARKER.exists()


def restore() -> bool:
    """Put back the value from before :func:`apply`; whether there was anything to restore."""
    if not MARKER.exists():
        return False
    try:
        previous = json.loads(MARKER.read_text()).get("previous")
    except ValueError:
        previous = None
    if previous is None:
        _vsctl("remove", "Open_vSwitch", ".", "other_config", KEY)
    else:
        _vsctl("set", "Open_vSwitch", ".", f"other_config:{KEY}={previous}")
    MARKER.unlink(missing_ok=True)
    return True
