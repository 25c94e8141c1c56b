"""The OWFCC's receive path (owfcc.service.Owfcc.receive and _on_reply), without the network
(issue 13): a stand-in socket records what is sent and hands out queued datagrams."""

from __future__ import annotations

import json
import struct

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from owfcc.service import COMMANDS, RX_REASONS, Owfcc
from sdvisc import wire
from sdvisc.config import OwfccConfig

FUZZ = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                           HealthCheck.function_scoped_fixture])


class FakeSock:
    def __init__(self) -> None:
        self.sent: list[tuple[bytes, tuple]] = []
        self.queue: list = []

    def sendto(self, data: bytes, addr: tuple) -> None:
        self.sent.append((data, addr))

    def recvfrom(self, _n: int):
        if not self.queue:
            raise BlockingIOError
        item = self.queue.pop(0)
        if isinstance(item, BaseException):
            raise item
        return item, ("10.0.0.254", wire.PORT_CONTROLLER)


_opened: list[Owfcc] = []


def owfcc(tmp_path) -> Owfcc:
    o = Owfcc(OwfccConfig(controller_vip="10.0.0.254", out_dir=str(tmp_path)), sock=FakeSock())
    _opened.append(o)
    return o


@pytest.fixture(autouse=True)
def _close_logs():
    yield
    while _opened:
        _opened.pop().log.close()


def reply(req_id: int, status: int = wire.Status.OK, wt: int = 101, cmd: int = wire.Command.VISC_ON,
          header: bool = True) -> bytes:
    return wire.encode(wire.MsgType.REPLY, {"req_id": req_id, "status": int(status), "wt": wt, "cmd": int(cmd),
                                            "detail": 0}, header=wire.Header(req_id & wire.UINT32_MAX, 1, 2)
                       if header else None)


def rejections(o: Owfcc) -> dict[str, int]:
    return {k[len("rx_reject_"):]: n for k, n in o.counts.items() if k.startswith("rx_reject_") and n}


def events(tmp_path) -> list[dict]:
    return [json.loads(line) for line in (tmp_path / "owfcc_events.jsonl").read_text().splitlines()]


def test_the_reply_to_a_pending_request_completes_it(tmp_path):
    o = owfcc(tmp_path)
    o.submit({"cmd": "visc_on", "wt": "wt1_1"})
    assert 1 in o.pending and len(o.sock.sent) == 1
    event = o.receive(reply(1, wire.Status.NO_PATH), now=o.pending[1]["t_first"] + 0.004)
    assert event["status"] == "NO_PATH" and event["rtt_ms"] == pytest.approx(4.0, abs=1e-3) and event["tries"] == 1
    assert not o.pending and o.counts == {"replies_rx": 1, "replies_late": 0, "rx_rejected": 0}
    assert [e["type"] for e in events(tmp_path)] == ["owfcc_request", "owfcc_reply"]
    # the answer to a retry of the same request arrives late: counted, not a rejection
    assert o.receive(reply(1), now=0.0) is None
    assert o.counts == {"replies_rx": 1, "replies_late": 1, "rx_rejected": 0}


CASES = {
    "length": reply(1)[:-4],
    "type-no-header": reply(1, header=False),  # the wt word where msg_type should be
    "type": reply(1)[:12] + struct.pack(">i", 42) + reply(1)[16:],
    "range": reply(1)[:20] + struct.pack(">i", 99) + reply(1)[24:],  # status 99
    "nonfinite": wire.encode(wire.MsgType.HEARTBEAT, {"sdc_id": 1, "seq": 1, "n_instances": 0, "t_wall": 0.0},
                             header=wire.Header(1, 2, 3))[:-4] + struct.pack(">I", 0x7FC00000),
    "unexpected_type": wire.encode(wire.MsgType.AK, {"wt": 101, "seq": 1, "ak": 1, "ctrl_rx": 1, "ctrl_age_ms": 0.0},
                                   header=wire.Header(1, 2, 3)),
    "unknown_req_id": reply(7),
    "unknown_req_id-zero": reply(0),
    "unknown_req_id-min": reply(wire.INT32_MIN),
    "mismatch": reply(1, wt=102),
    "mismatch-cmd": reply(1, cmd=wire.Command.VISC_OFF),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_each_unexpected_datagram_is_counted_once_under_its_reason(tmp_path, case):
    o = owfcc(tmp_path)
    o.submit({"cmd": "visc_on", "wt": "wt1_1"})
    assert o.receive(CASES[case], now=0.0) is None
    reason = case.split("-")[0]
    assert rejections(o) == {reason: 1} and o.counts["rx_rejected"] == 1
    assert 1 in o.pending  # still waiting for the real answer, which completes it
    assert o.receive(reply(1), now=0.0)["status"] == "OK" and not o.pending
    wire_rejected = o.rx_stats.rejected
    assert wire_rejected == (1 if reason in wire.REJECT_REASONS else 0)


def test_on_reply_keeps_reading_after_an_internal_error_and_a_socket_error(tmp_path, capsys):
    o = owfcc(tmp_path)
    o.submit({"cmd": "visc_on", "wt": "wt1_1"})
    o.submit({"cmd": "visc_off", "wt": "wt1_2"})
    real_log = o._log

    def failing_log(**event):
        if event.get("req_id") == 1:
            raise OSError("disk full")
        real_log(**event)

    o._log = failing_log
    o.sock.queue += [reply(1), b"junk", reply(2, wt=102, cmd=wire.Command.VISC_OFF)]
    o._on_reply()
    assert rejections(o) == {"internal": 1, "length": 1} and o.counts["replies_rx"] == 2 and not o.pending
    assert capsys.readouterr().err.count("rx_reject_internal") == 1
    o.sock.queue += [ConnectionRefusedError(), reply(5)]
    o._on_reply()
    assert o.counts["rx_socket_error"] == 1
    o._on_reply()
    assert rejections(o) == {"internal": 1, "length": 1, "unknown_req_id": 1}
    stats = json.loads(json.dumps(o.stats()))
    assert stats["requests"] == 2 and stats["pending"] == 0 and stats["rx_rejected"] == 3
    assert stats["rx_wire"]["length"] == 1 and stats["rx_wire"]["ok"] == 3


# --- hypothesis ---------------------------------------------------------------------------------

req_ids = st.one_of(st.integers(-2, 8), st.integers(wire.INT32_MIN, wire.INT32_MAX))


@st.composite
def datagrams(draw) -> bytes:
    kind = draw(st.sampled_from(["reply", "reply", "bytes", "mutant", "other"]))
    if kind == "reply":
        # mostly plausible ids and commands (those the script submits), so that replies complete requests
        return reply(draw(st.one_of(st.integers(1, 6), req_ids)), draw(st.sampled_from(list(wire.Status))),
                     wt=draw(st.sampled_from([101, 101, 101, 102])),
                     cmd=draw(st.one_of(st.integers(1, 3), st.sampled_from(list(wire.Command)))))
    if kind == "bytes":
        return draw(st.binary(max_size=64))
    if kind == "other":
        return wire.encode(wire.MsgType.REQUEST, {"req_id": draw(req_ids), "cmd": 1, "wt": 101, "sdc_ip": 0, "mask": 0,
                                                  "h": 0.0, "d": 0.0, "m_q": 0.0, "v_ref": 0.0, "q_ref": 0.0,
                                                  "supp": 0}, header=wire.Header(1, 2, 3))
    buf = bytearray(reply(draw(st.integers(1, 4))))
    for _ in range(draw(st.integers(1, 5))):
        bit = draw(st.integers(0, 8 * len(buf) - 1))
        buf[bit // 8] ^= 1 << (bit % 8)
    return bytes(buf[:draw(st.integers(0, len(buf) + 4))])


@FUZZ
@given(st.lists(st.one_of(st.tuples(st.just("submit"), st.sampled_from(["visc_on", "visc_off", "set_params"])),
                          st.tuples(st.just("answer"), st.integers(1, 8)),  # the SDN app's (maybe repeated) answer
                          st.tuples(st.just("rx"), datagrams())), max_size=30))
def test_any_datagram_is_handled_and_counted_under_exactly_one_counter(tmp_path, script):
    o = owfcc(tmp_path)
    issued: dict[int, int] = {}
    for op, arg in script:
        if op == "submit":
            issued[o.next_id] = int(COMMANDS[arg])
            o.submit({"cmd": arg, "wt": "wt1_1"})
            continue
        if op == "answer":
            arg = reply(arg, cmd=issued.get(arg, 1))
        before, pending = dict(o.counts), dict(o.pending)
        logged = o.receive(arg, now=1.0)
        changed = {k: o.counts.get(k, 0) - before.get(k, 0) for k in o.counts}
        changed = {k: d for k, d in changed.items() if d}
        event_name = "rx_rejected " + "/".join(sorted(k for k in changed if k != "rx_rejected"))
        event(event_name if "rx_rejected" in changed else "/".join(changed))
        if logged is not None:
            assert changed == {"replies_rx": 1} and logged["req_id"] in pending
            assert set(pending) - set(o.pending) == {logged["req_id"]}
            assert logged["status"] in wire.Status.__members__
        else:
            assert o.pending == pending
            if changed != {"replies_late": 1}:
                assert changed.pop("rx_rejected") == 1
                ((key, n),) = changed.items()
                assert n == 1 and key[len("rx_reject_"):] in RX_REASONS and key != "rx_reject_internal"
    assert sum(rejections(o).values()) == o.counts["rx_rejected"]
    json.dumps(o.stats())
    _opened.pop().log.close()
