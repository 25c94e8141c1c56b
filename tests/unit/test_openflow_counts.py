"""Issue 42 item 5: what each request costs the switches, counted by cause in the pure logic and
reported in summary.json apart from keepalives (which grow with wall time, not with requests)."""

from __future__ import annotations

from scenarios.summary import openflow_section
from sdn_app.logic import Controller
from sdvisc import wire
from tests.unit.test_sdn_logic import frame, ingress, make_config, request
from tests.unit.test_sdn_resilience import ak, heartbeat


def test_messages_are_counted_by_cause_and_steady_state_sends_nothing():
    ctl = Controller(make_config(backup_sdc=None), now=0.0)
    for dpid in ctl.dpids.values():
        ctl.switch_up(dpid, 0.1)
    owfcc = ctl.config.topology.hosts["owfcc"].model_dump()
    actions = ctl.packet_in(*ingress(ctl, "owfcc"), frame(owfcc, request(wire.Command.VISC_ON)), 1.0)
    counted = {k: v for k, v in ctl.counters.items() if k.startswith("of:request:") and k != "of:request:requests"}
    assert sum(counted.values()) == len(actions) > 0 and ctl.counters["of:request:requests"] == 1
    before = dict(ctl.counters)
    for k in range(1, 50):  # 0.5 s of steady state: AKs, heartbeats, ticks — no switch message
        now = 1.5 + k * 0.01
        assert ak(ctl, k, 1, 0.0005, now) == [] and heartbeat(ctl, "sdc1", k, now) == [] and ctl.tick(now) == []
    assert {k: v for k, v in ctl.counters.items() if k.startswith("of:")} == {k: v for k, v in before.items()
                                                                               if k.startswith("of:")}
    section = openflow_section({"openflow": {"tx_total": 999, "rx_echo_keepalive": 40}, "counters": dict(ctl.counters)})
    per = section["per_request"]
    assert per["requests"] == 1 and per["flow_mods"] == counted["of:request:flow_mods"]
    assert section["by_cause"]["on_connect"]["flow_mods"] == ctl.counters["of:on_connect:flow_mods"]
    assert section["keepalive"] == {"echo_requests_rx": 40, "switch_connects": len(ctl.dpids)}
    assert section["tx_total"] == 999  # the totals stay, for whoever wants them
