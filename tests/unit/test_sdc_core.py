"""The SDC service's core (sdc_unit.core.SdcCore) driven with datagrams and an injected ``now``: no
socket, no thread, no clock. What it hands back is what the service sends."""

from __future__ import annotations

import ast
import inspect
import math

import pytest

import sdc_unit.core
from sdc_unit.answer import FLAG_BACKUP, ctrl_bytes
from sdc_unit.core import SdcCore
from sdvisc import wire
from sdvisc.config import SdcConfig

TS = 0.00067
SDN_APP = ("127.0.0.2", wire.PORT_CONTROLLER)
TURBINE = ("10.0.1.1", 40000)


def core(tmp_path, **cfg) -> SdcCore:
    return SdcCore(SdcConfig(step_s=TS, controller_vip=SDN_APP[0], capacity=4, out_dir=str(tmp_path), **cfg))


def meas(wt: int, seq: int, t_sim: float | None = None, **changes) -> bytes:
    values = {"wt": wt, "seq": seq, "t_sim": seq * TS if t_sim is None else t_sim,
              "v_d": 1.0 + 0.01 * math.sin(seq / 7), "v_q": 0.05, "i_d": 0.5, "i_q": -0.1, "p": 0.5, "q": 0.1,
              "v_dc": 1.0, "omega_meas": 1.0}
    values.update(changes)
    return wire.encode(wire.MsgType.MEAS, values, header=wire.Header(seq, 50, 0))


def request(cmd: wire.Command, wt: int, req_id: int = 1) -> bytes:
    values = {"req_id": req_id, "cmd": int(cmd), "wt": wt, "sdc_ip": 0, "mask": 0, "h": 0.0, "d": 0.0, "m_q": 0.0,
              "v_ref": 0.0, "q_ref": 0.0, "supp": 0}
    return wire.encode(wire.MsgType.REQUEST, values, header=wire.Header(req_id, 0, 0))


def decoded(out) -> list[wire.Message]:
    return [wire.decode(data, header=True) for data, _, _ in out.sends]


def ctrls(out) -> list[wire.Message]:
    return [m for m in decoded(out) if m.type == wire.MsgType.CTRL]


def started(tmp_path, *wts: int, **cfg) -> SdcCore:
    c = core(tmp_path, **cfg)
    c.handle([(request(wire.Command.START_INSTANCE, wt, req_id=wt), SDN_APP) for wt in wts], 10.0)
    return c


def test_the_core_is_pure():
    tree = ast.parse(inspect.getsource(sdc_unit.core))
    imported = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    imported |= {n.module.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
    assert not imported & {"socket", "select", "threading", "time", "os", "signal", "selectors"}


def test_a_meas_is_answered_by_one_ctrl_stamped_now(tmp_path):
    c = core(tmp_path)
    out = c.handle([(request(wire.Command.START_INSTANCE, 101), SDN_APP)], 10.0)
    (reply,) = decoded(out)
    assert reply.type == wire.MsgType.REPLY and reply["status"] == wire.Status.OK and out.sends[0][1] == SDN_APP
    assert out.events == [{"t_wall": 10.0, "type": "sdc_command", "cmd": "START_INSTANCE", "wt": "wt1_1",
                           "status": "OK"}]
    out = c.handle([(meas(101, 1), TURBINE)], 12.25)
    (data, addr, owner), = out.sends
    msg = wire.decode(data, header=True)
    assert msg.type == wire.MsgType.CTRL and (msg["wt"], msg["seq"], msg["meas_seq"]) == (101, 1, 1)
    assert addr == TURBINE and owner is c.instances[101]  # to the MEAS's source, ip and port
    assert (msg.header.seq, msg.header.sec, msg.header.nsec) == (1, 12, 250_000_000)
    # bumpless start: the first output is the converter voltage the turbine applies
    assert msg["v_ref_d"] == pytest.approx(1.0 + 0.003 * 0.5 + 0.08 * 0.1, abs=2e-3)
    counts = c.instances[101].counts
    assert (counts["meas_rx"], counts["ctrl_tx"]) == (1, 1)
    assert c.instances[101].meas_delays_ms == [pytest.approx((12.25 - 50.0) * 1e3)]  # read at now, sent at 50 s


def test_duplicate_and_stale_samples_are_dropped_and_counted(tmp_path):
    c = started(tmp_path, 101)
    assert [m["meas_seq"] for m in ctrls(c.handle([(meas(101, s), TURBINE) for s in (1, 2, 3)], 11.0))] == [1, 2, 3]
    out = c.handle([(meas(101, 3), TURBINE), (meas(101, 2), TURBINE), (meas(101, 4), TURBINE)], 11.1)
    assert [m["meas_seq"] for m in ctrls(out)] == [4]
    assert c.instances[101].counts["meas_stale"] == 2 and c.rejected["stale"] == 2
    out = c.handle([(meas(101, 2**31 - 1, t_sim=5 * TS), TURBINE), (meas(101, 7), TURBINE)], 11.2)  # altered seq
    assert [m["meas_seq"] for m in ctrls(out)] == [7]
    assert c.rejected["inconsistent"] == 1 and c.instances[101].counts["meas_lost"] == 2  # 5 and 6


def test_a_malformed_datagram_is_counted_and_never_applied(tmp_path):
    c = started(tmp_path, 101)
    c.handle([(meas(101, 1), TURBINE)], 11.0)
    nan = meas(101, 2)
    nan = nan[:28] + bytes.fromhex("7fc00000") + nan[32:]  # v_d = NaN
    out = c.handle([(nan, TURBINE), (meas(101, 3)[:-4], TURBINE), (b"\x00" * 10, TURBINE),
                    (meas(101, 4, i_d=500.0), TURBINE), (meas(7, 2), TURBINE)], 11.1)
    assert out.sends == []
    assert (c.rx_stats.nonfinite, c.rx_stats.length) == (1, 2)
    assert c.rejected["out_of_range"] == 1 and c.rejected["unknown_turbine"] == 1
    inst = c.instances[101]
    assert inst.gate.last_seq == 1 and inst.counts["meas_rx"] == 1 and c.ctrl_seq[inst.slot] == 1
    assert [m["seq"] for m in ctrls(c.handle([(meas(101, 2), TURBINE)], 11.2))] == [2]  # the stream goes on


def test_start_and_stop_requests(tmp_path):
    c = started(tmp_path, 101)
    c.handle([(meas(101, 1), TURBINE)], 11.0)
    out = c.handle([(request(wire.Command.STOP_INSTANCE, 101, req_id=5), SDN_APP), (meas(101, 2), TURBINE)], 11.1)
    (reply,) = decoded(out)
    assert reply.type == wire.MsgType.REPLY and reply["req_id"] == 5 and reply["status"] == wire.Status.OK
    assert not c.instances[101].active and c.instances[101].counts["meas_inactive"] == 1
    assert [e["cmd"] for e in out.events] == ["STOP_INSTANCE"]
    out = c.handle([(request(wire.Command.STOP_INSTANCE, 101), TURBINE)], 11.2)  # not from the SDN app
    assert out.sends == [] and c.rejected["not_controller"] == 1
    out = c.handle([(request(wire.Command.START_INSTANCE, 101, req_id=6), SDN_APP), (meas(101, 40), TURBINE)], 11.3)
    assert [m.type for m in decoded(out)] == [wire.MsgType.REPLY, wire.MsgType.CTRL]  # a new stream: any seq
    assert ctrls(out)[0]["seq"] == 2  # the CTRL numbering goes on


def test_a_command_is_carried_out_where_it_was_read(tmp_path):
    c = started(tmp_path, 101, 102)
    out = c.handle([(meas(101, 1), TURBINE), (meas(102, 1), TURBINE),
                    (request(wire.Command.STOP_INSTANCE, 102, req_id=9), SDN_APP), (meas(102, 2), TURBINE),
                    (meas(101, 2), TURBINE)], 11.0)
    assert [(m.type, m["wt"]) for m in decoded(out)] == [
        (wire.MsgType.CTRL, 101), (wire.MsgType.CTRL, 102), (wire.MsgType.REPLY, 102), (wire.MsgType.CTRL, 101)]


def test_a_backup_follows_mirrored_samples_and_answers_only_after_takeover(tmp_path):
    c = core(tmp_path, role="backup")
    out = c.handle([(meas(101, s), TURBINE) for s in range(1, 6)], 11.0)
    assert out.sends == [] and c.instances[101].counts["meas_tracked"] == 5 and not c.instances[101].active
    out = c.handle([(request(wire.Command.TAKEOVER, 101, req_id=3), SDN_APP)], 11.1)
    assert [m["status"] for m in decoded(out)] == [wire.Status.OK]
    (ctrl,) = ctrls(c.handle([(meas(101, 6), TURBINE)], 11.2))
    assert ctrl["meas_seq"] == 6 and ctrl["flags"] & FLAG_BACKUP
    assert c.instances[101].counts["takeover_warm"] == 0  # standby "latest": initialised at take-over


def test_several_samples_of_one_turbine_in_one_call_give_ctrls_in_order(tmp_path):
    c = started(tmp_path, 101)
    out = c.handle([(meas(101, s), TURBINE) for s in range(1, 9)], 11.0)
    assert [(m["seq"], m["meas_seq"]) for m in ctrls(out)] == [(s, s) for s in range(1, 9)]
    assert c.instances[101].counts["ctrl_tx"] == 8


def test_the_answers_do_not_depend_on_how_the_samples_were_batched(tmp_path):
    stream = [(meas(wt, s, v_d=0.2 if 20 <= s < 30 else 1.0), TURBINE) for s in range(1, 60) for wt in (101, 102)]
    one = started(tmp_path, 101, 102)
    single = [d for pair in stream for d, _, _ in one.handle([pair], 11.0).sends]
    many = started(tmp_path, 101, 102)
    batched = [d for k in range(0, len(stream), 7) for d, _, _ in many.handle(stream[k:k + 7], 11.0).sends]
    assert single == batched and len(single) == len(stream)
    assert all(len(d) == ctrl_bytes(True) for d in single)


def test_heartbeat_content_and_the_streaming_count(tmp_path):
    c = started(tmp_path, 101, 102)
    data, addr = c.heartbeat(1234.5)
    hb = wire.decode(data, header=True)
    assert addr == SDN_APP and (hb["sdc_id"], hb["seq"], hb["n_instances"]) == (1, 1, 2)
    assert hb["t_wall"] == pytest.approx(1234.5) and wire.decode(c.heartbeat(1235.0)[0], header=True)["seq"] == 2
    c.handle([(meas(101, 1), TURBINE), (meas(102, 1), TURBINE)], 20.0, read_at=[20.0, 20.0 - 10 * TS])
    assert c.streaming(20.0) == 1 and c.streaming(20.0 - 9 * TS) == 2


def test_a_failed_send_is_moved_from_sent_to_errors(tmp_path):
    c = started(tmp_path, 101)
    out = c.handle([(meas(101, 1), TURBINE)], 11.0)
    c.send_failed(out.sends[0][2])
    c.send_failed(None)
    assert c.instances[101].counts["ctrl_tx"] == 0 and c.instances[101].counts["ctrl_tx_error"] == 1
    assert c.rejected["reply_tx_error"] == 1
    assert c.summary()["turbines"]["wt1_1"]["ctrl_tx_error"] == 1


def test_an_unexpected_error_is_counted_reported_once_and_the_core_goes_on(tmp_path, monkeypatch):
    c = started(tmp_path, 101)

    def broken(*_args, **_kwargs):
        raise RuntimeError("boom")

    monkeypatch.setattr(c.bank, "answer_datagrams", broken)
    first = c.handle([(meas(101, 1), TURBINE)], 11.0)
    second = c.handle([(meas(101, 2), TURBINE)], 11.1)
    assert first.sends == second.sends == [] and c.rejected["internal"] == 2
    assert len(first.log) == 1 and "boom" in first.log[0] and "unexpected error in round" in first.log[0]
    assert second.log == []  # once per place
    monkeypatch.undo()
    assert [m["meas_seq"] for m in ctrls(c.handle([(meas(101, 3), TURBINE)], 11.2))] == [3]
