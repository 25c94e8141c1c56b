"""The project's GTNET-SKT card emulator (plant.card): its pure core driven with datagrams and
an injected ``now`` (no sockets), its configuration, and the program itself as a subprocess on
loopback for a fraction of a second. No root; no assertion on timing."""

from __future__ import annotations

import ast
import inspect
import json
import signal
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from plant.card import core as gtnet_card_core
from plant.card.core import CardCore, GtnetCardConfig
from plant.card.emulator import STATS_FILE, load_card_config, main
from sdvisc import wire
from sdvisc.config import ConfigError

ROOT = Path(__file__).resolve().parents[2]
VIP = "10.0.0.254"
SDC = "10.0.0.21"
FIXED = ("10.0.0.30", 41000)
STEP = 0.001
T0 = 1_800_000_000.25  # a run clock reading (s since the epoch)
TURBINES = [{"name": "wt1_1", "wid": 101, "port": 40101}, {"name": "wt1_2", "wid": 102, "port": 40102}]


def make_core(**overrides) -> CardCore:
    settings = {"step_s": STEP, "out_dir": "unused", "framing": "villas", "controller_vip": VIP,
                "turbines": TURBINES, "ak_window_s": 0.005, **overrides}
    return CardCore(GtnetCardConfig(**settings))


def header(core: CardCore, seq: int = 1) -> wire.Header | None:
    return wire.Header(seq, 0, 0) if core.header else None


def request(core: CardCore, cmd, wid: int = 101, sdc: str = SDC) -> bytes:
    values = {"req_id": 1, "cmd": int(cmd), "wt": wid, "sdc_ip": wire.ip_to_i32(sdc) if sdc else 0, "mask": 0,
              "h": 0.0, "d": 0.0, "m_q": 0.0, "v_ref": 0.0, "q_ref": 0.0, "supp": 0}
    return wire.encode(wire.MsgType.REQUEST, values, header=header(core))


def ctrl(core: CardCore, meas_seq: int, wid: int = 101, i_ref=(0.3, 0.2)) -> bytes:
    values = {"wt": wid, "seq": meas_seq, "meas_seq": meas_seq, "v_ref_d": 1.0, "v_ref_q": 0.05, "i_ref_d": i_ref[0],
              "i_ref_q": i_ref[1], "delta": 0.2, "omega": 1.0, "e_mag": 1.01, "flags": 0}
    return wire.encode(wire.MsgType.CTRL, values, header=header(core, meas_seq))


def start(core: CardCore, *indices: int, sdc: str = SDC) -> None:
    for i in indices or range(len(core.ports)):
        core.receive(i, request(core, wire.Command.STREAM_START, core.ports[i].wid, sdc), (VIP, 50000), T0)


def run(core: CardCore, steps: int, answer=lambda port, msg: True, source: str = SDC) -> list:
    """``steps`` steps; each MEAS is answered with a CTRL (from ``source``) where ``answer`` says so.
    Returns every datagram sent: (port index, kind, message, destination)."""
    sent = []
    for _ in range(steps):
        now = T0 + core.k * STEP
        out = core.step(now)
        for i, kind, data, addr in out:
            msg = wire.decode(data, header=core.header)
            sent.append((i, kind, msg, addr))
            if kind == "meas" and answer(i, msg):
                core.receive(i, ctrl(core, msg["seq"], msg["wt"]), (source, 40000), now + STEP / 2)
    return sent


def test_the_core_opens_no_socket_and_reads_no_clock():
    tree = ast.parse(inspect.getsource(gtnet_card_core))
    imported = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    imported |= {n.module.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
    assert not imported & {"socket", "select", "selectors", "threading", "time", "os", "subprocess"}


def test_stream_start_then_answers_give_full_meas_and_move_the_models_current():
    core = make_core()
    assert core.step(T0) == []  # nothing before STREAM_START
    start(core)
    i_before = core.model.i.copy()
    sent = run(core, 200)
    meas = [(i, m, addr) for i, kind, m, addr in sent if kind == "meas"]
    assert {i for i, _, _ in meas} == {0, 1}
    assert all(addr == (SDC, wire.PORT_SDC) for _, _, addr in meas)
    for _, m, _ in meas:
        assert set(m.values) == set(wire.field_names(wire.MsgType.MEAS))  # every point of the layout
    for i, wid in ((0, 101), (1, 102)):
        seqs = [m["seq"] for j, m, _ in meas if j == i]
        assert seqs == list(range(1, 201)) and all(m["wt"] == wid for j, m, _ in meas if j == i)
    summary = core.summary()
    for name in ("wt1_1", "wt1_2"):
        t = summary["turbines"][name]
        assert t["meas_tx"] == 200 and t["ctrl_rx"] == 200 and t["commands_rx"] == 1 and t["rejected_total"] == 0
        assert t["mode"] == "remote"
    assert abs(core.model.i[0] - (0.3 + 0.2j)) < 0.02 < 0.5 < abs(i_before[0] - (0.3 + 0.2j))  # the answers steer it
    aks = [(i, m, addr) for i, kind, m, addr in sent if kind == "ak"]
    assert aks and all(addr == (VIP, wire.PORT_CONTROLLER) for _, _, addr in aks)
    assert aks[-1][1]["ak"] == 1 and aks[-1][1]["ctrl_rx"] > 0
    assert summary["totals"]["meas_tx"] == 400 and summary["totals"]["ak_tx"] == len(aks)


def test_native_framing_is_exactly_the_words_of_the_layout():
    core = make_core(framing="native")
    start(core)
    out = core.step(T0)
    kinds = {kind for _, kind, _, _ in out}
    assert kinds == {"meas", "ak"}
    for _, kind, data, _ in out:
        mtype = wire.MsgType.MEAS if kind == "meas" else wire.MsgType.AK
        assert len(data) == 4 * wire.word_count(mtype, header=False) == 4 * len(wire.LAYOUTS[mtype])
        assert struct.unpack_from(">i", data)[0] == int(mtype)  # word 0: msg_type, no header
        wire.decode(data, header=False)


def test_villas_framing_puts_the_three_header_words_first():
    core = make_core(framing="villas")
    start(core)
    core.step(T0)
    now = T0 + STEP
    out = core.step(now)
    for _, kind, data, _ in out:
        mtype = wire.MsgType.MEAS if kind == "meas" else wire.MsgType.AK
        assert len(data) == 4 * wire.word_count(mtype, header=True) == 4 * (len(wire.LAYOUTS[mtype]) + 3)
        seq, sec, nsec, msg_type = struct.unpack_from(">IIIi", data)
        assert msg_type == int(mtype) and sec == int(now) and abs(sec + nsec * 1e-9 - now) < 1e-6
        if kind == "meas":
            assert seq == wire.decode(data, header=True)["seq"] == 2


def test_bad_input_is_dropped_and_counted_per_port_and_the_other_turbine_keeps_control():
    core = make_core(flood_limit_per_step=10)
    start(core)
    good = ctrl(core, 1)
    bad = {
        "length": good + b"\0\0\0\0",  # a word too many
        "type": struct.pack(">IIIi", 1, 0, 0, 99) + bytes(4 * 8),
        "unknown_turbine": ctrl(core, 1, wid=305),
        "wrong_turbine": ctrl(core, 1, wid=102),  # wt1_2's CTRL on wt1_1's port
        "unexpected_type": wire.encode(wire.MsgType.AK, {"wt": 101, "seq": 1, "ak": 1, "ctrl_rx": 0,
                                                         "ctrl_age_ms": 0.0}, header=header(core)),
        "future_seq": ctrl(core, 50),
    }

    def answer(i, msg):
        if i == 0 and msg["seq"] == 3:  # one step of junk on wt1_1's port
            for data in bad.values():
                core.receive(0, data, (SDC, 40000), T0)
            core.receive(0, ctrl(core, msg["seq"]), ("10.0.0.99", 40000), T0)  # a CTRL from a wrong source
        if i == 0 and msg["seq"] == 6:  # a flood: the limit's worth taken, the rest dropped
            for _ in range(15):
                core.receive(0, ctrl(core, msg["seq"]), (SDC, 40000), T0)
            return False
        return True

    run(core, 40, answer)
    summary = core.summary()
    first, second = summary["turbines"]["wt1_1"], summary["turbines"]["wt1_2"]
    expected = {reason: 1 for reason in bad} | {"not_from_sdc": 1, "flood": 5}
    assert first["rejected"] == expected and first["rejected_total"] == sum(expected.values())
    assert first["ctrl_rx"] == 40 and first["ctrl_stale"] == 9  # the flood's ten taken: one applied, nine stale
    assert second["rejected"] == {} and second["ctrl_rx"] == 40  # wt1_2 unaffected
    assert summary["totals"]["rejected"] == expected
    assert core.model.mode.tolist() == [1, 1]
    assert summary["wire"]["length"] == 1 and summary["wire"]["type"] == 1


def test_a_datagram_whose_handling_raises_is_counted_and_the_card_goes_on(monkeypatch):
    core = make_core()
    monkeypatch.setattr(core.model, "set_mode", lambda *_: 1 / 0)
    start(core, 0)
    core.receive(0, None, (VIP, 50000), T0)  # not even bytes
    assert core.summary()["turbines"]["wt1_1"]["rejected"] == {"internal": 2}
    assert core.summary()["internal_error"].startswith("ZeroDivisionError")
    assert core.step(T0) is not None


def test_requests_are_taken_only_from_the_controller_and_stop_ends_the_stream():
    core = make_core()
    core.receive(0, request(core, wire.Command.STREAM_START), ("10.0.0.99", 50000), T0)
    core.receive(0, request(core, wire.Command.VISC_ON), (VIP, 50000), T0)
    core.receive(0, request(core, wire.Command.STREAM_START, sdc="224.0.0.1"), (VIP, 50000), T0)
    core.receive(0, request(core, wire.Command.STREAM_START, sdc=""), (VIP, 50000), T0)  # 0: no fixed remote
    assert core.step(T0) == []
    assert core.summary()["turbines"]["wt1_1"]["rejected"] == {"not_from_controller": 1, "bad_request": 3}
    start(core, 0)
    assert {i for i, *_ in core.step(T0)} == {0}
    core.receive(0, request(core, wire.Command.STREAM_STOP), (VIP, 50000), T0)
    assert core.step(T0) == [] and core.model.mode[0] == 0
    assert core.summary()["turbines"]["wt1_1"]["commands_rx"] == 2


def test_a_fixed_remote_takes_its_port_and_always_streams_from_t0():
    core = make_core(sdc={"ip": FIXED[0], "port": FIXED[1]})
    start(core, 0, sdc=FIXED[0])  # names the fixed remote: its configured port
    start(core, 1, sdc="")  # names none: the fixed remote
    assert {addr for _, kind, _, addr in core.step(T0) if kind == "meas"} == {FIXED}

    always = make_core(sdc={"ip": FIXED[0], "port": FIXED[1]}, stream="always")
    assert always.model.mode.tolist() == [0, 0]
    sent = run(always, 5, answer=lambda i, msg: i == 0, source=FIXED[0])
    assert {(i, addr) for i, kind, _, addr in sent if kind == "meas"} == {(0, FIXED), (1, FIXED)}
    assert always.model.mode.tolist() == [1, 0]  # remote from its first answer on
    assert always.summary()["turbines"]["wt1_1"]["ctrl_rx"] == 5
    start(always, 0)  # redirected to the SDC it names ...
    assert [addr for i, kind, _, addr in always.step(T0) if kind == "meas" and i == 0] == [(SDC, wire.PORT_SDC)]
    always.receive(0, request(always, wire.Command.STREAM_STOP), (VIP, 50000), T0)  # ... and back: it never stops
    assert [addr for i, kind, _, addr in always.step(T0) if kind == "meas" and i == 0] == [FIXED]
    assert always.model.mode[0] == 0


@pytest.mark.parametrize("change, key", [
    ({"turbines": []}, "turbines"),
    ({"turbines": [{"name": "wt1_1", "wid": 101, "port": 70000}]}, "turbines.0.port"),
    ({"turbines": [{"name": "wt1_1", "wid": 102, "port": 1}]}, "turbines.0"),
    ({"turbines": [{"name": "wt1_1", "wid": 101, "port": 1}, {"name": "wt1_2", "wid": 102, "port": 1}]}, "turbines"),
    ({"framing": "gtnet"}, "framing"),
    ({"stream": "always"}, "sdc"),
    ({"sdc": {"ip": "not-an-ip"}}, "sdc.ip"),
    ({"step_s": 0}, "step_s"),
    ({"bogus": 1}, "bogus"),
])
def test_config_errors_name_the_file_and_the_key(tmp_path, change, key, capsys):
    settings = {"step_s": STEP, "out_dir": str(tmp_path), "turbines": TURBINES, **change}
    path = tmp_path / "card.yaml"
    path.write_text(yaml.safe_dump(settings))
    with pytest.raises(ConfigError) as error:
        load_card_config(path)
    assert str(path) in str(error.value) and key in str(error.value)
    assert main(["--config", str(path)]) == 2
    assert key in capsys.readouterr().err


def test_json_and_yaml_configs_give_the_same_model(tmp_path):
    settings = {"step_s": STEP, "out_dir": str(tmp_path), "turbines": TURBINES, "sdc": {"ip": FIXED[0]}}
    (tmp_path / "a.json").write_text(json.dumps(settings))
    (tmp_path / "a.yml").write_text(yaml.safe_dump(settings))
    cfg = load_card_config(tmp_path / "a.json")
    assert cfg == load_card_config(tmp_path / "a.yml")
    assert (cfg.framing, cfg.stream, cfg.time_scale, cfg.sdc.port) == ("native", "on_request", 1.0, wire.PORT_SDC)


def free_udp(ip: str = "127.0.0.1") -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind((ip, 0))
    sock.settimeout(0.05)
    return sock


def test_the_program_streams_on_loopback_and_writes_its_stats_on_sigterm(tmp_path):
    sdc, controller = free_udp(), free_udp()
    probes = [free_udp(), free_udp()]
    ports = [p.getsockname()[1] for p in probes]
    for p in probes:  # free ports for the card (a race with another process is unlikely)
        p.close()
    config = {"step_s": 0.002, "bind_ip": "127.0.0.1", "framing": "villas", "out_dir": str(tmp_path / "out"),
              "controller_vip": "127.0.0.1", "controller_port": controller.getsockname()[1],
              "sdc": {"ip": "127.0.0.1", "port": sdc.getsockname()[1]}, "flood_limit_per_step": 100_000,
              # (no flood drops: a test process held up on a busy machine answers a backlog at once)
              "turbines": [{"name": "wt1_1", "wid": 101, "port": ports[0]}, {"name": "wt1_2", "wid": 102, "port": ports[1]}]}
    path = tmp_path / "card.yaml"
    path.write_text(yaml.safe_dump(config))
    proc = subprocess.Popen([sys.executable, "-m", "plant.card.emulator", "--config", str(path)], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        ready = tmp_path / "out" / "gtnet_card_ready.json"
        deadline = time.monotonic() + 60
        while not ready.exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        assert ready.exists(), proc.stderr.read() if proc.poll() is not None else "no ready file"
        ready_info = json.loads(ready.read_text())
        assert ready_info["ports"] == {"wt1_1": ports[0], "wt1_2": ports[1]} and ready_info["t0_wall"] > 0
        core = make_core()  # only for its framing in request() / ctrl()
        for wid, port in zip((101, 102), ports):
            controller.sendto(request(core, wire.Command.STREAM_START, wid, "127.0.0.1"), ("127.0.0.1", port))
        controller.sendto(b"\x00\x01\x02", ("127.0.0.1", ports[0]))  # malformed: not whole words
        answered: dict[int, int] = {101: 0, 102: 0}
        first = None
        while time.monotonic() < deadline and proc.poll() is None:
            if first is not None and time.monotonic() - first > 0.3 and min(answered.values()) >= 5:
                break
            try:
                data, addr = sdc.recvfrom(2048)
            except TimeoutError:
                continue
            msg = wire.decode(data, header=True)
            first = first or time.monotonic()
            sdc.sendto(ctrl(core, msg["seq"], msg["wt"]), addr)
            answered[msg["wt"]] += 1
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=30) == 0, proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        for sock in (sdc, controller):
            sock.close()
    stats = json.loads((tmp_path / "out" / STATS_FILE).read_text())
    assert stats["framing"] == "villas" and stats["steps"] > 0
    for name in ("wt1_1", "wt1_2"):
        t = stats["turbines"][name]
        assert t["meas_tx"] > 0 and t["ctrl_rx"] > 0 and t["commands_rx"] == 1 and t["ak_tx"] > 0
    assert stats["turbines"]["wt1_1"]["rejected"] == {"length": 1}
    assert stats["totals"]["rejected"] == {"length": 1}
    status = json.loads((tmp_path / "out" / "gtnet_card_status.json").read_text())  # the run's progress line
    assert status["streaming"] == ["wt1_1", "wt1_2"] and 0 < status["meas_tx"] <= stats["totals"]["meas_tx"]


def test_a_misbehaving_card_sends_its_bursts_once_from_the_named_port_and_counts_them():
    """``misbehave``: a faulty card on purpose (plant.card.faults) — the bursts leave the named
    turbine's port toward its SDC at their step, each kind as documented, and are counted apart."""
    core = make_core(misbehave=[{"t_s": 0.005, "turbine": "wt1_2", "kind": "wrong_word_count", "count": 3},
                                {"t_s": 0.006, "turbine": "wt1_2", "kind": "unknown_turbine", "count": 2},
                                {"t_s": 0.007, "turbine": "wt1_1", "kind": "flood", "count": 50}])
    start(core)
    out = []
    for _ in range(10):
        out += [(core.k, *o) for o in core.step(T0 + core.k * STEP)]
    bad = [(k, i, data, addr) for k, i, kind, data, addr in out if kind == "bad"]
    meas_words = wire.word_count(wire.MsgType.MEAS, header=True)
    wrong = [b for b in bad if len(b[2]) == 4 * (meas_words + 1)]
    assert len(wrong) == 3 and {b[1] for b in wrong} == {1} and {b[3] for b in wrong} == {(SDC, wire.PORT_SDC)}
    unknown = [wire.decode(b[2], header=True) for b in bad if b not in wrong and b[1] == 1]
    assert len(unknown) == 2 and {m["wt"] for m in unknown} == {wire.turbine_id(49, 99)}
    flood = [wire.decode(b[2], header=True) for b in bad if b[1] == 0]
    assert len(flood) == 50 and {m["wt"] for m in flood} == {101}
    assert len({b[0] for b in bad}) == 3  # three steps, each burst once
    stats = core.summary()["turbines"]
    assert (stats["wt1_1"]["misbehaved_tx"], stats["wt1_2"]["misbehaved_tx"]) == (50, 5)
    assert stats["wt1_1"]["meas_tx"] == stats["wt1_2"]["meas_tx"] == 10  # the MEAS stream is not touched


def test_a_pause_in_the_answers_is_recorded_for_the_runs_recovery_times():
    """The summary's recoveries read the card's CTRL gaps (clock before, clock after) and its last CTRL,
    as the plant's: a pause of 20 steps gives one gap spanning it; the first/last CTRL times follow."""
    core = make_core()
    start(core)
    run(core, 10)
    run(core, 20, answer=lambda port, msg: port == 1)  # wt1_1 unanswered
    run(core, 10)
    stats = core.summary()["turbines"]
    (gap,) = stats["wt1_1"]["ctrl_gaps_wall"]
    assert gap[1] - gap[0] == pytest.approx(21 * STEP, abs=STEP / 2)
    assert stats["wt1_2"]["ctrl_gaps_wall"] == []
    assert stats["wt1_1"]["first_ctrl_rx_t"] == pytest.approx(1 * STEP)
    assert stats["wt1_1"]["last_ctrl_rx_t"] == pytest.approx(40 * STEP)  # card time after the step it answers
    assert stats["wt1_1"]["last_ctrl_wall"] == pytest.approx(T0 + 39 * STEP + STEP / 2)
