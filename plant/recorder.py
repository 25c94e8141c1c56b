"""Decimated time-series recording of the plant to CSV (what ``timeseries.csv`` holds)."""

from __future__ import annotations

import csv
from pathlib import Path


class Recorder:
    """Writes ``t, v_pcc, f_pcc_hz`` and, per recorded turbine, ``<wt>.p, <wt>.q, <wt>.i, <wt>.mode,
    <wt>.ctrl_rx, <wt>.streaming`` every ``every`` steps; then, per recorded turbine, the newest
    applied CTRL's ``<wt>.delta`` (rad) and ``<wt>.e_mag`` (p.u.) (nan before the first) and
    ``<wt>.ctrl_lag``: samples from the measurement that CTRL answered to the newest one sent (1 =
    the CTRL answering the last MEAS drove this step, the paper's one-sample loop; 2 = one sample
    older, held; 0 = no CTRL applied yet)."""

    def __init__(self, path: Path, endpoints: list, every: int) -> None:
        self.endpoints = endpoints
        self.every = every
        self._file = open(path, "w", newline="")  # noqa: SIM115 - closed in close()
        self._writer = csv.writer(self._file)
        header = ["t", "v_pcc", "f_pcc_hz"]
        for ep in endpoints:
            header += [f"{ep.name}.{k}" for k in ("p", "q", "i", "mode", "ctrl_rx", "streaming")]
        for ep in endpoints:  # appended after the columns above, which keep their order
            header += [f"{ep.name}.{k}" for k in ("delta", "e_mag", "ctrl_lag")]
        self._writer.writerow(header)

    def maybe_record(self, k: int, model) -> None:
        if k % self.every:
            return
        out = model.outputs()
        row = [f"{out['t']:.6f}", f"{float(out['v_pcc']):.6f}", f"{float(out['f_pcc_hz']):.6f}"]
        for ep in self.endpoints:
            i = ep.index
            row += [f"{out['p'][i]:.5f}", f"{out['q'][i]:.5f}", f"{out['i_mag'][i]:.5f}", int(out["mode"][i]),
                    ep.counts["ctrl_rx"], int(ep.streaming)]
        for ep in self.endpoints:
            row += [f"{ep.last_delta:.6f}", f"{ep.last_e_mag:.6f}", ep.meas_seq - ep.ctrl_seq if ep.ctrl_seq >= 0 else 0]
        self._writer.writerow(row)

    def close(self) -> None:
        self._file.close()
