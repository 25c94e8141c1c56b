"""Read back what a network run's plant recorded, for :mod:`plant.cosim_service`.

From a run's output directory: ``plant_config.json`` (each turbine's converter, ``plant_index``),
``plant_stats.json`` (the plant service's applied events, with the
iteration each was applied in, and per turbine the first MEAS and CTRL), ``timeseries.csv``
(recorded with ``record_every: 1``: |V_pcc|, per turbine Q, the applied CTRL's δ and E, the control's
age ``ctrl_lag``) and ``summary.json`` (the SDC's first used MEAS). :func:`read_run` returns the
:class:`~plant.cosim_service.ServiceConditions` of the run, its recorded per-step lag table and its
traces in the layout of :mod:`plant.cosim` (rows after each step).
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from plant.cosim_service import ServiceConditions, unwrap_finite


def plant_indices(out: Path) -> dict[str, int]:
    """Each turbine host's converter in the full plant model, as the run's plant was told it
    (``plant_config.json``: the topology's description, ``HostInfo.plant_index``)."""
    config = json.loads((out / "plant_config.json").read_text())
    found = {t["name"]: t.get("plant_index") for t in config["turbines"]}
    missing = sorted(name for name, index in found.items() if index is None)
    if missing:
        raise ValueError(f"{out}/plant_config.json: no plant_index for {', '.join(missing[:3])}: a run from before "
                         f"the topology wrote it (run again)")
    return found


def _step_of(t: float, step_s: float) -> int:
    return int(round(t / step_s))


def read_run(out_dir: str | Path, turbines: list[str], step_s: float = 0.67e-3) -> tuple[ServiceConditions, np.ndarray, dict]:
    """(conditions, lag table (steps x turbines), traces) of the run in ``out_dir`` for the ViSC
    ``turbines`` (host names). Raises ValueError when the run did not record every step."""
    out = Path(out_dir)
    stats = json.loads((out / "plant_stats.json").read_text())
    summary = json.loads((out / "summary.json").read_text())
    starts = {e["wt"]: _step_of(e["t"], step_s) for e in stats["events"] if e.get("type") == "stream_start"}
    missing = [wt for wt in turbines if wt not in starts]
    if missing:
        raise ValueError(f"{out}: no stream_start for {missing} in plant_stats.json")
    first_used = []
    for wt in turbines:
        first_tx = stats["turbines"][wt]["first_meas_tx_t"]
        rx = [r["first_meas_rx_t"] for r in summary["turbines"][wt]["per_sdc"].values() if r.get("first_meas_rx_t") is not None]
        first_used.append(1 + _step_of(min(rx) - first_tx, step_s) if rx else 1)
    faults = tuple((_step_of(e["t"], step_s), bool(e.get("on", True))) for e in stats["events"] if e.get("type") == "fault")
    with open(out / "timeseries.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    t = np.array([float(r["t"]) for r in rows])
    if len(t) != stats["steps"] or not np.allclose(t, (np.arange(len(t)) + 1) * step_s, atol=step_s / 10):
        raise ValueError(f"{out}: timeseries.csv has {len(t)} rows for {stats['steps']} steps: record with record_every: 1")

    def col(suffix: str) -> np.ndarray:
        return np.array([[float(r[f"{wt}.{suffix}"]) for wt in turbines] for r in rows])

    index = plant_indices(out)
    cond = ServiceConditions(visc_turbines=tuple(index[wt] for wt in turbines),
                             start_steps=tuple(starts[wt] for wt in turbines), first_used_seq=tuple(first_used),
                             fault_steps=faults, n_steps=len(rows), step_s=step_s)
    traces = {"t": t, "v_pcc": np.array([[float(r["v_pcc"])] for r in rows]), "q": col("q"),
              "delta": unwrap_finite(col("delta")), "e_mag": col("e_mag"), "i_wt": col("i")}
    return cond, col("ctrl_lag").astype(np.int64), traces
