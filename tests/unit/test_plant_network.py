"""Network solve, factorisation bookkeeping and the fault equivalent (validation item 3)."""

import numpy as np
import pytest

from plant.network import Network
from plant.params import PlantParams
from plant.sim import Plant


def test_prefactorised_solve_equals_direct_numpy_solve():
    net = Network(PlantParams(), 50)
    rng = np.random.default_rng(1)
    for _ in range(3):
        inj = rng.normal(size=net.n_nodes) + 1j * rng.normal(size=net.n_nodes)
        ref = np.linalg.solve(net.build_y(), inj)
        assert np.allclose(net.solve(inj), ref, rtol=1e-10, atol=1e-12)
        assert np.allclose(net.solve_lu(inj), ref, rtol=1e-10, atol=1e-12)
    net.set_fault(True, 0.01)
    net.ensure()
    inj = rng.normal(size=net.n_nodes) + 0j
    assert np.allclose(net.solve(inj), np.linalg.solve(net.build_y(), inj), rtol=1e-10, atol=1e-12)


def test_refactorisation_only_on_topology_scr_fault_changes():
    p = Plant(n_turbines=50)
    net = p.net
    n0 = net.n_factorizations
    for _ in range(20):
        p.step()
    p.load_step(50.0)
    p.set_avr_ref(1.02)
    p.set_power_ref([0, 1], p=0.5)
    p.set_mode(3, "remote")
    for _ in range(5):
        p.step()
    assert net.n_factorizations == n0, "steps, loads, references and modes must not refactor"
    p.set_scr(2.04)
    assert net.n_factorizations == n0 + 1
    p.plug(7, False)
    assert net.n_factorizations == n0 + 2
    p.fault(True)
    n_fault = net.n_factorizations
    assert n_fault == n0 + 4  # one solve for Z2 plus the refactorisation
    for _ in range(5):
        p.step()
    p.fault(False)
    assert net.n_factorizations == n_fault + 1
    print("factorisations:", net.n_factorizations - n0)


def test_grid_impedance_from_scr():
    net = Network(PlantParams(), 50)
    for scr in (7.14, 2.04, 1.58, 1.51):
        net.set_scr(scr)
        z = net.z_grid()
        assert abs(z) == pytest.approx(1.0 / scr)
        assert z.real / z.imag == pytest.approx(0.1)


def test_fault_shunt_is_z2_plus_z0_plus_3zf():
    net = Network(PlantParams(), 50)
    y = net.build_y(with_fault=False)
    e = np.zeros(net.n_nodes, dtype=complex)
    e[net.pcc] = 1.0
    z2 = np.linalg.solve(y, e)[net.pcc]
    zf = 0.002 + 0.01j
    net.set_fault(True, zf)
    net.ensure()
    dy = net.y[net.pcc, net.pcc] - y[net.pcc, net.pcc]
    assert 1.0 / dy == pytest.approx(z2 + net.z0 + 3 * zf)
    # bolted fault on an ideal source with only the grid: V1 = (Z2+Z0)/(Z1+Z2+Z0) roughly 0.5-0.7
    assert 0.3 < abs((z2 + net.z0) / (z2 + net.z0 + net.z_grid())) < 0.8


def test_reduced_solve_equals_full_solve():
    rng = np.random.default_rng(2)
    for fault, unplug in ((False, False), (True, True)):
        net = Network(PlantParams(), 50)
        if unplug:
            net.set_plugged([3, 17], False)
        net.set_fault(fault, 0.01)
        net.ensure()
        i_t = rng.normal(size=50) + 1j * rng.normal(size=50)
        e_g, e_sc, i_l = 1.0 + 0.1j, 0.98 - 0.05j, 0.1 + 0.02j
        full = net.solve(net.injections(i_t, e_g, e_sc, i_l))
        u = net.reduced_u(i_t, e_g, e_sc, i_l)
        assert np.allclose(net.zcols @ u, full, rtol=1e-12, atol=1e-13)
        assert np.allclose(net.zred @ u, full[net.red_idx], rtol=1e-12, atol=1e-13)
