"""Hostile traffic for the testbed's own ports: ``python -m host_tools.fuzz --config FILE``, run by the
scenario runner inside a Mininet host (timeline action ``fuzz``).

Every datagram is one of four kinds, drawn with a seeded generator so a run can be repeated:

* ``random``: random bytes of random length (0–1300);
* ``truncated``: a real message of the target's kind cut short or extended by a few bytes;
* ``bitflip``: a real message with 1–3 bits flipped anywhere (header, type word, ids, values);
* ``extreme``: a real message with one word replaced by INT32_MIN/MAX, 0, −1, NaN, ±Inf or the
  largest float32.

"Real messages" are what the target listens for, built with the testbed's own codec and the
sender's own identity where it has one (a turbine fuzzing its SDC uses its turbine id and a
current ``seq``/``t_sim``), so the mutations reach every check behind the decoder. The sender
writes what it sent (per target and kind) to ``fuzz_<name>.json`` in the run's directory.
"""

from __future__ import annotations

import argparse
import json
import random
import socket
import struct
import sys
import time
from pathlib import Path

from sdc_unit.params import ViscParams
from sdvisc import wire
from sdvisc.vocabulary import VISC_PARAMS, param_word

PARAM_TEMPLATE = {name: param_word(name, getattr(ViscParams(), name)) for name in VISC_PARAMS}
"""Plausible run-time parameter words of a REQUEST: the ViSC law's defaults."""
KINDS = ("random", "truncated", "bitflip", "extreme")
EXTREME_WORDS = (0x80000000, 0x7FFFFFFF, 0, 0xFFFFFFFF, 0x7FC00000, 0x7F800000, 0xFF800000, 0x7F7FFFFF)
TARGET_TYPES = {
    wire.PORT_SDC: (wire.MsgType.MEAS, wire.MsgType.REQUEST),
    wire.PORT_CONTROLLER: (wire.MsgType.AK, wire.MsgType.HEARTBEAT, wire.MsgType.REQUEST, wire.MsgType.REPLY),
    wire.PORT_TURBINE: (wire.MsgType.CTRL, wire.MsgType.REQUEST),
    wire.PORT_OWFCC: (wire.MsgType.REPLY,),
}


def template(mtype: wire.MsgType, wid: int, seq: int, t_sim: float, rng: random.Random) -> dict:
    """Plausible values of a ``mtype`` message for turbine ``wid`` around sample ``seq``."""
    if mtype == wire.MsgType.MEAS:
        return {"wt": wid, "seq": seq, "t_sim": t_sim, "v_d": 1.0, "v_q": 0.02, "i_d": 0.5, "i_q": -0.1, "p": 0.5,
                "q": 0.1, "v_dc": 1.0, "omega_meas": 1.0}
    if mtype == wire.MsgType.CTRL:
        return {"wt": wid, "seq": seq, "meas_seq": seq, "v_ref_d": 1.0, "v_ref_q": 0.05, "i_ref_d": 0.5,
                "i_ref_q": -0.1, "delta": 0.1, "omega": 1.0, "e_mag": 1.05, "flags": 0}
    if mtype == wire.MsgType.AK:
        return {"wt": wid, "seq": seq, "ak": rng.choice((0, 1)), "ctrl_rx": seq, "ctrl_age_ms": rng.uniform(0, 100)}
    if mtype == wire.MsgType.REQUEST:
        return {"req_id": rng.randint(1, 1000), "cmd": int(rng.choice(list(wire.Command))), "wt": wid,
                "sdc_ip": wire.ip_to_i32("10.0.0.21"), **PARAM_TEMPLATE, "mask": rng.randint(0, 2 ** len(PARAM_TEMPLATE) - 1)}
    if mtype == wire.MsgType.REPLY:
        return {"req_id": rng.randint(1, 1000), "status": 0, "wt": wid, "cmd": int(wire.Command.VISC_ON), "detail": 0}
    return {"sdc_id": rng.choice((1, 2)), "seq": seq, "n_instances": 1, "t_wall": 0.0}


def real_message(port: int, wid: int, seq: int, t_sim: float, rng: random.Random) -> bytes:
    mtype = rng.choice(TARGET_TYPES.get(port, tuple(wire.MsgType)))
    sec, nsec = divmod(time.time_ns(), 1_000_000_000)
    header = wire.Header(seq & wire.UINT32_MAX, sec & wire.UINT32_MAX, nsec)
    return wire.encode(mtype, template(mtype, wid, seq, t_sim, rng), header=header)


def mutate(kind: str, real: bytes, rng: random.Random) -> bytes:
    """One hostile datagram of ``kind`` made from the real message ``real``."""
    if kind == "random":
        return rng.randbytes(rng.randint(0, 1300))
    if kind == "truncated":
        cut = rng.randint(0, len(real) + 8)
        return real[:cut] if cut <= len(real) else real + rng.randbytes(cut - len(real))
    data = bytearray(real)
    if kind == "bitflip":
        for _ in range(rng.randint(1, 3)):
            bit = rng.randrange(len(data) * 8)
            data[bit // 8] ^= 1 << (bit % 8)
        return bytes(data)
    if kind == "extreme":
        word = rng.randrange(len(data) // 4)
        struct.pack_into(">I", data, 4 * word, rng.choice(EXTREME_WORDS))
        return bytes(data)
    raise ValueError(f"unknown fuzz kind {kind!r}")


def udp_sender(src_port: int | None):
    """(socket, sendto) for UDP datagrams from ``src_port`` (None: an ephemeral port). A given port is
    written into the UDP header of a raw socket, so the sender need not bind it: a turbine's port is
    held by the plant, and the switches carry a turbine's datagrams to its SDC only from that port
    (checksum 0: none, allowed over IPv4)."""
    if src_port is None:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        return sock, sock.sendto
    sock = socket.socket(socket.AF_INET, socket.SOCK_RAW, socket.IPPROTO_UDP)

    def sendto(data: bytes, addr: tuple[str, int]) -> None:
        sock.sendto(struct.pack(">HHHH", src_port, addr[1], 8 + len(data), 0) + data, (addr[0], 0))
    return sock, sendto


def run(cfg: dict) -> dict:
    """Send ``count`` datagrams spread evenly over ``duration_s`` to ``targets`` ([ip, port] pairs)."""
    rng = random.Random(cfg.get("seed", 1))
    targets = [tuple(t) for t in cfg["targets"]]
    count, duration = int(cfg["count"]), float(cfg["duration_s"])
    wid, step_s = int(cfg.get("wid", 101)), float(cfg.get("step_s", 0.00067))
    sock, sendto = udp_sender(cfg.get("src_port"))
    sent = {f"{ip}:{port}": dict.fromkeys(KINDS, 0) for ip, port in targets}
    errors = 0
    t_start = time.time()
    batch = max(1, count // max(1, int(duration * 200)))  # ~200 bursts per second
    for k in range(count):
        ip, port = targets[k % len(targets)]
        elapsed = time.time() - t_start
        seq = int(elapsed / step_s) + int(cfg.get("seq0", 0))
        kind = KINDS[rng.randrange(len(KINDS))]
        data = mutate(kind, real_message(port, wid, seq, seq * step_s, rng), rng)
        try:
            sendto(data, (ip, port))
            sent[f"{ip}:{port}"][kind] += 1
        except OSError:
            errors += 1
        if k % batch == batch - 1:
            wait = t_start + duration * (k + 1) / count - time.time()
            if wait > 0:
                time.sleep(wait)
    sock.close()
    return {"sent": sent, "total": count - errors, "send_errors": errors, "t_start": t_start,
            "t_end": time.time(), "seed": cfg.get("seed", 1)}


def spoof_ak(cfg: dict) -> dict:
    """Mode ``spoof_ak``: send ``count`` AK messages for turbine ``victim_wid`` (``ak`` 0 or 1) to
    the SDN app from this host, with the given Ethernet/IP source (this host's own, or the
    victim's), as raw frames on ``iface`` (scapy builds them). The AK counter continues from
    ``seq0`` (a forger that guessed the victim's counter well); ``ctrl_rx`` is the counter's value
    unless ``ctrl_rx`` is given."""
    from scapy.layers.inet import IP, UDP
    from scapy.layers.l2 import Ether

    count, duration = int(cfg["count"]), float(cfg["duration_s"])
    sock = socket.socket(socket.AF_PACKET, socket.SOCK_RAW)
    sock.bind((cfg["iface"], 0))
    t_start, sent = time.time(), 0
    for k in range(count):
        sec, nsec = divmod(time.time_ns(), 1_000_000_000)
        seq = int(cfg.get("seq0", 1)) + k
        payload = wire.encode(wire.MsgType.AK, {"wt": int(cfg["victim_wid"]), "seq": seq, "ak": int(cfg["ak"]),
                                                "ctrl_rx": seq if cfg.get("ctrl_rx") is None else int(cfg["ctrl_rx"]), "ctrl_age_ms": 0.5 if cfg["ak"] else 80.0},
                              header=wire.Header(seq, sec & wire.UINT32_MAX, nsec))
        frame = (Ether(src=cfg["src_mac"], dst=cfg["dst_mac"]) / IP(src=cfg["src_ip"], dst=cfg["dst_ip"])
                 / UDP(sport=wire.PORT_TURBINE, dport=wire.PORT_CONTROLLER) / payload)
        sock.send(bytes(frame))
        sent += 1
        wait = t_start + duration * (k + 1) / count - time.time()
        if wait > 0:
            time.sleep(wait)
    sock.close()
    return {"mode": "spoof_ak", "total": sent, "ak": int(cfg["ak"]), "src_ip": cfg["src_ip"],
            "src_mac": cfg["src_mac"], "t_start": t_start, "t_end": time.time()}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m host_tools.fuzz", description=__doc__.splitlines()[0])
    parser.add_argument("--config", required=True)
    args = parser.parse_args(argv)
    cfg = json.loads(Path(args.config).read_text())
    result = spoof_ak(cfg) if cfg.get("mode") == "spoof_ak" else run(cfg)
    Path(cfg["out"]).write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
