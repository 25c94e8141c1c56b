"""Which SDViSC arrangement the network versions of F3–F7 (F3net–F7net) run, and its offline twin.

``onshore`` (the default, issue 28 item 1): the paper's comparison arrangement (Section IV-A) — one
aggregated 40 MVA SDViSC at the onshore PCC, plant converter 50 (``plant.cases.COMPARISON_UNIT``),
whose GTNET endpoint is the host ``wt6_1`` on the substation switch ``sub1``
(``topology.onshore_units: 1``), stepped by one SDC instance; compared with
``plant.cases.comparison_visc_plant``, the case the offline F3–F7 run. ``cluster3``: the earlier
variant, the leftmost four turbines of cluster 3 (``wt3_1`` … ``wt3_4``, converters 20–23) as
SDViSCs, compared with ``plant.cases.visc_plant(4)``; its files are ``scenarios/paper/<name>_cluster3.yaml``.
``python -m report --net-arrangement cluster3`` runs it.
"""

from __future__ import annotations

import numpy as np

from plant.cases import COMPARISON_UNIT, comparison_visc_plant, visc_indices, visc_plant
from plant.params import PlantParams
from sdvisc.vocabulary import onshore_host

ONSHORE, CLUSTER3 = "onshore", "cluster3"
ARRANGEMENTS = (ONSHORE, CLUSTER3)
CHOSEN = ONSHORE
"""The arrangement of this report process (``--net-arrangement``)."""

ONSHORE_HOST = onshore_host(1)  # wt6_1
CLUSTER3_HOSTS = ("wt3_1", "wt3_2", "wt3_3", "wt3_4")


def choose(arrangement: str) -> None:
    global CHOSEN
    if arrangement not in ARRANGEMENTS:
        raise ValueError(f"unknown arrangement {arrangement!r} (known: {', '.join(ARRANGEMENTS)})")
    CHOSEN = arrangement


def scenario(name: str) -> str:
    """The scenarios/paper/ file (stem) of experiment file ``name`` in the chosen arrangement."""
    return name if CHOSEN == ONSHORE else f"{name}_cluster3"


def offline_plant(visc_params=None, activate: bool = True, battery: bool = False, **grid):
    """The network run's case offline (the law inside the plant, hd_visc)."""
    if CHOSEN == ONSHORE:
        return comparison_visc_plant(visc_params=visc_params, activate=activate, battery=battery, **grid)
    return visc_plant(4, visc_params=visc_params, activate=activate, battery=battery, **grid)


def indices() -> np.ndarray:
    """The SDViSC converters of the chosen arrangement in the plant."""
    return np.array([COMPARISON_UNIT]) if CHOSEN == ONSHORE else visc_indices(4)


def label() -> str:
    """The SDViSC(s), in words, for findings and figures."""
    if CHOSEN == ONSHORE:
        return f"the onshore {PlantParams.onshore_unit_mva:g} MVA SDViSC ({ONSHORE_HOST})"
    return "4 SDViSCs of cluster 3"


def capacity() -> str:
    """The SDViSC capacity against the PCC, in words (why a PCC voltage moves so little)."""
    if CHOSEN == ONSHORE:
        return f"one {PlantParams.onshore_unit_mva:g} MVA unit"
    return "4 × 10 MVA"


DESCRIPTION = (f"The paper's comparison arrangement: one 40 MVA SDViSC at the onshore PCC (plant converter "
               f"{COMPARISON_UNIT}, its GTNET host {ONSHORE_HOST} on sub1), stepped by one SDC instance over the network "
               "at the auto time scale, beside the same case offline (plant.cases.comparison_visc_plant); "
               "--net-arrangement cluster3 runs the four SDViSCs of cluster 3 instead")
