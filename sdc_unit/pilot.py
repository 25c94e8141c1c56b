"""The real SDC service for the time-scale calibration (``time_scale: auto``, scenarios/calibrate.py).

``python -m sdc_unit.pilot --config FILE --serve WID[,WID…] --ready FILE`` builds the
:class:`sdc_unit.service.SdcService` of the run's configuration, starts an instance for each turbine
id as a START_INSTANCE from the SDN app would (the app is not running yet during the calibration),
and serves MEAS → CTRL until SIGTERM. It then writes its CPU seconds and the service's summary to
the ready file. The calibration thus measures the SDC's real per-round work, not a model of it.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path

from sdc_unit.service import SdcService
from sdvisc import wire
from sdvisc.config import SdcConfig, load_config_or_exit
from sdvisc.jsonlines import write_json_atomic
from sdvisc.netns import raise_priority
from sdvisc.vocabulary import REQUEST_PARAM_WORDS


def start_request(wid: int, req_id: int, header: bool) -> wire.Message:
    """A START_INSTANCE for turbine ``wid`` with default ViSC parameters, as the SDN app sends it."""
    values = {"req_id": req_id, "cmd": int(wire.Command.START_INSTANCE), "wt": wid, "sdc_ip": 0,
              **{k: 0 for k in REQUEST_PARAM_WORDS}}
    data = wire.encode(wire.MsgType.REQUEST, values, header=wire.Header(req_id, 0, 0) if header else None)
    return wire.decode(data, header=header)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sdc_unit.pilot", description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", required=True)
    parser.add_argument("--serve", required=True, help="turbine ids, comma-separated")
    parser.add_argument("--ready", type=Path, required=True)
    args = parser.parse_args(argv)
    cfg = load_config_or_exit(SdcConfig, args.config, "sdc pilot")
    service = SdcService(cfg)
    service.bank.warm_up()
    if cfg.realtime_priority:
        raise_priority()
    sdn_app = (cfg.controller_vip, wire.PORT_CONTROLLER)
    for n, wid in enumerate(int(w) for w in args.serve.split(",")):
        service.serve([(start_request(wid, n + 1, cfg.header).encode(), sdn_app)], service.clock.now())

    def stop(*_):
        service.stop()

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    write_json_atomic(args.ready, {"ready": True, "instances": len(service.instances)})
    cpu0 = time.process_time()
    try:
        service.run()
    finally:
        summary = service.summary()
        write_json_atomic(args.ready, {"ready": True, "done": True, "cpu_s": time.process_time() - cpu0,
                                       "rejected": summary["rejected"],
                                       "served": {n: t.get("ctrl_tx", 0) for n, t in summary["turbines"].items()}})
    return 0


if __name__ == "__main__":
    sys.exit(main())
