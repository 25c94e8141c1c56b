"""Decimated time-series recording of the plant to CSV (what ``timeseries.csv`` holds)."""

from __future__ import annotations

import csv
from pathlib import Path


class Recorder:
    """Writes ``t, v_pcc, f_pcc_hz`` and, per recorded turbine, ``<wt>.p, <wt>.q, <wt>.i, <wt>.mode,
    <wt>.ctrl_rx`` every ``every`` steps."""

    def __init__(self, path: Path, endpoints: list, every: int) -> None:
        self.endpoints = endpoints
        self.every = every
        self._file = open(path, "w", newline="")  # noqa: SIM115 - closed in close()
        self._writer = csv.writer(self._file)
        header = ["t", "v_pcc", "f_pcc_hz"]
        for ep in endpoints:
            header += [f"{ep.name}.{k}" for k in ("p", "q", "i", "mode", "ctrl_rx", "streaming")]
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
        self._writer.writerow(row)

    def close(self) -> None:
        self._file.close()
