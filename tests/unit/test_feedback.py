"""The interactive session's feedback (scenarios.feedback) on event lists, the event tail
(scenarios.live.EventTail) on files written piecewise, and the live view's pure parts
(scenarios.web: layout, snapshot, who may connect)."""

from __future__ import annotations

import json

import pytest

from scenarios.feedback import Feedback, event_line, progress_line, watch_line
from scenarios.live import EventTail, check_open_ended
from scenarios.processes import RunError
from scenarios.web import _is_loopback, layout, snapshot

OLD = ["sdc1", "s1", "s3", "l2", "wt1_1"]
NEW = ["sdc1", "s1", "s4", "l2", "wt1_1"]


def cli_link_down(t):
    return {"t": t, "t_effective": t, "source": "cli", "type": "link_down", "a": "s1", "b": "s3"}


def test_a_link_failure_reads_as_one_line_from_loss_to_restoration():
    fb = Feedback()
    assert fb.feed([cli_link_down(14.80)], 14.80) == []  # the CLI printed the action itself
    lines = fb.feed([{"t": 14.803, "source": "sdn_app", "type": "link_down", "link": ["s1", "s3"], "switch": "s1", "port": 3}],
                    14.81)
    assert lines == ["link s1-s3: down, seen by the SDN app at 14.80 s (port status)"]
    # the DR arrives before the plant's loss report (they come from different files)
    lines = fb.feed([{"t": 14.85, "source": "sdn_app", "type": "dr", "wt": "wt1_1", "t_loss": 14.806,
                      "old_path": OLD, "new_path": NEW},
                     {"t": 14.83, "source": "plant", "type": "ctrl_lost", "wt": "wt1_1", "t_loss": 14.81}], 14.86)
    assert lines == []  # nothing to say until it is over
    lines = fb.feed([{"t": 14.863, "source": "plant", "type": "ctrl_restored", "wt": "wt1_1", "t_loss": 14.81,
                      "gap_ms": 53.0}], 14.9)
    assert lines == ["wt1_1: control lost at 14.81 s; DR at 14.85 s; new path sdc1-s1-s4-l2-wt1_1; "
                     "restored after 63 ms (link s1-s3 down at 14.80 s)"]
    assert fb.feed([], 16.0) == []  # the action caused a loss: no "nothing happened" line later


def test_a_loss_nothing_repairs_is_reported_open_then_closed():
    fb = Feedback(follow_s=2.0)
    fb.feed([cli_link_down(5.0), {"t": 5.03, "source": "plant", "type": "ctrl_lost", "wt": "wt1_1", "t_loss": 5.0}], 5.05)
    assert fb.feed([{"t": 5.045, "source": "sdn_app", "type": "dr_not_acted", "wt": "wt1_1", "t_loss": 5.0,
                     "reason": "dynamic routing off"}], 6.0) == []
    lines = fb.feed([], 7.01)
    assert lines == ["wt1_1: control lost at 5.00 s; DR at 5.04 s not acted on (dynamic routing off); not restored 2.0 s later"]
    assert fb.feed([], 9.0) == []  # said once
    lines = fb.feed([{"t": 12.5, "source": "plant", "type": "ctrl_restored", "wt": "wt1_1", "t_loss": 5.0, "gap_ms": 7500}],
                    12.6)
    assert lines == ["wt1_1: control restored at 12.50 s, 7.50 s after it was lost"]


def test_a_dr_on_missing_acknowledgements_without_a_loss_at_the_turbine_is_not_called_a_loss():
    # seen in a test on a busy machine: the AKs stopped, DR rerouted hitlessly before the link was cut,
    # the plant never saw a pause of 20 ms; this must not read "control lost ... not restored"
    fb = Feedback(follow_s=2.0, quiet_s=0.5)
    fb.feed([{"t": 2.693, "source": "sdn_app", "type": "dr", "wt": "wt1_1", "t_loss": 2.652,
              "old_path": OLD, "new_path": NEW}], 2.70)
    fb.feed([cli_link_down(2.696)], 2.70)
    assert fb.feed([], 3.1) == []  # the plant could still report the loss
    assert fb.feed([], 3.2) == [
        "wt1_1: acknowledgements missing from 2.65 s; DR at 2.69 s; new path sdc1-s1-s4-l2-wt1_1; its control "
        "packets did not stop (no pause of 20 ms or more at the turbine)",
        "link s1-s3 down: no ViSC turbine lost its control packets in the 0.5 s after it"]
    assert fb.feed([], 5.0) == []  # said once, never "not restored"
    assert fb.losses == {}


def test_a_dr_whose_loss_the_plant_reports_late_is_still_followed_to_its_restoration():
    fb = Feedback(follow_s=2.0, quiet_s=0.5)
    fb.feed([{"t": 4.04, "source": "sdn_app", "type": "dr", "wt": "wt1_1", "t_loss": 4.0,
              "old_path": OLD, "new_path": NEW}], 4.05)
    fb.feed([{"t": 4.3, "source": "plant", "type": "ctrl_lost", "wt": "wt1_1", "t_loss": 4.001}], 4.3)
    assert fb.feed([], 4.8) == []  # the plant saw it: no "did not stop" line
    assert fb.feed([{"t": 4.9, "source": "plant", "type": "ctrl_restored", "wt": "wt1_1", "t_loss": 4.001,
                     "gap_ms": 899.0}], 4.9) == [
        "wt1_1: control lost at 4.00 s; DR at 4.04 s; new path sdc1-s1-s4-l2-wt1_1; restored after 899 ms"]


def test_a_loss_while_no_sdn_app_runs_says_why_nothing_reacts():
    fb = Feedback(follow_s=2.0)
    assert fb.feed([{"t": 2.589, "source": "runner", "type": "no_controller"}], 2.6) == [
        "no SDN application running since 2.59 s: switches keep their flows, nothing reacts to failures"]
    fb.feed([cli_link_down(3.141), {"t": 3.172, "source": "plant", "type": "ctrl_lost", "wt": "wt1_1", "t_loss": 3.141}],
            3.2)
    assert fb.feed([], 5.2) == ["wt1_1: control lost at 3.14 s; no SDN application running to react; not restored 2.0 s later"]
    fb.feed([{"t": 6.0, "source": "runner", "type": "service_restarted", "process": "controller", "exit_code": -9,
              "restart": 1}], 6.0)
    fb.feed([{"t": 7.0, "source": "plant", "type": "ctrl_lost", "wt": "wt1_2", "t_loss": 6.97}], 7.0)
    assert fb.losses["wt1_2"].steps == []


def test_an_action_that_interrupts_nothing_says_so_after_quiet_s():
    fb = Feedback(quiet_s=0.5)
    fb.feed([{"t": 3.0, "t_effective": 3.0, "source": "cli", "type": "link_down", "a": "s2", "b": "s3"}], 3.0)
    assert fb.feed([], 3.4) == []
    assert fb.feed([], 3.51) == ["link s2-s3 down: no ViSC turbine lost its control packets in the 0.5 s after it"]
    assert fb.feed([], 5.0) == []


def test_timeline_actions_are_announced_cli_actions_are_not():
    fb = Feedback()
    assert fb.feed([{"t": 2.0, "source": "timeline", "type": "kill", "host": "sdc1", "process": "sdc", "crash": False}],
                   2.0) == ["t=2.000 s: timeline: kill sdc on sdc1"]
    assert fb.feed([{"t": 2.0, "source": "cli", "type": "visc_on", "wt": "wt1_2"}], 2.0) == []


def test_visc_on_is_followed_to_the_first_control_packet():
    fb = Feedback()
    fb.feed([{"t": 1.0, "source": "cli", "type": "visc_on", "wt": "wt1_1"}], 1.0)
    fb.feed([{"t": 1.002, "source": "sdn_app", "type": "visc_on", "wt": "wt1_1", "sdc": "sdc1", "path": OLD}], 1.003)
    lines = fb.feed([{"t": 1.004, "source": "plant", "type": "ctrl_started", "wt": "wt1_1", "after_ms": 1.3}], 1.01)
    assert lines == ["wt1_1: ViSC on via sdc1-s1-s3-l2-wt1_1 (SDC sdc1); first control packet at 1.00 s, "
                     "1 ms after its stream started"]
    assert fb.feed([], 10.0) == []


def test_refused_and_unanswered_requests():
    fb = Feedback(follow_s=2.0)
    fb.feed([{"t": 1.0, "source": "cli", "type": "visc_on", "wt": "wt1_2"}], 1.0)
    assert fb.feed([{"t": 1.01, "source": "sdn_app", "type": "request_refused", "wt": "wt1_2", "cmd": "VISC_ON",
                     "reason": "ViSC not enabled (T2 x/0)"}], 1.02) == [
        "wt1_2: VISC_ON refused by the SDN app at 1.01 s: ViSC not enabled (T2 x/0)"]
    assert fb.feed([], 5.0) == []
    fb.feed([{"t": 6.0, "source": "cli", "type": "visc_on", "wt": "wt1_1"}], 6.0)
    assert fb.feed([], 8.0) == ["wt1_1: visc_on asked at 6.00 s; no control packet 2.0 s later"]


def test_sdc_failover_after_a_kill():
    fb = Feedback()
    fb.feed([{"t": 2.0, "source": "cli", "type": "kill", "host": "sdc1", "process": "sdc", "crash": False}], 2.0)
    lines = fb.feed([{"t": 2.031, "source": "sdn_app", "type": "sdc_dead", "sdc": "sdc1", "turbines": ["wt1_1"]},
                     {"t": 2.031, "source": "sdn_app", "type": "sdc_failover", "sdc": "sdc1", "backup": "sdc2",
                      "turbines": ["wt1_1"], "t_loss": 2.0},
                     {"t": 2.036, "source": "plant", "type": "ctrl_restored", "wt": "wt1_1", "t_loss": 2.0005,
                      "gap_ms": 35.5}], 2.04)
    assert lines == ["sdc1: declared dead by the SDN app at 2.03 s (no heartbeat)",
                     "wt1_1: control lost at 2.00 s; SDC failover sdc1 -> sdc2 at 2.03 s; restored after 36 ms "
                     "(kill sdc on sdc1 at 2.00 s)"]


def test_a_pause_without_fault_or_reaction_is_called_what_it_is():
    fb = Feedback()
    lines = fb.feed([{"t": 24.527, "source": "plant", "type": "ctrl_restored", "wt": "wt1_1", "t_loss": 24.505,
                      "gap_ms": 22.1}], 24.6)
    assert lines == ["wt1_1: control packets paused 22 ms at 24.50 s (no fault, no SDN reaction: this machine was busy?)"]


def test_pauses_on_an_impaired_link_say_so_and_do_not_flood():
    fb = Feedback()
    fb.feed([{"t": 1.0, "source": "timeline", "type": "impair", "a": "s3", "b": "s1", "loss": 0.3}], 1.0)
    assert fb.feed([], 2.0) == ["link s3-s1 impair loss=0.3: no ViSC turbine lost its control packets in the 0.5 s after it"]

    def pause(t):
        return fb.feed([{"t": t + 0.025, "source": "plant", "type": "ctrl_restored", "wt": "wt1_1", "t_loss": t,
                         "gap_ms": 25.0}], t + 0.03)

    assert pause(3.0) == ["wt1_1: control packets paused 25 ms at 3.00 s (link s1-s3 impaired)"]
    assert pause(3.2) == [] and pause(3.5) == []
    assert pause(4.1) == ["wt1_1: control packets paused 25 ms at 4.10 s (link s1-s3 impaired); 2 more such pauses before"]
    fb.feed([{"t": 5.0, "source": "cli", "type": "clear_impairments", "a": "s1", "b": "s3"}], 5.0)
    assert pause(6.0) == ["wt1_1: control packets paused 25 ms at 6.00 s (no fault, no SDN reaction: this machine was busy?)"]


def test_shadow_decisions_of_a_slave_app_are_not_reported():
    fb = Feedback()
    assert fb.feed([{"t": 1.0, "source": "sdn_app2", "type": "link_down", "link": ["s1", "s3"], "shadow": True}], 1.0) == []


def test_impair_is_a_fault_action_with_its_settings():
    fb = Feedback(quiet_s=0.5)
    fb.feed([{"t": 4.0, "source": "cli", "type": "impair", "a": "s1", "b": "s3", "delay_ms": 5.0}], 4.0)
    assert fb.feed([], 4.6) == ["link s1-s3 impair delay_ms=5: no ViSC turbine lost its control packets in the 0.5 s after it"]
    fb.feed([{"t": 5.0, "source": "cli", "type": "impair", "a": "s1", "b": "s3",  # as scenarios.impairments records it
              "now": {"delay_ms": 5.0, "jitter_ms": 0.0, "loss": 0.5, "bw_mbps": None}},
             {"t": 5.004, "source": "plant", "type": "ctrl_restored", "wt": "wt1_1", "t_loss": 5.001, "gap_ms": 25.0}], 5.01)
    assert fb.feed([{"t": 5.2, "source": "plant", "type": "ctrl_restored", "wt": "wt1_1", "t_loss": 5.1, "gap_ms": 100.0}],
                   5.3) == ["wt1_1: control lost at 5.10 s; restored after 200 ms (link s1-s3 impair delay_ms=5 loss=0.5 at 5.00 s)"]


def test_event_line_and_watch_line():
    line = event_line({"t": 15.414, "source": "sdn_app", "type": "dr", "wt": "wt1_1", "new_path": NEW, "t_loss": 15.3718})
    assert line.split() == ["15.414", "s", "sdn_app", "dr", "wt=wt1_1", "new_path=sdc1-s1-s4-l2-wt1_1", "t_loss=15.37"]
    before = {"t_sim": 10.0, "turbines": {"wt1_1": {"streaming": True, "meas_tx": 1000, "ctrl_rx": 990}}}
    now = {"t_sim": 10.5, "turbines": {"wt1_1": {"streaming": True, "meas_tx": 1746, "ctrl_rx": 1736, "v": 1.0,
                                                 "q": 0.0123, "f_hz": 50.0, "ctrl_delay_ms": 0.52}}}
    tables = {"T2": {"wt1_1": "1/1"}, "T3": {"wt1_1": "1/1"}, "paths": {"wt1_1": {"path": NEW}}}
    text = watch_line("wt1_1", now, before, tables)
    for part in ("meas  1492/s", "ctrl  1492/s", "one-way 0.52 ms", "V=1.0000 Q=+0.0123 f=50.000 Hz", "T2 1/1 T3 1/1",
                 "path sdc1-s1-s4-l2-wt1_1"):
        assert part in text
    assert "not streaming" in watch_line("wt1_1", {"t_sim": 1, "turbines": {"wt1_1": {"streaming": False, "meas_tx": 0,
                                                                                    "ctrl_rx": 0}}}, None, {})
    assert watch_line("wt9_9", now, before, tables) == "wt9_9: not a turbine of this run"


def test_event_tail_reads_complete_lines_only_and_puts_times_on_the_scenario_axis(tmp_path):
    t0 = 1_000_000.0
    runner_events: list[dict] = [{"t": 2.0, "source": "cli", "type": "link_down", "a": "s1", "b": "s3"}]
    tail = EventTail(tmp_path, t0, runner_events)
    dr = {"t_wall": t0 + 2.05, "type": "dr", "wt": "wt1_1", "t_loss": t0 + 2.001, "t_detect": t0 + 2.05}
    with open(tmp_path / "sdn_events.jsonl", "w") as fh:
        fh.write(json.dumps(dr) + "\n" + '{"t_wall": 1000002.1, "type": "li')  # the second line is being written
    (tmp_path / "plant_events.jsonl").write_text(json.dumps({"t": 2.06, "type": "ctrl_restored", "wt": "wt1_1"}) + "\n")
    first = tail.read()
    assert [(e["t"], e["source"], e["type"]) for e in first] == [
        (2.0, "cli", "link_down"), (2.05, "sdn_app", "dr"), (2.06, "plant", "ctrl_restored")]
    assert first[1]["t_loss"] == pytest.approx(2.001) and first[1]["t_detect"] == pytest.approx(2.05)
    assert tail.read() == []
    with open(tmp_path / "sdn_events.jsonl", "a") as fh:
        fh.write('nk_up", "link": ["s1", "s3"]}\n')
    runner_events.append({"t": 2.2, "source": "cli", "type": "link_up", "a": "s1", "b": "s3"})
    assert [(e["t"], e["type"]) for e in tail.read()] == [(2.1, "link_up"), (2.2, "link_up")]


def test_an_open_ended_run_needs_the_cli():
    check_open_ended(None, cli=True)
    check_open_ended(3.0, cli=False)
    with pytest.raises(RunError, match="needs --cli"):
        check_open_ended(None, cli=False)


DESC = {"switches": {"s1": {"dpid": 1, "openflow": True}, "s2": {"dpid": 2, "openflow": True},
                     "l2": {"dpid": 256, "openflow": False}},
        "hosts": {"sdc1": {"role": "service", "switch": "s1"}, "wt1_1": {"role": "turbine", "switch": "l2"},
                  "wt1_2": {"role": "turbine", "switch": "l2"}},
        "links": [{"a": "s1", "b": "s2"}, {"a": "s2", "b": "l2"}]}


def test_layout_puts_services_on_top_switches_by_distance_and_turbines_below():
    lay = layout(DESC)
    y = {n: v["y"] for n, v in lay["nodes"].items()}
    assert y["sdc1"] < y["s1"] < y["s2"] < y["l2"] < y["wt1_1"] == y["wt1_2"]
    assert all(0 < v["x"] < 1 and 0 < v["y"] < 1 for v in lay["nodes"].values())
    assert ["s1", "s2"] in lay["links"] and ["l2", "wt1_1"] in lay["links"] and ["s1", "sdc1"] in lay["links"]


def test_snapshot_has_paths_down_links_and_rates_of_the_visc_turbines_only():
    prev = {"t_sim": 4.0, "turbines": {"wt1_1": {"streaming": True, "ctrl_rx": 100, "meas_tx": 100}}}
    status = {"t_sim": 4.1, "late_steps": 2, "turbines": {
        "wt1_1": {"streaming": True, "ctrl_rx": 250, "meas_tx": 250, "v": 1.0, "q": 0.01, "p": 0.5, "f_hz": 50.0},
        "wt1_2": {"streaming": False, "ctrl_rx": 0, "meas_tx": 0}}}
    sdn = {"tables": {"T1": {"wt1_1": {}}, "T2": {"wt1_1": "1/1"}, "T3": {"wt1_1": "1/1"},
                      "paths": {"wt1_1": {"path": NEW}}, "down_links": [["s3", "s1"]], "active_sdc": "sdc1"}}
    snap = snapshot(4.12, status, prev, sdn, {("s2", "s3")})
    assert snap["paths"] == {"wt1_1": NEW}
    assert snap["down_links"] == [["s1", "s3"], ["s2", "s3"]]
    assert list(snap["turbines"]) == ["wt1_1"] and snap["turbines"]["wt1_1"]["ctrl_per_s"] == pytest.approx(1500, rel=1e-6)
    json.dumps(snap)  # what the page receives


def test_only_loopback_clients_are_served():
    assert _is_loopback("127.0.0.1") and _is_loopback("::1") and _is_loopback("127.0.0.2")
    assert not _is_loopback("10.0.1.1") and not _is_loopback("192.168.1.5") and not _is_loopback("not an address")


def test_live_view_updates_carry_new_events_and_lines_once_and_the_history_on_connect():
    import threading

    from scenarios.web import LiveView

    statuses = iter([{"t_sim": t, "turbines": {"wt1_1": {"streaming": True, "ctrl_rx": int(1500 * t), "meas_tx": 0,
                                                         "v": 1.0, "q": 0.0, "f_hz": 50.0}}} for t in (1.0, 1.1, 1.2)])

    class Run:
        links_down: set = set()
        plant_status = staticmethod(lambda: next(statuses))
        sdn_state = staticmethod(dict)

    class Session:
        events = [{"t": 1.0, "type": "a"}, {"t": 1.05, "type": "b"}]
        lines = ["one"]
        ended = threading.Event()
        now = staticmethod(lambda: 1.2)

    view = LiveView(Run(), Session(), 0)  # not started: no thread, no socket served
    try:
        previous = None
        for _ in range(3):
            view.collect_once(previous)
            previous = view._last_status
        cursor = {"events": 0, "lines": 0}
        first = view.update(cursor, history=True)
        assert [p["t_sim"] for p in first["history"]] == [1.0, 1.1, 1.2]
        assert first["turbines"]["wt1_1"]["ctrl_per_s"] == pytest.approx(150 / 0.1)
        assert [e["type"] for e in first["events"]] == ["a", "b"] and first["lines"] == ["one"]
        Session.events.append({"t": 1.2, "type": "c"})
        second = view.update(cursor)
        assert "history" not in second and [e["type"] for e in second["events"]] == ["c"] and second["lines"] == []
    finally:
        view.server.server_close()


def test_session_options_of_sdvisc_run():
    """--duration goes through the scenario's checks (tests/unit/test_cli_overrides.py); what is
    left to _session_options: an open-ended run needs --cli, --web and --cli-duration only with it."""
    from argparse import Namespace

    from scenarios.cli import _overrides, _session_options
    from scenarios.loader import ScenarioError, load_scenario

    def opts(**kw):
        return Namespace(**{"duration": None, "cli": False, "cli_duration": None, "web": None, "time_scale": None, "plant": None,
                            "switch_ports": None, "switch_links": None, "cpu_split": None, "pcap": False, **kw})

    def load(o):
        return load_scenario(smoke, _overrides(o))

    smoke = "scenarios/smoke.yaml"  # timeline action at t = 1 s, duration 3 s
    o = opts(cli=True, duration=float("inf"), web=8765)
    sc = load(o)
    assert _session_options(o, sc) is None and sc.duration_s is None
    o = opts(duration=float("inf"))
    assert "needs --cli" in _session_options(o, load(o))
    with pytest.raises(ScenarioError, match="t=1.0 s is after duration_s=0.5"):
        load(opts(cli=True, duration=0.5))
    o = opts(web=8765)
    assert "(--cli)" in _session_options(o, load(o))
    o = opts(duration=10.0)
    sc = load(o)
    assert _session_options(o, sc) is None and sc.duration_s == 10.0


def test_progress_line_fills_the_bar_with_simulated_time_and_shows_the_counters():
    status = {"t_sim": 5.0, "late_steps": 3, "meas_tx": 7000, "ctrl_rx": 6990, "streaming": ["wt1_1", "wt2_3"]}
    line = progress_line(status, 10.0, width=20)
    assert line.startswith("[" + "#" * 10 + "." * 10 + "] t=  5.00/10.00 s")
    assert "late=3" in line and "meas_tx=7000" in line and "ctrl_rx=6990" in line and "visc=wt1_1,wt2_3" in line
    assert progress_line({"t_sim": 12.5}, 10.0, width=20).startswith("[" + "#" * 20 + "] t= 10.00/10.00 s")  # clipped
    before_start = progress_line({}, 10.0, width=20)
    assert before_start.startswith("[" + "." * 20 + "] t=  0.00") and "late=0" in before_start and "visc=-" in before_start
