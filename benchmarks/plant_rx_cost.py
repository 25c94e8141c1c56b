"""CPU per plant-service step around the model, without sockets: the plant service's pure core
(:class:`plant.service.core.PlantCore`, full 50-turbine farm, every turbine streaming as after
all_visc_50's requests) receives one CTRL per turbine (``receive``: decode, checks, bookkeeping) and
steps (``step``: the CTRLs applied, the model, every MEAS packed, the AKs due). Process CPU over
``STEPS`` steps after ``WARM_UP``; one JSON line. For before/after pairs with farm-bench:

    farm-bench -n 6 --timeout 300 \\
      --vs "sh -c 'exec .venv/bin/python benchmarks/plant_rx_cost.py OLD_CHECKOUT >>/tmp/b.txt'" \\
      -- sh -c 'exec .venv/bin/python benchmarks/plant_rx_cost.py . >>/tmp/a.txt'

Usage: python benchmarks/plant_rx_cost.py [CHECKOUT]
"""

from __future__ import annotations

import json
import os
import sys
import time

STEPS, WARM_UP = 2000, 300
STEP_S = 2e-3 / 3  # the scenarios' Ts
SDC_IP = "10.0.0.21"


def main(checkout: str) -> None:
    sys.path.insert(0, checkout)  # the checkout whose plant core is measured
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    from plant.service.core import PlantCore
    from plant.service.model import build_model
    from sdvisc import wire
    from sdvisc.config import PlantConfig

    names = [f"wt{c}_{n}" for c in range(1, 6) for n in range(1, 11)]
    turbines = [{"name": nm, "wid": wire.turbine_id(*wire.parse_turbine(nm)), "ip": f"10.0.{i // 10 + 1}.{i % 10 + 1}",
                 "pid": None} for i, nm in enumerate(names)]
    cfg = PlantConfig(model="full", step_s=STEP_S, controller_vip="10.0.0.254", out_dir="/tmp", duration_s=None,
                      turbines=turbines, remote_apply="v_ref")
    model, indices = build_model(cfg, names)
    core = PlantCore(cfg, model, indices)
    vip = (cfg.controller_vip, wire.PORT_CONTROLLER)
    blank = dict.fromkeys(wire.field_names(wire.MsgType.REQUEST), 0)
    sdc_word = int.from_bytes(bytes(int(b) for b in SDC_IP.split(".")), "big", signed=True)
    for ep in core.endpoints:  # STREAM_START from the SDN app, as in a run
        req = {**blank, "req_id": 1, "cmd": int(wire.Command.STREAM_START), "wt": ep.wid, "sdc_ip": sdc_word}
        core.receive(ep, wire.encode(wire.MsgType.REQUEST, req, header=wire.Header(1, 0, 0)), vip, 0.0)
    ctrl_blank = dict.fromkeys(wire.field_names(wire.MsgType.CTRL), 0)
    src = (SDC_IP, wire.PORT_SDC)

    def answers(k: int, now: float) -> list:
        """Each turbine's CTRL answering its last MEAS (values near an operating point)."""
        return [(ep, wire.encode(wire.MsgType.CTRL, {**ctrl_blank, "wt": ep.wid, "seq": k, "meas_seq": ep.meas_seq,
                                                     "v_ref_d": 1.0, "v_ref_q": 0.1, "i_ref_d": 0.5, "e_mag": 1.0,
                                                     "omega": 1.0}, header=wire.Header.at(k, now)))
                for ep in core.endpoints]

    cpu = 0.0
    for k in range(WARM_UP + STEPS):
        now = (k + 1) * STEP_S
        feeds = answers(k, now)
        t0 = time.process_time()
        for ep, data in feeds:
            core.receive(ep, data, src, now)
        core.step(now)
        if k >= WARM_UP:
            cpu += time.process_time() - t0
    applied = sum(ep.counts["ctrl_rx"] for ep in core.endpoints)
    print(json.dumps({"turbines": len(names), "cpu_us_per_step": round(cpu / STEPS * 1e6, 1),
                      "ctrl_applied": applied, "meas_sent": sum(ep.counts["meas_tx"] for ep in core.endpoints),
                      "load": os.getloadavg()[0]}))


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
