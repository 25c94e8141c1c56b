"""``summary.json``'s per-turbine rows (issue 42 items 7 and 8): one way to add the counts up, whatever
the plant was.

Per turbine, ``packets`` holds what the turbine's side counted (``meas_tx``, ``ctrl_rx``, ``ak_tx``,
…: the testbed's plant, the emulated card, or for a real card what the capture on its cable saw,
:mod:`scenarios.peer_tap`) and ``meas_rx_sdc``/``ctrl_tx_sdc``: the sum over **every** SDC of the
run of what it received and sent for the turbine (``per_sdc``: each SDC's own counts, a killed
SDC's up to its last snapshot of them, ``sdc_stats_partial``). An SDC that left no statistics at
all is named in ``sdc_stats_missing``. A count nobody could take is ``None`` ("n/a (real card)"),
never 0.
"""

from __future__ import annotations

SUMMARY_GAP_S = 0.005  # turbines.<wt>.ctrl_gaps and recoveries list pauses longer than this (interruptions: all)
PER_SDC_KEYS = ("meas_rx", "ctrl_tx", "meas_lost", "meas_stale", "meas_inactive")
NOT_COUNTED = "n/a (real card)"
"""What the CLI shows for a count that is ``None`` in summary.json: a real card counts nothing for us."""


def long_gaps(stats: dict) -> list:
    """The plant's recorded control pauses longer than :data:`SUMMARY_GAP_S` (run clock)."""
    return [(a, b) for a, b in stats.get("ctrl_gaps_wall", []) if b - a > SUMMARY_GAP_S]


def round_trip(histogram: dict | None) -> dict | None:
    """MEAS → CTRL round trip, in samples, of the control answers a turbine applied: the count per
    number of samples, the share within one sample (the paper's one-sample loop) and the median."""
    if not histogram:
        return None
    total = sum(histogram.values())
    order = sorted(histogram, key=lambda key: int(key.lstrip(">")) + (1 if key.startswith(">") else 0))
    acc, median = 0, None
    for key in order:
        acc += histogram[key]
        if median is None and acc * 2 >= total:
            median = key
    return {"counts": {key: histogram[key] for key in order}, "within_one": round(histogram.get("1", 0) / total, 4),
            "median": median}


def meas_resumed(sdcs: dict) -> dict[str, list]:
    """Per turbine, where its MEAS got through again after a loss, from every SDC's statistics."""
    out: dict[str, list] = {}
    for stats in sdcs.values():
        for wt, row in stats.get("turbines", {}).items():
            out.setdefault(wt, []).extend(row.get("meas_resumed", []))
    return out


def peer_as_plant(card: dict, sdcs: dict, tap: dict | None = None) -> dict:
    """An external peer's counts in the plant statistics' shape: the emulated card's own
    (``gtnet_card_stats.json``); for a real card what the capture on its cable saw (``tap``:
    :func:`scenarios.peer_tap.read`), its steps unknown; without a capture the turbines the SDCs heard
    from, every count of the card's side unknown."""
    if card:
        turbines = {n: {**t, "rx_rejected": t.get("rejected_total", 0)} for n, t in card.get("turbines", {}).items()}
        return {**card, "turbines": turbines}
    unknown = {"steps": None, "late_steps": None}
    if tap:
        return {**unknown, "turbines": tap["turbines"]}
    names = sorted({n for d in sdcs.values() for n in d.get("turbines", {})})
    return {**unknown, "turbines": {n: {k: None for k in ("meas_tx", "ctrl_rx", "ak_tx", "ak_ones", "ctrl_stale",
                                                          "rx_rejected")} for n in names}}


def turbine_rows(plant: dict, sdcs: dict, t0: float | None) -> dict[str, dict]:
    """summary.json ``turbines``: the rows of the module docstring, for every turbine that took part."""
    rows = {}
    for name, stats in sorted(plant.get("turbines", {}).items()):
        sdc_rows = {s: d.get("turbines", {}).get(name, {}) for s, d in sdcs.items()}
        meas_rx = sum(r.get("meas_rx", 0) for r in sdc_rows.values())
        ctrl_tx = sum(r.get("ctrl_tx", 0) for r in sdc_rows.values())
        if not (stats.get("meas_tx") or stats.get("ctrl_rx") or meas_rx or ctrl_tx or stats.get("requests_rx")):
            continue  # a turbine that never took part is left out to keep the summary readable
        rows[name] = {
            "packets": {"meas_tx": stats.get("meas_tx", 0), "meas_rx_sdc": meas_rx, "ctrl_tx_sdc": ctrl_tx,
                        **{k: stats.get(k, 0) for k in ("ctrl_rx", "ak_tx", "ctrl_stale", "rx_rejected")}},
            "per_sdc": {s: {k: r.get(k, 0) for k in PER_SDC_KEYS} | {"first_meas_rx_t": r.get("first_meas_rx_t")}
                        for s, r in sdc_rows.items() if r},
            "first_meas_tx_t": stats.get("first_meas_tx_t"),
            "first_ctrl_rx_t": stats.get("first_ctrl_rx_t"),
            "last_ctrl_rx_t": stats.get("last_ctrl_rx_t"),
            "ak_ones": stats.get("ak_ones", 0),
            "ctrl_gaps": [[round(a - t0, 6), round(b - t0, 6)] for a, b in long_gaps(stats)] if t0 else [],
            "takeover_jump_pu": stats.get("takeover_jump_pu"),
            "round_trip_samples": round_trip(stats.get("rtt_samples")),
            "one_way_delay_ms": {
                "meas_to_sdc": next((r.get("meas_one_way_ms") for r in sdc_rows.values() if r.get("meas_one_way_ms")), None),
                "ctrl_to_turbine": stats.get("ctrl_one_way_ms"),
            },
        }
        if "card_ctrl_rx" in stats:  # a real card: what its AK stream said (scenarios.peer_tap)
            rows[name]["ak_stream"] = {k: stats[k] for k in ("card_ctrl_rx", "ak_zero", "ctrl_age_max_ms")}
    return rows


def sdc_stats_missing(run, sdcs: dict) -> dict[str, str]:
    """The SDCs the run started that left no statistics (an SDC writes them as it goes; one killed
    before its first snapshot cannot): their MEAS and CTRL are missing from every turbine's
    ``meas_rx_sdc`` and ``ctrl_tx_sdc`` (which add up ``per_sdc``), so those can be below
    ``meas_tx`` / ``ctrl_rx``."""
    procs = getattr(getattr(run, "processes", None), "procs", {})
    started = sorted({name.split(".")[0] for name in procs if name.endswith(".sdc")})
    return {s: "killed" if f"{s}.sdc" in run.killed else "ended without writing them"
            for s in started if s not in sdcs}


def sdc_stats_partial(run, sdcs: dict) -> dict[str, dict]:
    """The SDCs whose statistics are a snapshot taken while they served (``final`` False: killed, or
    ended without writing the full ones): what they served up to ``as_of_t`` (seconds from t = 0)
    is counted, the rest (at most :data:`sdc_unit.service.STATS_PERIOD_S` wall seconds) is not."""
    t0 = getattr(run, "t0", None)
    return {s: {"as_of_t": round(d["t_written"] - t0, 3) if t0 is not None and d.get("t_written") else None,
                "why": "killed" if f"{s}.sdc" in run.killed else "ended without writing its full statistics"}
            for s, d in sdcs.items() if d.get("final") is False}
