"""Collector layouts of the electrical model (plant/collectors.py, issue 41): the registry entry is
what a new layout adds. A ring of array cables between neighbouring clusters, written here as a
new layout would be (one class, one entry of COLLECTORS), changes Y by exactly those cables'
pi-sections and nothing else, and the network still solves."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from plant import collectors
from plant.collectors import COLLECTORS, RadialFarm, pi_section
from plant.network import Network
from plant.params import PlantParams


class RingFarm(RadialFarm):
    """The radial farm and one array cable between each pair of neighbouring cluster nodes,
    closing a ring (the last cluster back to the first)."""

    def add_elements(self, net, el) -> None:
        super().add_elements(net, el)
        g = net.p.grid
        z, b = net._cable(g.array_km, g.array_r_ohm_km, g.array_l_mh_km, g.array_c_nf_km, g.v_array_kv)
        nodes = [int(c) for c in net.cluster_nodes]
        for a, c in zip(nodes, nodes[1:] + nodes[:1]):
            pi_section(el, a, c, z, b)


def test_an_unknown_layout_names_the_known_ones():
    with pytest.raises(ValueError, match="collector layouts are farm, single"):
        Network(replace(PlantParams(), topology="mesh"), 50)


def test_a_ring_is_one_class_and_one_entry(monkeypatch):
    monkeypatch.setitem(COLLECTORS, "ring", RingFarm())
    p = PlantParams()
    radial = Network(p, 50)
    ring = Network(replace(p, topology="ring"), 50)
    assert (ring.n_nodes, ring.pcc, ring.sc) == (radial.n_nodes, radial.pcc, radial.sc)  # same nodes
    g = p.grid
    z, b = radial._cable(g.array_km, g.array_r_ohm_km, g.array_l_mh_km, g.array_c_nf_km, g.v_array_kv)
    added = np.zeros_like(radial.y)  # the ring's five cables, stamped by hand
    nodes = list(radial.cluster_nodes)
    for i, j in zip(nodes, nodes[1:] + nodes[:1]):
        added[[i, j], [i, j]] += 1.0 / z + 0.5j * b
        added[i, j] -= 1.0 / z
        added[j, i] -= 1.0 / z
    np.testing.assert_allclose(ring.y - radial.y, added, rtol=0, atol=1e-9 * np.abs(radial.y).max())
    assert not np.allclose(ring.y, radial.y)
    inj = np.zeros(ring.n_nodes, dtype=complex)
    inj[:50] = 0.5 * ring.k_t  # every turbine injecting half its rating
    for net in (radial, ring):
        v = net.solve(inj)
        np.testing.assert_allclose(net.y @ v, inj, atol=1e-9)  # Y v = I: the solve is the network's


def test_the_registry_is_what_the_network_reads():
    assert set(COLLECTORS) == {"farm", "single"}
    assert collectors.collector_layout("single").turbine_bus(Network(replace(PlantParams(), topology="single"), 3), 2) == 3
