"""How "the PCC voltage" during an unbalanced fault can be read from the sequence-network model: the
positive sequence V1, each phase's RMS (V_a = V1 + V2 + V0, V_b = a²V1 + aV2 + V0, V_c = aV1 + a²V2 + V0:
plant/network.py ``phase_phasors``, recorded by the plant as ``v_pcc_ph``), the faulted phase(s), the
three-phase RMS sqrt((|V_a|² + |V_b|² + |V_c|²)/3) = sqrt(|V1|² + |V2|² + |V0|²); and the fault
resistance that makes one of them a given value, over a cited range."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.optimize import brentq

FAULTED_PHASES = {"slg": [0], "llg": [1, 2]}  # plant/network.py: SLG on phase a, LLG on phases b and c
V_PCC_KV = 400.0  # [assumed: the onshore 220/400 kV transformer's grid side, plant/params.py GridParams.x_ontr]
R_F_RANGE_OHM = (0.0, 50.0)
"""Cited range of a ground fault's resistance, Ω [src: ebrary.net/84198 "Circuit Parameters with Faults"
(transmission-system protection text): typical fault resistance 0 Ω at the source, 15 Ω on a line with
ground wires, 50 Ω on a line without]."""


def ohm_to_pu(r_ohm: float, s_base_mva: float, v_kv: float = V_PCC_KV) -> float:
    """A resistance at the PCC in network p.u. (Z_base = V² / S_base)."""
    return r_ohm / (v_kv**2 / s_base_mva)


def readings(r: dict, during: np.ndarray, kind: str) -> dict[str, float]:
    """Means over the samples ``during`` of V1, the faulted phase(s)' RMS (their mean), each phase
    and the three-phase RMS at the PCC of a run ``r`` with a ``kind`` fault."""
    ph = r["v_pcc_ph"][during]
    return {"v1": float(r["v_pcc"][during].mean()),
            "faulted_phase": float(ph[:, FAULTED_PHASES[kind]].mean()),
            "phases": [float(x) for x in ph.mean(axis=0)],
            "three_phase_rms": float(np.sqrt((ph**2).mean(axis=1)).mean())}


def resistance_for(target: float, reading_at: Callable[[float], float], r_max_ohm: float) -> float | None:
    """The fault resistance in [0, r_max_ohm] Ω at which ``reading_at(r_ohm)`` (a reading that rises
    with the resistance) equals ``target``; None when no value in the interval does (to ±0.1 Ω)."""
    lo, hi = reading_at(0.0) - target, reading_at(r_max_ohm) - target
    if lo * hi > 0:
        return None
    return float(brentq(lambda r: reading_at(r) - target, 0.0, r_max_ohm, xtol=0.1))
