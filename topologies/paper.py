"""The paper's real-time prototype (Fig. 9 of the SDViSC paper) as a Mininet topology.

Four OpenFlow switches ``s1``–``s4`` form a ring with one diagonal (``s1``–``s3``), so every
switch-to-switch link has an alternative. The plant side (the GTNET cards in the lab) hangs on a
non-OpenFlow L2 switch ``l2`` that is dual-homed to ``s3`` and ``s4``; the turbine hosts sit on
``l2``. ``owfcc`` and the primary SDC ``sdc1`` hang on ``s1``, the backup SDC ``sdc2`` on ``s2``::

        owfcc  sdc1            sdc2
            \\  /               |
             s1 -------------- s2
             | \\               |
             |   \\             |
             s4 -------------- s3
               \\              /
                ----- l2 -----
                   /  |  \\
                wt1_1 ... wt<c>_<n>
"""

from __future__ import annotations

from topologies.base import TestbedTopo
from topologies.options import ClusteredOptions


class PaperTopo(TestbedTopo):
    """The prototype: 4 OpenFlow switches, 1 L2 switch, owfcc, sdc1, sdc2 and turbine hosts."""

    options_model = ClusteredOptions

    def build(self, clusters: int, turbines: int):
        s1, s2, s3, s4 = (self.add_switch(f"s{i}", dpid=i) for i in range(1, 5))
        l2 = self.add_switch("l2", dpid=0x100, openflow=False)
        for a, b in ((s1, s2), (s2, s3), (s3, s4), (s4, s1), (s1, s3)):
            self.addLink(a, b)
        self.addLink(l2, s3)
        self.addLink(l2, s4)
        self.addLink(self.add_service_host("owfcc"), s1)
        self.addLink(self.add_service_host("sdc1"), s1)
        self.addLink(self.add_service_host("sdc2"), s2)
        for c in range(1, clusters + 1):
            for n in range(1, turbines + 1):
                self.addLink(self.add_turbine(c, n), l2)
