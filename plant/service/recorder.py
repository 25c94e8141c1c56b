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
    older, held; 0 = no CTRL applied yet). Last, per turbine with a battery (``batteries``: name ->
    model index), ``<wt>.soc`` and ``<wt>.p_batt`` (p.u. of the turbine rating, + = into the DC
    link). It keeps the PCC frequency's extremes and the batteries' over the recorded samples
    (:meth:`extremes`)."""

    def __init__(self, path: Path, endpoints: list, every: int, batteries: dict[str, int] | None = None) -> None:
        self.endpoints = endpoints
        self.every = every
        self.batteries = dict(batteries or {})
        self.f_min = self.f_max = None  # (Hz, t)
        self.batt = {name: {"soc_min": None, "p_batt_max": None} for name in self.batteries}
        self._file = open(path, "w", newline="")  # noqa: SIM115 - closed in close()
        self._writer = csv.writer(self._file)
        header = ["t", "v_pcc", "f_pcc_hz"]
        for ep in endpoints:
            header += [f"{ep.name}.{k}" for k in ("p", "q", "i", "mode", "ctrl_rx", "streaming")]
        for ep in endpoints:  # appended after the columns above, which keep their order
            header += [f"{ep.name}.{k}" for k in ("delta", "e_mag", "ctrl_lag")]
        for name in self.batteries:
            header += [f"{name}.soc", f"{name}.p_batt"]
        self._writer.writerow(header)

    def maybe_record(self, k: int, model) -> None:
        if k % self.every:
            return
        out = model.recorded()  # not outputs(): its full node-voltage solve is not recorded
        row = [f"{out['t']:.6f}", f"{float(out['v_pcc']):.6f}", f"{float(out['f_pcc_hz']):.6f}"]
        for ep in self.endpoints:
            i = ep.index
            row += [f"{out['p'][i]:.5f}", f"{out['q'][i]:.5f}", f"{out['i_mag'][i]:.5f}", int(out["mode"][i]),
                    ep.counts["ctrl_rx"], int(ep.streaming)]
        for ep in self.endpoints:
            row += [f"{ep.last_delta:.6f}", f"{ep.last_e_mag:.6f}", ep.meas_seq - ep.ctrl_seq if ep.ctrl_seq >= 0 else 0]
        f, t = float(out["f_pcc_hz"]), float(out["t"])
        if self.f_min is None or f < self.f_min[0]:
            self.f_min = (f, t)
        if self.f_max is None or f > self.f_max[0]:
            self.f_max = (f, t)
        for name, i in self.batteries.items():
            soc, p = float(out["soc"][i]), float(out["p_batt"][i])
            row += [f"{soc:.8f}", f"{p:.5f}"]
            b = self.batt[name]
            b["soc_min"] = soc if b["soc_min"] is None else min(b["soc_min"], soc)
            b["p_batt_max"] = p if b["p_batt_max"] is None else max(b["p_batt_max"], p)
        self._writer.writerow(row)

    def extremes(self) -> dict:
        """``f_pcc_hz``: the smallest and largest recorded PCC frequency and when; ``batteries``:
        per battery turbine the smallest SOC and largest power recorded."""
        f = {} if self.f_min is None else {"min": round(self.f_min[0], 6), "t_min": round(self.f_min[1], 6),
                                            "max": round(self.f_max[0], 6), "t_max": round(self.f_max[1], 6)}
        return {"f_pcc_hz": f, "batteries": self.batt}

    def close(self) -> None:
        self._file.close()
