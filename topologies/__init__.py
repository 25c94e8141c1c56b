"""Mininet topologies of the testbed; ``topos`` makes them usable with ``mn --custom``.

Example: ``mn --custom topologies/__init__.py --topo farm,clusters=2,turbines=3 --switch ovs,datapath=user``
(the testbed's runner chooses the datapath by itself).
"""

from topologies.farm import FarmTopo
from topologies.paper import PaperTopo
from topologies.star import StarTopo

topos = {  # the only list of topology names (a scenario's topology.name is checked against it)
    "paper": PaperTopo,
    "farm": FarmTopo,
    "star": StarTopo,
}

__all__ = ["FarmTopo", "PaperTopo", "StarTopo", "topos"]
