"""Link impairments on real Mininet + Open vSwitch + os-ken: an impairment element (no netem on these
kernels) on s1–s3, the link carrying wt1_1's MEAS and CTRL. Asserted in simulated time: the
turbine's one-way delays rise by the configured delay, the counted loss is the configured one, and a
failure of the impaired link is still seen by both switches and repaired by DR."""

from __future__ import annotations

import pytest
import yaml

from impairment.queue import binomial_interval
from tests.integration.helpers import ROOT, assert_no_leftovers, run_scenario

pytestmark = pytest.mark.network


def scenario(tmp_path, name: str, links: list[dict], **extra) -> str:
    sc = yaml.safe_load((ROOT / "scenarios" / "smoke.yaml").read_text())
    sc.update(name=name, duration_s=3.0, links=links, **extra)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(sc))
    return path


def one_way_p50(summary: dict) -> tuple[float, float]:
    delays = summary["turbines"]["wt1_1"]["one_way_delay_ms"]
    return delays["meas_to_sdc"]["p50"], delays["ctrl_to_turbine"]["p50"]


HEADROOM = ("--time-scale", "4")
"""The element is one more forwarding hop (a process and a second veth pair) that a loaded 2-core
machine can make ~1 ms slower in wall time (CI, 88991e7: +0.52 ms at k = 2); at k = 4 that is
0.25 ms of simulated time, so the asserted rise is the configured delay's."""


def test_delay_and_loss_on_the_path(tmp_path):
    # the path must stay on the impaired link: detect and log DR, never reroute (a stall of the busy
    # machine once made the turbine miss its AKs for the hold and moved it off s1-s3 early in the run;
    # the next test has DR on)
    no_reroute = {"sdn": {"dynamic_routing": False}}
    plain = run_scenario(scenario(tmp_path, "plain", [], **no_reroute), tmp_path / "plain", *HEADROOM)
    impaired = run_scenario(scenario(tmp_path, "impaired", [{"a": "s1", "b": "s3", "delay_ms": 5.0, "loss": 0.1}],
                                     **no_reroute), tmp_path / "impaired", *HEADROOM)
    assert plain["impairments"] == {"mechanism": None, "links": []}
    (link,) = impaired["impairments"]["links"]
    assert link["complete"] and (link["a"], link["b"]) == ("s1", "s3")
    (phase,) = link["phases"]
    assert phase["configured"]["delay_ms"] == 5.0 and phase["added_delay_ms"]["p50"] == pytest.approx(5.0, abs=0.5)
    # both directions of the turbine's traffic cross s1-s3: each one-way delay rises by the 5 ms
    # configured, plus what the element itself reports as its own lateness, plus the extra hop
    for before, after in zip(one_way_p50(plain), one_way_p50(impaired)):
        assert 5.0 - 0.3 <= after - before <= 5.0 + phase["late_ms"]["p50"] + 0.5
    offered = phase["offered"]
    assert offered >= 2 * 0.9 * 2.0 / impaired["step_s"]  # MEAS and CTRL from t = 1 s
    low, high = binomial_interval(offered, 0.1)
    assert low <= phase["dropped_loss"] / offered <= high
    # the SDC received what the element let through toward it (MEAS: s3 -> s1), no more
    meas_through = phase["directions"]["s3->s1"]["forwarded"]
    packets = impaired["turbines"]["wt1_1"]["packets"]
    assert 0.99 * meas_through <= packets["meas_rx_sdc"] <= meas_through
    assert packets["meas_rx_sdc"] < 0.93 * packets["meas_tx"]
    assert_no_leftovers()


def test_failure_of_an_impaired_link_is_repaired_by_dr(tmp_path):
    sc = yaml.safe_load((ROOT / "scenarios" / "link_failure_dr.yaml").read_text())
    sc.update(name="impaired_link_failure", links=[{"a": "s1", "b": "s3", "delay_ms": 2.0, "jitter_ms": 0.5}])
    path = tmp_path / "lf.yaml"
    path.write_text(yaml.safe_dump(sc))
    s = run_scenario(path, tmp_path / "out")
    (rec,) = s["recoveries"]
    assert rec["cause"] == "dr" and rec["recovery_ms"] is not None
    assert rec["t_detect"] - rec["t_loss"] >= 0.040 - 0.001
    dr = next(e for e in s["events"] if e["type"] == "dr")
    assert ["s1", "s3"] not in [sorted(hop) for hop in zip(dr["new_path"], dr["new_path"][1:])]
    # the SDN app saw the link s1-s3 go down by port status, from both switches' ports toward the element
    assert any(e["type"] == "link_down" and e.get("source") == "sdn_app" and e["link"] == ["s1", "s3"]
               for e in s["events"])
    assert s["openflow"]["rx_port_status"] >= 2
    (link,) = s["impairments"]["links"]
    (phase,) = link["phases"]
    assert phase["forwarded"] > 0 and phase["added_delay_ms"]["p50"] == pytest.approx(2.0, abs=0.5)
    assert_no_leftovers()
