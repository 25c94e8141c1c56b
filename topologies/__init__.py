"""Mininet topologies of the testbed; ``topos`` makes them usable with ``mn --custom``.

Example: ``mn --custom topologies/__init__.py --topo farm,clusters=2,turbines=3 --switch ovs,datapath=user``
(the testbed's runner chooses the datapath by itself).
"""

from topologies.farm import FarmTopo
from topologies.paper import PaperTopo

topos = {
    "paper": PaperTopo,
    "farm": FarmTopo,
}

__all__ = ["FarmTopo", "PaperTopo", "topos"]
