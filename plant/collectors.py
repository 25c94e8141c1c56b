"""Collector layouts of the electrical model: how the turbines' transformers reach the PCC.

A layout numbers the network's nodes after the turbine terminals (:meth:`CollectorLayout.place`),
says which node each turbine's transformer ends on (:meth:`~CollectorLayout.turbine_bus`), adds
the passive elements between those nodes and the PCC (:meth:`~CollectorLayout.add_elements`) and
the zero-sequence paths it gives a fault at the PCC (:meth:`~CollectorLayout.zero_sequence`).
:class:`plant.network.Network` does the rest (filter capacitors, turbine transformers, the grid's
Thevenin branch, the condenser, the fault) for any layout. ``PlantParams.topology`` names one of
:data:`COLLECTORS`; a new layout (a ring of array cables, say) is one class and one entry there.
"""

from __future__ import annotations

import numpy as np

from plant.dynamic_network import GROUND, Elements


def pi_section(el: Elements, a: int, b: int, z: complex, bsh: float) -> None:
    """A cable between ``a`` and ``b``: its series impedance, half its charging at each end."""
    el.rl(a, b, z)
    el.shunt_c(a, 0.5 * bsh)
    el.shunt_c(b, 0.5 * bsh)


class CollectorLayout:
    """Nodes ``0 .. n-1`` are the turbine terminals; a layout places the others (``net.pcc`` and
    ``net.sc`` last: ``n_nodes = sc + 1``) and sets ``cluster_of``, ``cluster_nodes``, ``os_mv``,
    ``os_hv``, ``on_hv`` on the network."""

    def place(self, net) -> None:
        raise NotImplementedError

    def turbine_bus(self, net, k: int) -> int:
        """The node farm turbine ``k``'s transformer ends on (an onshore unit's is the pcc, always)."""
        raise NotImplementedError

    def add_elements(self, net, el: Elements) -> None:
        """The collector's elements between the turbine buses and the pcc (none by default)."""

    def zero_sequence(self, net) -> list[complex]:
        """Zero-sequence impedances to ground at the pcc that this layout adds (none by default)."""
        return []


class RadialFarm(CollectorLayout):
    """The paper's farm (``topology="farm"``): C clusters, each cluster's strings aggregated into one
    pi-section of array cable to the offshore substation's 66 kV bus; the substation transformer;
    the export cable in ``export_sections`` pi-sections with shunt reactors at both ends; the
    onshore transformer to the pcc. Nodes after the N turbines::

        N .. N+C-1      cluster 66 kV nodes
        os_mv, os_hv    offshore substation 66 kV and 220 kV buses
        cable nodes     export_sections-1 internal nodes of the export cable, then on_hv
        pcc, sc         the onshore point of common coupling, the condenser's terminal
    """

    def place(self, net) -> None:
        n, nf, c = net.n, net.n_farm, net.p.n_clusters
        net.cluster_of = np.r_[(np.arange(nf) * c) // max(nf, 1), np.full(n - nf, -1)]  # -1: onshore unit
        net.cluster_nodes = n + np.arange(c)
        k = n + c
        net.os_mv, net.os_hv = k, k + 1
        ns = net.p.grid.export_sections
        net.cable_nodes = np.arange(k + 1, k + 2 + ns)  # os_hv ... on_hv (ns+1 nodes)
        net.on_hv = int(net.cable_nodes[-1])
        net.pcc = net.on_hv + 1
        net.sc = net.pcc + 1

    def turbine_bus(self, net, k: int) -> int:
        return int(net.cluster_nodes[net.cluster_of[k]])

    def add_elements(self, net, el: Elements) -> None:
        g = net.p.grid
        za, ba = net._cable(g.array_km, g.array_r_ohm_km, g.array_l_mh_km, g.array_c_nf_km, g.v_array_kv)
        for cn in net.cluster_nodes:
            pi_section(el, int(cn), net.os_mv, za, ba)
        el.rl(net.os_mv, net.os_hv, complex(g.r_otr, g.x_otr) * net.sb / g.s_otr_mva)
        ns = g.export_sections
        ze, be = net._cable(g.export_km / ns, g.export_r_ohm_km, g.export_l_mh_km, g.export_c_nf_km, g.v_export_kv)
        for s in range(ns):
            pi_section(el, int(net.cable_nodes[s]), int(net.cable_nodes[s + 1]), ze, be)
        b_comp = g.comp_fraction * be * ns / 2.0  # half of the total charging at each end
        if b_comp > 0.0:  # shunt reactors: admittance -j b_comp = 1/(j x), x = 1/b_comp
            el.rl(net.os_hv, GROUND, 1j / b_comp)
            el.rl(net.on_hv, GROUND, 1j / b_comp)
        el.rl(net.on_hv, net.pcc, net.z_ontr())

    def zero_sequence(self, net) -> list[complex]:
        """The onshore transformer (YNd, grounded star at the pcc) and each plugged onshore unit's
        step-up (its turbine transformers are behind its delta)."""
        zs = [net.z_ontr()]
        for k in range(net.n_farm, net.n):
            if net.plugged[k]:
                zs.append(complex(0.0, net.p.x_onshore_step_up) * net.sb / net.p.onshore_unit_mva)
        return zs


class Single(CollectorLayout):
    """One turbine terminal per converter, each through its transformer straight to the pcc
    (``topology="single"``): node n is the pcc, n+1 the condenser's terminal."""

    def place(self, net) -> None:
        n = net.n
        net.cluster_of = np.zeros(n, dtype=int)
        net.cluster_nodes = np.array([], dtype=int)
        net.pcc, net.sc = n, n + 1
        net.os_mv = net.os_hv = net.on_hv = net.pcc

    def turbine_bus(self, net, k: int) -> int:
        return net.pcc


COLLECTORS: dict[str, CollectorLayout] = {
    "farm": RadialFarm(),
    "single": Single(),
}
"""The collector layouts by ``PlantParams.topology``."""


def collector_layout(name: str) -> CollectorLayout:
    if name not in COLLECTORS:
        raise ValueError(f"unknown topology {name!r}: the plant's collector layouts are {', '.join(COLLECTORS)}")
    return COLLECTORS[name]
