"""The plant service's stats file (plant_stats.json): steps and lateness, trips and fallbacks, each
turbine's packet counts, gaps, one-way delays and round trips in samples, the batteries."""

from __future__ import annotations

from plant.service import endpoint_rx
from sdvisc.stats import delay_summary


def summarise(core, pacing, extremes: dict, *, scheduling: str = "default", cpu_s: float = 0.0) -> dict:
    """The plant service's stats after its run: ``core`` (a :class:`plant.service.core.PlantCore`),
    ``pacing`` (its loop's :class:`plant.service.core.Pacing`), ``extremes`` (the recorder's,
    :meth:`plant.service.recorder.Recorder.extremes`), the loop's ``scheduling`` and process CPU ``cpu_s``."""
    model, endpoints = core.model, core.endpoints
    return {
        "steps": core.k,
        "scheduling": scheduling,
        "late_steps": pacing.late_steps,
        "cpu_s": round(cpu_s, 4),
        "converter_trips": {ep.name: int(model.trips[ep.index]) for ep in endpoints
                            if getattr(model, "trips", None) is not None and model.trips[ep.index]},
        "fallbacks": {ep.name: int(model.fallbacks[ep.index]) for ep in endpoints
                      if getattr(model, "fallbacks", None) is not None and model.fallbacks[ep.index]},
        "max_lateness_ms": pacing.max_lateness_s * 1e3,
        "stalls": [{"t_sim": t, "worst_ms": ms, "steps": last - round(t / core.step_s) + 1} for t, ms, last in pacing.stalls],
        "frequency_hz": extremes["f_pcc_hz"],
        "batteries": _battery_summary(core, extremes["batteries"]),
        "rx_wire": core.rx_stats.as_dict(),
        "rx_rejected": endpoint_rx.rejections_by_reason(ep.counts for ep in endpoints),
        "events": core.events_applied,
        "turbines": {
            ep.name: {**ep.counts, "first_meas_tx_t": ep.first_meas_tx_t, "first_ctrl_rx_t": ep.first_ctrl_rx_t,
                      "last_ctrl_rx_t": ep.last_ctrl_rx_t, "ak_ones": ep.ak_ones,
                      "ctrl_gaps_wall": ep.ctrl_gaps, "ctrl_resumed": ep.ctrl_resumed,
                      "takeover_jump_pu": ep.takeover_jump,
                      "last_ctrl_wall": ep.last_ctrl_wall if ep.last_ctrl_wall > float("-inf") else None,
                      "ctrl_one_way_ms": delay_summary(ep.ctrl_delays_ms),
                      "rtt_samples": {**{str(n + 1): c for n, c in enumerate(ep.rtt_samples[:-1]) if c},
                                      **({f">{len(ep.rtt_samples) - 1}": ep.rtt_samples[-1]} if ep.rtt_samples[-1] else {})}}
            for ep in endpoints
        },
    }


def _battery_summary(core, recorded: dict) -> dict:
    """Per battery turbine: SOC at t = 0 and now, the smallest recorded, the change, the energy
    delivered to the DC link (MWh) and the largest recorded power (p.u.)."""
    if not core.batteries:
        return {}
    batt = core.model.tb.batt
    energy = batt.energy_mwh()
    out = {}
    for name, i in core.batteries.items():
        soc = float(batt.soc[i])
        out[name] = {"soc_start": round(core.soc_start[name], 8), "soc_end": round(soc, 8),
                     "soc_change": round(soc - core.soc_start[name], 8), "soc_min": recorded[name]["soc_min"],
                     "energy_mwh": round(float(energy[i]), 6), "p_batt_max_pu": recorded[name]["p_batt_max"]}
    return out
