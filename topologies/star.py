"""A dual star: every cluster switch on both substation switches (the worked example of a new
topology, docs/architecture.md "Extending the testbed"; this module and one line of
``topologies.topos``).

Two OpenFlow core switches ``h1``, ``h2`` are linked; each cluster's switch ``c<k>`` (its
turbines ``wt<k>_<n>`` attached) has one link to each, so any single switch-to-switch link failure
leaves another path, and every turbine is two switch hops from either SDC. ``owfcc`` and ``sdc1``
hang on ``h1``, ``sdc2`` on ``h2``::

        owfcc sdc1          sdc2
            \\ /              |
             h1 ----------- h2
             | \\          / |
             |   c1 ... ck   |
             |  (both hubs)  |

``link_delay_ms``: a one-way delay declared on every switch-to-switch link (Mininet's ``delay`` link
option), which the description carries as each link's ``delay_s`` for the SDN app's delay path
policy. Declared, not emulated by the testbed's run (its links are plain veths or patch ports):
``mn --custom topologies/__init__.py --topo star,link_delay_ms=2 --link tc`` emulates it with netem
where the kernel has it (not on the development machine, ../shared/PLATFORM.md); a run emulates a
delay with an impairment element (the scenario's ``links: [{a, b, delay_ms}]``).
"""

from __future__ import annotations

from pydantic import Field

from topologies.base import TestbedTopo
from topologies.options import ClusteredOptions


class StarOptions(ClusteredOptions):
    """Clusters × turbines, and a delay on the switch-to-switch links."""

    link_delay_ms: float = Field(0.0, ge=0, le=1000, description=(
        "one-way delay declared on every switch-to-switch link, ms (0: none; e.g. 0.1 for 20 km of fibre at "
        "5 µs/km); declared for the path policies, emulated only with a tc link class (see the module)"))


class StarTopo(TestbedTopo):
    """``h1``–``h2`` and ``clusters`` switches ``c<k>`` on both, ``turbines`` hosts on each."""

    options_model = StarOptions

    def build(self, clusters: int, turbines: int, link_delay_ms: float):
        delayed = {"delay": f"{link_delay_ms:g}ms"} if link_delay_ms else {}
        h1 = self.add_switch("h1", dpid=1)
        h2 = self.add_switch("h2", dpid=2)
        self.addLink(self.add_service_host("owfcc"), h1)
        self.addLink(self.add_service_host("sdc1"), h1)
        self.addLink(self.add_service_host("sdc2"), h2)
        self.addLink(h1, h2, **delayed)
        for c in range(1, clusters + 1):
            switch = self.add_switch(f"c{c}", dpid=0x10 + c)
            self.addLink(switch, h1, **delayed)
            self.addLink(switch, h2, **delayed)
            for n in range(1, turbines + 1):
                self.addLink(self.add_turbine(c, n), switch)
