"""The plant service's stats file (plant_stats.json): steps and lateness, trips and fallbacks, each
turbine's packet counts, gaps, one-way delays and round trips in samples, the batteries."""

from __future__ import annotations

from plant import endpoint_rx
from sdvisc.stats import delay_summary


def summarise(service) -> dict:
    """The plant service's stats after its run (``service``: a :class:`plant.service.PlantService`)."""
    return {
        "steps": service.k,
        "scheduling": getattr(service, "scheduling", "default"),
        "late_steps": service.late_steps,
        "cpu_s": round(getattr(service, "cpu_s", 0.0), 4),
        "converter_trips": {ep.name: int(service.model.trips[ep.index]) for ep in service.endpoints
                            if getattr(service.model, "trips", None) is not None and service.model.trips[ep.index]},
        "fallbacks": {ep.name: int(service.model.fallbacks[ep.index]) for ep in service.endpoints
                      if getattr(service.model, "fallbacks", None) is not None and service.model.fallbacks[ep.index]},
        "max_lateness_ms": service.max_lateness_s * 1e3,
        "stalls": [{"t_sim": t, "worst_ms": ms, "steps": last - round(t / service.step_s) + 1} for t, ms, last in service.stalls],
        "frequency_hz": service.recorder.extremes()["f_pcc_hz"],
        "batteries": _battery_summary(service),
        "rx_wire": service.rx_stats.as_dict(),
        "rx_rejected": endpoint_rx.rejections_by_reason(ep.counts for ep in service.endpoints),
        "events": service.events_applied,
        "turbines": {
            ep.name: {**ep.counts, "first_meas_tx_t": ep.first_meas_tx_t, "first_ctrl_rx_t": ep.first_ctrl_rx_t,
                      "last_ctrl_rx_t": ep.last_ctrl_rx_t, "ak_ones": ep.ak_ones,
                      "ctrl_gaps_wall": ep.ctrl_gaps, "ctrl_resumed": ep.ctrl_resumed,
                      "takeover_jump_pu": ep.takeover_jump,
                      "last_ctrl_wall": ep.last_ctrl_wall if ep.last_ctrl_wall > float("-inf") else None,
                      "ctrl_one_way_ms": delay_summary(ep.ctrl_delays_ms),
                      "rtt_samples": {**{str(n + 1): c for n, c in enumerate(ep.rtt_samples[:-1]) if c},
                                      **({f">{len(ep.rtt_samples) - 1}": ep.rtt_samples[-1]} if ep.rtt_samples[-1] else {})}}
            for ep in service.endpoints
        },
    }


def _battery_summary(service) -> dict:
    """Per battery turbine: SOC at t = 0 and now, the smallest recorded, the change, the energy
    delivered to the DC link (MWh) and the largest recorded power (p.u.)."""
    if not service.batteries:
        return {}
    batt, rec = service.model.tb.batt, service.recorder.extremes()["batteries"]
    energy = batt.energy_mwh()
    out = {}
    for name, i in service.batteries.items():
        soc = float(batt.soc[i])
        out[name] = {"soc_start": round(service.soc_start[name], 8), "soc_end": round(soc, 8),
                     "soc_change": round(soc - service.soc_start[name], 8), "soc_min": rec[name]["soc_min"],
                     "energy_mwh": round(float(energy[i]), 6), "p_batt_max_pu": rec[name]["p_batt_max"]}
    return out
