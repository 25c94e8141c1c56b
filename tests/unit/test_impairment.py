"""Link impairments as pure logic: the timed queue (delay, jitter, seeded loss, order) on an injected
clock, what an element reports, the CLI's value syntax, the tc commands, the topology's view of a
link with an element, and the scenario checks (no switches, no root)."""

from __future__ import annotations

import numpy as np
import pytest

from impairment.element import tbf_args
from impairment.queue import Impairment, Phase, TimedQueue, binomial_interval
from scenarios.impairments import netem_args, parse_cli_values
from scenarios.loader import ScenarioError, load_scenario
from sdvisc.clock import ManualClock
from topologies import topos
from topologies.base import describe

TS = 0.67e-3  # one SDViSC sample: the rate a turbine's MEAS cross a link


def feed(queue: TimedQueue, clock: ManualClock, n: int, period: float) -> list[tuple[float, float]]:
    """Offer ``n`` frames ``period`` apart; returns (arrival, planned release) of every frame that
    left, releasing at each step what is due (as the element does when it wakes)."""
    out = []
    for i in range(n):
        queue.offer(i.to_bytes(4, "big"), clock.now())
        clock.advance(period)
        due = list(queue.pop_due(clock.now()))
        assert all(t_rel <= clock.now() for _, _, t_rel in due)
        out += [(t_arr, t_rel) for _, t_arr, t_rel in due]
    clock.advance(10.0)
    out += [(t_arr, t_rel) for _, t_arr, t_rel in queue.pop_due(clock.now())]
    return out


def test_constant_delay_holds_every_frame_exactly_that_long():
    clock = ManualClock(1000.0)
    queue = TimedQueue(Impairment(delay_ms=5.0), np.random.default_rng(1))
    queue.offer(b"x", clock.now())
    assert queue.next_release() == pytest.approx(1000.005)
    clock.advance(0.004999)
    assert list(queue.pop_due(clock.now())) == []
    clock.advance(0.000001)
    ((frame, t_arr, t_rel),) = list(queue.pop_due(clock.now()))
    assert frame == b"x" and t_rel - t_arr == pytest.approx(0.005)
    assert queue.next_release() is None


def test_delay_is_in_the_callers_simulated_seconds():
    """The queue never reads a clock: at time scale k the element hands it simulated seconds, so
    a 5 ms delay is 5 simulated ms (k·5 ms of wall time)."""
    clock = ManualClock(0.0, time_scale=4.0)
    queue = TimedQueue(Impairment(delay_ms=5.0), np.random.default_rng(1))
    queue.offer(b"x", clock.now())
    assert clock.wall_s(queue.next_release() - clock.now()) == pytest.approx(0.020)


def test_jitter_is_uniform_within_delay_plus_minus_jitter():
    clock = ManualClock()
    queue = TimedQueue(Impairment(delay_ms=5.0, jitter_ms=1.0), np.random.default_rng(7))
    # frames far apart (no queueing behind each other): the delays are the draws themselves
    delays = np.array([t_rel - t_arr for t_arr, t_rel in feed(queue, clock, 20_000, 0.01)]) * 1e3
    assert delays.min() >= 4.0 and delays.max() <= 6.0
    assert delays.mean() == pytest.approx(5.0, abs=0.02)
    assert delays.std() == pytest.approx(1.0 / np.sqrt(3), rel=0.03)  # uniform on [4, 6]
    counts, _ = np.histogram(delays, bins=10, range=(4.0, 6.0))
    assert counts.min() > 0.9 * 2000 and counts.max() < 1.1 * 2000


def test_jitter_never_reorders_frames_and_never_goes_below_zero():
    clock = ManualClock()
    queue = TimedQueue(Impairment(delay_ms=0.5, jitter_ms=2.0), np.random.default_rng(3))
    departures = feed(queue, clock, 5000, TS)  # frames closer than the jitter
    releases = [t_rel for _, t_rel in departures]
    assert len(departures) == 5000
    assert releases == sorted(releases)
    assert all(t_rel >= t_arr for t_arr, t_rel in departures)


def test_loss_is_seeded_and_within_its_binomial_interval():
    def lost(seed: int) -> list[int]:
        queue = TimedQueue(Impairment(loss=0.1), np.random.default_rng(seed))
        return [i for i in range(20_000) if not queue.offer(b"x", float(i))]

    first, again, other = lost(5), lost(5), lost(6)
    assert first == again and first != other
    low, high = binomial_interval(20_000, 0.1)
    assert low <= len(first) / 20_000 <= high
    assert 0.094 < low and high < 0.106


def test_no_loss_and_certain_loss():
    keep = TimedQueue(Impairment(), np.random.default_rng(1))
    drop = TimedQueue(Impairment(loss=1.0), np.random.default_rng(1))
    assert all(keep.offer(b"x", float(i)) for i in range(1000))
    assert not any(drop.offer(b"x", float(i)) for i in range(1000))


def test_a_new_impairment_applies_to_frames_offered_afterwards():
    clock = ManualClock()
    queue = TimedQueue(Impairment(delay_ms=20.0), np.random.default_rng(1))
    queue.offer(b"old", 0.0)
    queue.set(Impairment(delay_ms=1.0))
    queue.offer(b"new", 0.001)
    clock.advance(1.0)
    (old, new) = list(queue.pop_due(clock.now()))
    assert old[2] == pytest.approx(0.020)
    assert new[2] == pytest.approx(0.020)  # 2 ms would overtake the frame ahead: a link does not reorder


def test_phase_reports_counts_loss_rate_and_delay_error():
    phase = Phase(Impairment(delay_ms=5.0, loss=0.01), 100.0, ("s1->s3", "s3->s1"))
    for i in range(100):
        phase.counts["s1->s3"]["offered"] += 1
        phase.sent("s1->s3", 0.005 + i * 1e-6, i * 1e-6)
    phase.counts["s3->s1"].update(offered=100, dropped_loss=1)
    report = phase.report(with_percentiles=True)
    assert report["offered"] == 200 and report["forwarded"] == 100 and report["loss_rate"] == 0.005
    assert report["added_delay_ms"]["p50"] == pytest.approx(5.0495, abs=1e-3)
    assert report["added_delay_error_ms"]["p95"] == pytest.approx(0.094, abs=1e-3)
    assert report["late_ms"]["max"] == pytest.approx(0.099, abs=1e-4)
    assert "added_delay_ms" not in phase.report(with_percentiles=False)


def test_impairment_values_are_checked_and_merged():
    with pytest.raises(ValueError, match="loss"):
        Impairment(loss=1.5)
    with pytest.raises(ValueError, match="delay_ms"):
        Impairment(delay_ms=-1)
    imp = Impairment(delay_ms=2, loss=0.01, bw_mbps=100).merged(delay_ms=5, jitter_ms=None)
    assert imp == Impairment(delay_ms=5, loss=0.01, bw_mbps=100)
    assert imp.merged(bw_mbps=0).bw_mbps is None
    assert imp.describe() == "delay=5ms loss=1% bw=100Mbit/s" and Impairment().describe() == "clear"


def test_cli_values_with_units_and_clear_errors():
    assert parse_cli_values(["delay=5ms", "loss=1%", "jitter=500us", "bw=1gbit"]) == {
        "delay_ms": 5.0, "loss": 0.01, "jitter_ms": 0.5, "bw_mbps": 1000.0}
    assert parse_cli_values(["delay=2", "loss=0.1", "bw=10"]) == {"delay_ms": 2.0, "loss": 0.1, "bw_mbps": 10.0}
    for bad, message in ((["speed=5"], "key one of"), (["delay=5 parsecs"], "cannot read"), ([], "nothing to set"),
                         (["loss=x%"], "cannot read")):
        with pytest.raises(ValueError, match=message):
            parse_cli_values(bad)


def test_tc_commands_scale_with_virtual_time():
    imp = Impairment(delay_ms=5, jitter_ms=1, loss=0.01, bw_mbps=100)
    assert netem_args("s1-eth3", imp, 2.0) == ["tc", "qdisc", "replace", "dev", "s1-eth3", "root", "netem", "limit",
                                               "100000", "delay", "10ms", "2ms", "loss", "1%", "rate", "50000000bit"]
    assert netem_args("s1-eth3", Impairment(), 2.0) == ["tc", "qdisc", "del", "dev", "s1-eth3", "root"]
    tbf = tbf_args("imp1-eth0", 100, 4.0)
    assert tbf[:8] == ["tc", "qdisc", "replace", "dev", "imp1-eth0", "root", "tbf", "rate"] and tbf[8] == "25000000bit"
    assert tbf_args("imp1-eth0", None, 1.0) == ["tc", "qdisc", "del", "dev", "imp1-eth0", "root"]


def test_an_element_keeps_the_sdn_apps_view_of_the_link():
    plain = describe(topos["paper"](clusters=1, turbines=2))
    impaired_topo = topos["paper"](clusters=1, turbines=2, impaired=[("s3", "s1")])
    impaired = describe(impaired_topo)
    assert impaired["hosts"] == plain["hosts"] and impaired["switches"] == plain["switches"]
    assert [{k: v for k, v in lk.items() if k != "element"} for lk in impaired["links"]] == plain["links"]
    (with_element,) = [lk for lk in impaired["links"] if "element" in lk]
    assert (with_element["a"], with_element["b"], with_element["element"]) == ("s1", "s3", "imp1")
    assert impaired_topo.nodeInfo("imp1")["role"] == "impairment" and "imp1" in impaired_topo.hosts()
    assert not any({"s1", "s3"} == {a, b} for a, b in impaired_topo.links())  # the frames really pass imp1


def _write(tmp_path, body: str):
    path = tmp_path / "sc.yaml"
    path.write_text("name: x\nduration_s: 3\ntopology: {name: paper, clusters: 1, turbines: 2}\n" + body)
    return path


def test_scenario_links_are_checked_against_the_topology(tmp_path):
    path = _write(tmp_path, "links:\n  - {a: s1, b: s3, delay_ms: 2}\n  - {a: s1, b: s9}\n  - {a: s3, b: s1, loss: 2}\n"
                            "timeline:\n  - {t: 1, do: impair, a: s2, b: s4, delay_ms: 1}\n"
                            "  - {t: 1, do: impair, a: s1, b: s2}\n  - {t: 2, do: clear_impairments, a: s1}\n")
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    lines = str(err.value).splitlines()
    assert f"{path}:6: links.1: no switch-to-switch link s1-s9 in topology paper" in lines[0]
    assert any(line.startswith(f"{path}:7: links.2.loss: Input should be less than or equal to 1") for line in lines)
    assert any(line.startswith(f"{path}:7: links.2: link s3-s1 is listed twice") for line in lines)
    assert any(line.startswith(f"{path}:9: timeline.0: no switch-to-switch link s2-s4") for line in lines)
    assert any(line.startswith(f"{path}:10: timeline.1:") and "at least one of" in line for line in lines)
    assert any(line.startswith(f"{path}:11: timeline.2:") and "both a and b" in line for line in lines)


def test_a_valid_impaired_scenario_loads(tmp_path):
    sc = load_scenario(_write(tmp_path, "links:\n  - {a: s3, b: s1, delay_ms: 2, jitter_ms: 0.5, loss: 0.01, bw_mbps: 100}\n"
                                        "impairable: all\ntimeline:\n  - {t: 1, do: impair, a: s1, b: s2, loss: 0.1}\n"
                                        "  - {t: 2, do: clear_impairments}\n"))
    assert sc.links[0].bw_mbps == 100 and sc.impairable == "all" and sc.timeline[1].a is None


def test_cleanup_knows_the_elements():
    from host_tools import cleanup

    assert cleanup.LINK_RE.match("imp1-eth0") and cleanup.LINK_RE.match("imp12")  # a crash mid-build leaves veths
    assert not cleanup.LINK_RE.match("impish")
    # the element processes are found by the run's marker in their environment (scenarios.processes
    # starts them: tests/unit/test_cleanup_ownership.py), not by their command line
