"""CPU cost of the SDC's stats snapshot (issue 42 item 8; sdc_unit/service.py ``STATS_PERIOD_S``): the
SDC writes its counts as it goes so that a killed SDC's counts survive. Measured: process CPU time of
:meth:`sdc_unit.service.SdcService.snapshot` and its JSON encoding (what the loop does; the write itself
runs on the LatestWriter thread, measured apart), for 2 and 50 turbines with 20 losses each, and the
share of one core that costs at ``STATS_PERIOD_S``. CPU time, not wall time: the machine is shared.

Usage: nice -n 10 .venv/bin/python benchmarks/sdc_stats_snapshot.py [--out benchmarks/measured/FILE.json]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from sdc_unit.service import STATS_PERIOD_S, SdcService  # noqa: E402
from sdvisc import wire  # noqa: E402
from sdvisc.config import SdcConfig  # noqa: E402
from sdvisc.jsonlines import write_json_atomic  # noqa: E402
from sdvisc.latest_writer import LatestWriter  # noqa: E402

REPEATS = 2000


def measure(turbines: int) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        svc = SdcService(SdcConfig(step_s=0.00067, bind_ip="127.0.0.1", controller_vip="127.0.0.1",
                                   capacity=turbines + 1, out_dir=tmp), sock=_NoSocket())
        for n in range(turbines):
            inst = svc.core._instance(wire.turbine_id(1 + n // 50, 1 + n % 50), create=True)
            inst.counts.update(meas_rx=37_000, ctrl_tx=37_000, meas_lost=40)
            inst.first_meas_rx_t = 1.0e9
            inst.meas_resumed.extend([[1.0e9 + i, 2] for i in range(20)])
        start = time.process_time()
        for _ in range(REPEATS):
            data = json.dumps(svc.snapshot()).encode()
        encode_us = (time.process_time() - start) / REPEATS * 1e6
        writer = LatestWriter(Path(tmp) / "sdc1_stats.json")
        start = time.process_time()
        for _ in range(REPEATS // 10):
            writer._write(data)  # what its thread does per snapshot (off the SDC's loop)
        write_us = (time.process_time() - start) / (REPEATS // 10) * 1e6
        writer.close()
    return {"turbines": turbines, "bytes": len(data), "snapshot_encode_cpu_us": round(encode_us, 1),
            "writer_thread_cpu_us": round(write_us, 1),
            "core_share_at_period": round((encode_us + write_us) * 1e-6 / STATS_PERIOD_S, 5)}


class _NoSocket:
    def sendto(self, *_):
        return 0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="benchmarks/measured/sdc-stats-snapshot.json")
    args = parser.parse_args()
    result = {"what": __doc__.splitlines()[0], "stats_period_s": STATS_PERIOD_S, "repeats": REPEATS,
              "load_average": os.getloadavg(), "cases": [measure(n) for n in (2, 50)]}
    write_json_atomic(args.out, result)
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
