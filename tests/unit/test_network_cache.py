"""The network's factorisation cache (plant.network): a state entered again, or prepared ahead,
gives exactly the solve a fresh factorisation gives, without an LU in the step that enters it."""

from __future__ import annotations

import numpy as np

from plant.network import Network
from plant.params import PlantParams


def fresh(**state) -> Network:
    net = Network(PlantParams(), 50)
    for name, value in state.items():
        setattr(net, name, value)
    net.dirty = True
    net.ensure()
    return net


def test_prepared_fault_is_entered_without_a_factorisation_and_solves_alike():
    net = Network(PlantParams(), 50)
    net.prepare(fault_on=True)
    assert not net.fault_on and not net.dirty  # the present state is untouched
    before = net.zred
    hits = net.cache_hits
    net.set_fault(True)
    net.ensure()
    assert net.cache_hits == hits + 1 and net.zred is not before
    ref = fresh(fault_on=True)
    for name in ("zred", "zcols", "zinv", "z2col"):
        np.testing.assert_allclose(getattr(net, name), getattr(ref, name), rtol=1e-12, atol=1e-14)
    assert net.z2 == ref.z2 and net.z0 == ref.z0


def test_clearing_the_fault_returns_to_the_pre_fault_solve():
    net = Network(PlantParams(), 50)
    pre = net.zred.copy()
    net.set_fault(True)
    net.ensure()
    net.set_fault(False)
    n = net.n_factorizations
    net.ensure()
    np.testing.assert_array_equal(net.zred, pre)
    assert net.n_factorizations == n + 1  # still counted as a change (the model re-reads the network)


def test_every_state_variable_is_part_of_the_key():
    net = Network(PlantParams(), 50)
    base = net.zred.copy()
    for change in ({"scr": 2.0}, {"sc_connected": not net.sc_connected}):
        for name, value in change.items():
            old = getattr(net, name)
            setattr(net, name, value)
            net.dirty = True
            net.ensure()
            assert not np.allclose(net.zred, base), name
            setattr(net, name, old)
            net.dirty = True
            net.ensure()
            np.testing.assert_array_equal(net.zred, base)
    net.set_plugged([3], False)
    net.ensure()
    assert not np.allclose(net.zred, base)


def test_the_plant_service_prepares_the_fault_and_the_timelines_scr_values(tmp_path):
    from plant.service.model import build_model
    from sdvisc.config import PlantConfig

    cfg = PlantConfig(step_s=0.00067, out_dir=str(tmp_path), duration_s=1.0, model="full", prepare_scr=[1.51],
                      turbines=[{"name": "wt1_1", "wid": 101, "ip": "10.0.1.1"}])
    plant, _ = build_model(cfg, ["wt1_1"])
    net = plant.net
    hits = net.cache_hits
    for change in (lambda: net.set_fault(True), lambda: net.set_scr(1.51), lambda: net.set_fault(False)):
        change()
        net.ensure()
    assert net.cache_hits == hits + 3  # fault at the base SCR, SCR 1.51 under the fault, then cleared
