"""The EMT arrangement as a plant-service backend (plant/emt/service_backend.py, ``plant.model: emt``):
the one backend interface, the service's core around it with GTNET-SKT datagrams, CTRL applied as the
converter's reference every Ts, and the SDC's Tustin law closing the loop through the wire encoding.

Tolerances: at rest within 0.5 % of the phasor plant's operating point over 50 ms of the unit's own law;
under the SDC's Tustin law settled (< 0.2 % peak to peak over 50 ms) within 1.5 % of it (measured: the
terminal settles from 1.0125 to 1.0011 p.u. in ~0.3 s, both under the unit's own law and the SDC's, i.e.
the EMT circuit's equilibrium, not the loop's; docs/plant.md, "EMT through the network"); a +5 % converter
voltage reference must move the terminal voltage by more than 1 % (hand phasor ≈ +3.7 %, issue 40's probe);
after an SLG fault the terminal comes back within 2 % of its pre-fault value."""

from __future__ import annotations

import numpy as np
import pytest

from plant import settable
from plant import turbine as T
from plant.backend import PlantBackend, close_backend
from plant.emt.service_backend import EmtServiceBackend
from plant.emt.service_loop import emt_core, sdc_loop, start_stream
from plant.minimal import MinimalPlant
from sdvisc.vocabulary import MEAS_FIELDS

TS = 0.67e-3


@pytest.fixture(scope="module")
def backend_factory():
    made = []

    def make(**kw):
        b = EmtServiceBackend(50, TS, duration_s=1.0, **kw)
        made.append(b)
        return b
    yield make
    for b in made:
        close_backend(b)


def run(b, seconds: float, each=None) -> np.ndarray:
    """Step ``b`` for ``seconds``; returns |v_t| after each step (``each(b)`` before each step)."""
    out = []
    for _ in range(int(round(seconds / TS))):
        if each is not None:
            each(b)
        b.step()
        out.append(abs(b.v_t))
    return np.array(out)


def test_every_model_implements_the_backend_interface(backend_factory):
    from plant.sim import Plant

    for model in (MinimalPlant(2), Plant(n_turbines=50, jit=False), backend_factory()):
        assert isinstance(model, PlantBackend), type(model)
    assert settable.model_class("emt") is EmtServiceBackend
    assert settable.settable_params(EmtServiceBackend) == ["sc_connected"]
    assert settable.supported_actions(EmtServiceBackend) == ["fault"]


def test_at_rest_with_measurements_per_converter_and_commands_refused_clearly(backend_factory):
    b = backend_factory()
    v0 = abs(b.op.v_terminal)
    v = run(b, 0.05)
    assert np.max(np.abs(v / v0 - 1.0)) < 5e-3
    m = b.measurements()
    assert set(m) == set(MEAS_FIELDS) and all(len(m[k]) == b.n == 51 for k in m)
    assert m["omega_meas"][b.unit] == pytest.approx(1.0, abs=1e-3)
    assert abs(complex(m["v_d"][b.unit], m["v_q"][b.unit])) == pytest.approx(v0, rel=5e-3)
    rec = b.recorded()
    assert rec["t"] == pytest.approx(b.k * TS) and rec["f_pcc_hz"] == pytest.approx(50.0, abs=0.05)
    assert rec["mode"][b.unit] == T.HD_VISC and rec["mode"][0] == T.GFL
    b.set_sc_connected(False)
    with pytest.raises(ValueError, match="no SC"):
        b.set_sc_connected(True)
    with pytest.raises(ValueError, match="only the onshore unit"):
        b.set_mode(3, "remote")


def test_ctrl_is_the_converters_reference_each_ts_and_its_loss_falls_back(backend_factory):
    b = backend_factory(remote_loss_fallback_s=0.05)
    b.set_mode(b.unit, "remote")
    v_ref = b.op.e_source * 1.05
    held = abs(b.v_t)
    v = run(b, 0.04, lambda m: m.apply_remote(np.array([m.unit]), np.array([v_ref.real]), np.array([v_ref.imag])))
    assert v[-1] / held - 1.0 > 0.01 and b.mode[b.unit] == T.REMOTE
    run(b, 0.06)  # no CTRL for 60 ms > 50 ms
    assert b.mode[b.unit] == T.HD_VISC and b.fallbacks[b.unit] == 1


def test_the_service_core_closes_the_sdc_loop_on_the_emt_plant_and_rides_through_a_fault():
    core = emt_core()
    try:
        wt6, wt1 = core.endpoints
        assert core.model.n == 51 and [wt6.index, wt1.index] == [50, 0]
        start_stream(core, "wt1_1")
        assert not wt1.streaming and wt1.counts.get("rx_reject_internal") == 1  # aggregated: no converter
        start_stream(core, "wt6_1")
        assert wt6.streaming and core.model.mode[core.model.unit] == T.REMOTE
        v0 = abs(core.model.op.v_terminal)
        n_rest, n_on, n_off = (int(round(s / TS)) for s in (0.15, 0.25, 0.45))
        v = sdc_loop(core, 0.45, fault={n_rest: True, n_on: False})
        settled = v[n_rest - int(0.05 / TS):n_rest]  # the law's slow settling from the phasor operating point
        assert np.ptp(settled) < 2e-3 and abs(settled[-1] / v0 - 1.0) < 0.015  # at rest under the SDC's CTRL
        assert np.min(v[n_rest:n_on]) < 0.9 * settled[-1]  # the fault is seen at the terminal
        assert abs(v[-1] / settled[-1] - 1.0) < 0.02 and np.all(np.isfinite(v))
        steps = len(v)
        assert wt6.counts["meas_tx"] == steps and wt6.counts["ctrl_rx"] == steps - 1
        assert wt6.rtt_samples[0] == steps - 1  # every CTRL answers the newest MEAS: applied in the next step
        assert core.model.fallbacks[core.model.unit] == 0 and wt6.ak_ones == wt6.counts["ak_tx"] - 1
        assert [e["type"] for e in core.events_applied] == ["stream_start", "ctrl_started", "fault", "fault"]
    finally:
        close_backend(core.model)


@pytest.mark.parametrize("i_max_local", [0.0, 1.5], ids=["no_local_limit", "local_limit"])
def test_a_stall_holding_every_ctrl_a_step_longer_is_ridden_out_only_with_the_local_current_limit(i_max_local):
    """plant.emt.service_backend.REMOTE_LOOP_MEASURED: 0.1 s of CTRLs one sample late (a stall's catch-up)
    makes the v_ref loop grow on the EMT circuit; the converter's local current limit (TurbineParams.i_max_local,
    the phasor plant's) bounds it and the loop is back at rest once the one-sample loop resumes; without the
    limit it runs away (> 100 p.u., what the SDC rejects as out of range)."""
    core = emt_core()
    core.model.i_max_local = i_max_local
    try:
        start_stream(core)
        stall = range(int(0.1 / TS), int(0.2 / TS))
        with np.errstate(all="ignore"):
            v = sdc_loop(core, 0.5, late_steps=stall)
        before = v[stall.start - 1]
        if i_max_local:
            assert np.nanmax(v) < 5.0 and abs(v[-1] / before - 1.0) < 0.01
        else:
            assert not np.all(np.isfinite(v)) or np.nanmax(v) > 100.0
    finally:
        close_backend(core.model)


def test_the_pll_follows_a_frequency_offset_of_the_measured_phasor():
    """A phasor turning at +0.5 Hz in the common frame is a 50.5 Hz voltage: the PLL's speed settles at
    1.01 p.u. (within 1e-4 after 2 s; its bandwidth ~ OMEGA0 kp = 79 rad/s, integral 10/s)."""
    from plant.emt.service_backend import Pll

    pll = Pll(0.25, 10.0, 1.0 + 0j)
    for k in range(int(2.0 / TS)):
        omega = pll.update(np.exp(2j * np.pi * 0.5 * k * TS), TS)
    assert omega == pytest.approx(1.01, abs=1e-4)


def test_plant_emt_from_the_command_line_is_checked_as_the_scenarios_key():
    from pathlib import Path

    from scenarios.loader import Override, ScenarioError, load_scenario

    root = Path(__file__).resolve().parents[2]
    emt = Override("--plant", "emt", ("plant", "model"), "emt")
    assert load_scenario(root / "scenarios" / "paper" / "f6_slg_fault_current.yaml", [emt]).plant.model == "emt"
    with pytest.raises(ScenarioError, match=r"--plant emt: plant.model: .*onshore_units: 1"):
        load_scenario(root / "scenarios" / "smoke.yaml", [emt])  # no onshore unit: nothing to drive
    with pytest.raises(ScenarioError, match=r"--plant emd: plant.model: Input should be"):
        load_scenario(root / "scenarios" / "smoke.yaml", [Override("--plant", "emd", ("plant", "model"), "emd")])


def test_remote_apply_i_ref_tracks_the_sdcs_current_reference_at_rest():
    """``remote_apply: i_ref``: the converter's own current loop on the SDC's limited current reference
    (the phasor plant's law, the active damping's low-pass fed forward) holds the unit at rest."""
    core = emt_core(remote_apply="i_ref")
    try:
        start_stream(core)
        v = sdc_loop(core, 0.3)
        settled = v[-int(0.05 / TS):]
        assert np.ptp(settled) < 2e-3 and abs(settled[-1] / abs(core.model.op.v_terminal) - 1.0) < 0.015
        assert core.model.fallbacks[core.model.unit] == 0
    finally:
        close_backend(core.model)
