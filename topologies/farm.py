"""The 50-turbine offshore farm's communication network, in two layouts.

``compact`` (default under the userspace datapath, where every bridge costs latency):
one OpenFlow switch ``c<k>`` per cluster with its turbines attached, and the cluster switches
and two substation switches ``sub1``/``sub2`` closed in a ring
(``sub1 – c1 – c2 – … – c<K> – sub2 – sub1``). ``owfcc`` and ``sdc1`` hang on ``sub1``,
``sdc2`` on ``sub2``.

``tower`` (realistic; for machines with the kernel datapath): each turbine sits behind its own
tower switch ``t<k>x<n>``; a cluster's tower switches form a string whose two ends are closed at
the substation (first tower on ``sub1``, last on ``sub2``), and ``sub1 – sub2`` are linked.

In both, any single switch-to-switch link failure leaves another path.

``onshore_units`` (default 0): the plant's aggregated onshore units (the paper's 40 MVA SDViSC at the
onshore PCC, ``PlantParams.onshore_units``), each a turbine-like host ``wt6_<k>``
(:func:`sdvisc.vocabulary.onshore_host`) on the substation switch ``sub1``, beside ``owfcc`` and
``sdc1``: the onshore end of the farm's network, not a cluster's string.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, ValidationInfo, field_validator

from sdvisc.config import OnshoreUnits
from sdvisc.vocabulary import ONSHORE_CLUSTER, onshore_host
from topologies.base import TestbedTopo
from topologies.options import ClusteredOptions


class FarmOptions(ClusteredOptions):
    """The farm's options: the paper's 5 × 10 turbines by default."""

    turbines: int = Field(10, ge=1, le=100, description="turbines per cluster (the paper's farm: 10)")
    layout: Literal["compact", "tower"] = Field("compact", description=(
        "compact: one switch per cluster; tower: one switch per turbine (for the kernel datapath)"))
    onshore_units: OnshoreUnits

    @field_validator("onshore_units")
    @classmethod
    def _onshore_beside_the_clusters(cls, value: int, info: ValidationInfo) -> int:
        clusters = info.data.get("clusters", 0)
        if value and clusters >= ONSHORE_CLUSTER:
            raise ValueError(f"onshore unit hosts are {onshore_host(1)}, …: at most {ONSHORE_CLUSTER - 1} "
                             f"clusters beside them, not {clusters}")
        return value


class FarmTopo(TestbedTopo):
    """``clusters`` × ``turbines`` turbine hosts ``wt<c>_<n>`` on a ring-protected network, and
    ``onshore_units`` hosts ``wt6_<k>`` on ``sub1``."""

    options_model = FarmOptions

    def build(self, clusters: int, turbines: int, layout: str, onshore_units: int):
        sub1 = self.add_switch("sub1", dpid=1)
        sub2 = self.add_switch("sub2", dpid=2)
        self.addLink(self.add_service_host("owfcc"), sub1)
        self.addLink(self.add_service_host("sdc1"), sub1)
        self.addLink(self.add_service_host("sdc2"), sub2)
        self.addLink(sub1, sub2)
        if layout == "compact":
            self._build_compact(sub1, sub2, clusters, turbines)
        else:
            self._build_tower(sub1, sub2, clusters, turbines)
        for k in range(1, onshore_units + 1):
            self.addLink(self.add_turbine(ONSHORE_CLUSTER, k), sub1)

    def _build_compact(self, sub1: str, sub2: str, clusters: int, turbines: int) -> None:
        previous = sub1
        for c in range(1, clusters + 1):
            switch = self.add_switch(f"c{c}", dpid=0x10 + c)
            self.addLink(previous, switch)
            for n in range(1, turbines + 1):
                self.addLink(self.add_turbine(c, n), switch)
            previous = switch
        self.addLink(previous, sub2)

    def _build_tower(self, sub1: str, sub2: str, clusters: int, turbines: int) -> None:
        for c in range(1, clusters + 1):
            previous = sub1
            for n in range(1, turbines + 1):
                tower = self.add_switch(f"t{c}x{n}", dpid=0x1000 * c + n)
                self.addLink(previous, tower)
                self.addLink(self.add_turbine(c, n), tower)
                previous = tower
            self.addLink(previous, sub2)
