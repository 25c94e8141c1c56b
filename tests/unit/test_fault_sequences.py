"""The PCC fault's sequence networks (plant/network.py): the two-phase-to-ground fault's sequence
currents against the closed form on a small network, the zero-sequence impedance with the step-ups
in and out of service, and the phase voltages from the sequence ones against a hand computation."""

from __future__ import annotations

import numpy as np
import pytest

from plant.network import Network, phase_phasors
from plant.params import PlantParams
from report.fault_readings import FAULTED_PHASES, ohm_to_pu, readings, resistance_for

A = np.exp(2j * np.pi / 3.0)


def _single(sc: bool = True) -> Network:
    pp = PlantParams(topology="single", sc_connected=sc)
    return Network(pp, 1)


def _pcc_voltage(net: Network, e_grid: complex = 1.0) -> np.ndarray:
    """Node voltages with the grid source only (the converter injects nothing, the SC's EMF shorted)."""
    net.ensure()
    return net.solve(net.injections(np.zeros(net.n, dtype=complex), e_grid, 0.0, 0.0))


@pytest.mark.parametrize("z_f", [0.0, 0.05])
def test_two_phase_to_ground_sequence_currents_match_the_closed_form(z_f):
    net = _single()
    v_pre = _pcc_voltage(net)[net.pcc]
    net.set_fault(True, z_f, "llg")
    v = _pcc_voltage(net)
    i1, v2, v0 = net.fault_sequences(v)
    z1 = z2 = net.z2  # passive network: Z1 = Z2 (the Thevenin impedance of the fault-free Y at the pcc)
    z0f = net.z0 + 3 * z_f
    # closed form (e.g. Grainger & Stevenson, Power System Analysis, sec. 12.4): I1 = V_pre/(Z1 + Z2 || (Z0 + 3Zf))
    i1_ref = v_pre / (z1 + z2 * z0f / (z2 + z0f))
    i2_ref, i0_ref = -i1_ref * z0f / (z2 + z0f), -i1_ref * z2 / (z2 + z0f)
    assert i1 == pytest.approx(i1_ref, rel=1e-9)
    assert -v2[net.pcc] / z2 == pytest.approx(i2_ref, rel=1e-9)
    assert -v0 / net.z0 == pytest.approx(i0_ref, rel=1e-9)
    assert abs(i1_ref + i2_ref + i0_ref) < 1e-12  # no current returns through the unfaulted phase a
    va, vb, vc = phase_phasors(v[net.pcc], v2[net.pcc], v0)
    assert vb == pytest.approx(3 * z_f * i0_ref, abs=1e-12) and vc == pytest.approx(vb, abs=1e-12)
    assert abs(va) > 0.5  # the healthy phase


def test_single_phase_to_ground_faulted_phase_is_the_fault_resistance_drop():
    net = _single()
    net.set_fault(True, 0.04, "slg")
    v = _pcc_voltage(net)
    i_f, v2, v0 = net.fault_sequences(v)
    va = phase_phasors(v[net.pcc], v2[net.pcc], v0)[0]
    assert va == pytest.approx(3 * 0.04 * i_f, rel=1e-9)  # V_a = 3 Z_f I_f (I1 = I2 = I0 = I_f)


def test_zero_sequence_has_a_step_up_only_while_its_side_is_in_service():
    zg = lambda net: net.p.grid.k0_grid * net.z_grid()  # noqa: E731
    par = lambda *zs: 1 / sum(1 / z for z in zs)  # noqa: E731
    on, off = _single(sc=True), _single(sc=False)
    assert on.z_zero() == pytest.approx(par(zg(on), on.z_sc_tr()))
    assert off.z_zero() == pytest.approx(zg(off))  # the SC out: its YNd step-up grounds nothing
    pp = PlantParams(sc_connected=False, onshore_units=1)
    farm = Network(pp, 51)
    z_unit = 1j * pp.x_onshore_step_up * pp.grid.s_base_mva / pp.onshore_unit_mva
    assert farm.z_zero() == pytest.approx(par(zg(farm), farm.z_ontr(), z_unit))
    farm.set_plugged(50, False)
    assert farm.z_zero() == pytest.approx(par(zg(farm), farm.z_ontr()))


def test_phase_voltages_from_sequences_against_a_hand_computation():
    # V1 0.6, V2 = V0 = -0.3 (a bolted SLG on a bus with Z1 = Z2 = Z0): by hand V_a = 0,
    # V_b = 0.6 a² - 0.3 a - 0.3 = -0.45 - j 0.7794, V_c = its conjugate: |V_b| = |V_c| = 0.9
    va, vb, vc = phase_phasors(0.6, -0.3, -0.3)
    assert abs(va) < 1e-12
    assert vb == pytest.approx(-0.45 - 0.45 * np.sqrt(3) * 1j) and vc == pytest.approx(np.conj(vb))
    assert abs(vb) == pytest.approx(0.9)
    ph = np.abs(np.array([[va, vb, vc]]))
    r = {"v_pcc": np.array([0.6]), "v_pcc_ph": ph}
    got = readings(r, np.array([True]), "slg")
    assert got["faulted_phase"] == pytest.approx(0.0, abs=1e-12)
    # three-phase RMS = sqrt((|Va|² + |Vb|² + |Vc|²)/3) = sqrt(|V1|² + |V2|² + |V0|²) = sqrt(0.54)
    assert got["three_phase_rms"] == pytest.approx(np.sqrt(0.54))
    assert readings(r, np.array([True]), "llg")["faulted_phase"] == pytest.approx(0.9)
    assert FAULTED_PHASES["llg"] == [1, 2]


def test_ohms_and_the_resistance_search():
    assert ohm_to_pu(320.0, 500.0) == pytest.approx(1.0)  # 400 kV on 500 MVA: Z_base 320 Ω
    assert resistance_for(0.4, lambda r: r / 50.0, 50.0) == pytest.approx(20.0, abs=0.1)
    assert resistance_for(0.4, lambda r: 0.5 + r, 50.0) is None  # never as low as 0.4


def test_a_fault_kind_outside_the_set_is_refused():
    with pytest.raises(ValueError, match="fault kind"):
        _single().set_fault(True, 0.0, "lll")
