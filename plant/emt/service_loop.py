"""The plant service's core on the EMT backend with the SDC's law in the same process: the loop a
network run closes, without the network (tests/unit/test_emt_service.py, benchmarks/emt_service_speed.py).

:func:`emt_core` builds :class:`plant.service.core.PlantCore` on ``plant.model: emt`` exactly as the
service does (:func:`plant.service.model.build_model`); :func:`sdc_loop` answers every MEAS datagram with
a CTRL datagram from the SDC's discretised law (:class:`sdc_unit.discrete.DiscreteVisc`, Tustin, the
SDC's method), both through the GTNET-SKT wire encoding, the CTRL received before the plant's next step
(the paper's one-sample loop) or ``extra_delay`` steps later.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from plant.service.core import PlantCore
from plant.service.model import build_model
from sdc_unit.discrete import DiscreteVisc
from sdvisc import wire
from sdvisc.config import PlantConfig
from sdvisc.vocabulary import MEAS_FIELDS

VIP, SDC = "10.0.0.254", "10.0.0.21"
WIDS = {"wt6_1": 601, "wt1_1": 101}
"""The onshore unit (the EMT arrangement's SDViSC) and one farm turbine (aggregated: no converter)."""
CTRL_VALUES = ("v_ref_d", "v_ref_q", "i_ref_d", "i_ref_q", "delta", "omega", "e_mag")


def emt_core(remote_apply: str = "v_ref", step_s: float = 0.67e-3, duration_s: float = 3.0) -> PlantCore:
    """A plant core on ``plant.model: emt`` with the endpoints of :data:`WIDS` (call
    ``plant.backend.close_backend(core.model)`` when done)."""
    cfg = PlantConfig(duration_s=duration_s, turbines=[{"name": n, "wid": w, "ip": f"10.0.1.{i + 1}"}
                                                       for i, (n, w) in enumerate(WIDS.items())],
                      out_dir="unused", step_s=step_s, controller_vip=VIP, model="emt", onshore_units=1,
                      remote_apply=remote_apply, p_star={"wt6_1": 0.0})
    model, indices = build_model(cfg, [t.name for t in cfg.turbines])
    return PlantCore(cfg, model, indices)


def request(cmd, wid: int) -> bytes:
    """The SDN application's REQUEST ``cmd`` (STREAM_START/STOP) for turbine ``wid``, naming the SDC."""
    values = {"req_id": 1, "cmd": int(cmd), "wt": wid, "sdc_ip": wire.ip_to_i32(SDC), "mask": 0, "h": 0.0, "d": 0.0,
              "m_q": 0.0, "v_ref": 0.0, "q_ref": 0.0, "supp": 0}
    return wire.encode(wire.MsgType.REQUEST, values, header=wire.Header(1, 2, 3))


def start_stream(core: PlantCore, name: str = "wt6_1") -> None:
    """STREAM_START for ``name`` from the SDN application's address."""
    ep = next(e for e in core.endpoints if e.name == name)
    core.receive(ep, request(wire.Command.STREAM_START, WIDS[name]), (VIP, wire.PORT_CONTROLLER), core.k * core.step_s)


def sdc_loop(core: PlantCore, seconds: float, extra_delay: int = 0, fault: dict | None = None,
             late_steps: range = range(0)) -> np.ndarray:
    """Run ``seconds`` with the SDC's law answering the first streaming endpoint, each CTRL received
    ``extra_delay`` steps late, one more during ``late_steps`` (step indices: a stall); ``fault``: step
    index -> on/off. Returns |v| at the unit's terminal after each step."""
    ep = core.streaming[0]
    ts = core.step_s
    law = None
    pending, v = [], []
    for k in range(int(round(seconds / ts))):
        now = core.k * ts
        if fault is not None and k in fault:
            core.apply_event({"type": "fault", "on": fault[k]})
        while len(pending) > extra_delay + (k in late_steps):  # after a stall, the held ones at once
            core.receive(ep, pending.pop(0), (SDC, wire.PORT_SDC), now)
        for _, data, _addr in core.step(now + ts):
            msg = wire.decode(data, header=True)
            if msg.type != wire.MsgType.MEAS:
                continue
            meas = SimpleNamespace(**{f: np.array([msg[f]]) for f in MEAS_FIELDS})
            if law is None:  # START_INSTANCE: the SDC's law from the first MEAS
                law = DiscreteVisc(1, core.model.op.visc_params, ts=ts, method="tustin")
                law.initialise(np.arange(1), meas)
            o = law.step(meas)
            values = {"wt": msg["wt"], "seq": msg["seq"], "meas_seq": msg["seq"], "flags": 0,
                      **{f: float(getattr(o, f)[0]) for f in CTRL_VALUES}}
            pending.append(wire.encode(wire.MsgType.CTRL, values, header=wire.Header(msg["seq"], int(now), 0)))
        v.append(abs(core.model.v_t))
    return np.array(v)
