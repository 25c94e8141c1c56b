"""The compiled Tustin engine of DiscreteVisc gives the reference (block-by-block) trajectory.

The run covers what the fast paths restructure: the limiter engaging and releasing (a deep dip
with a large current), a NaN measurement, run-time parameter changes (bumpless and not),
deactivation and re-initialisation, warm-standby tracking of one instance, float64 and float32.
"""

from __future__ import annotations

import hashlib
import inspect
from types import SimpleNamespace

import numpy as np
import pytest

from sdc_unit import engines, law_kernels, tustin_jit
from sdc_unit.discrete import DiscreteVisc
from sdc_unit.params import ViscParams
from sdvisc.vocabulary import MEAS_FIELDS

N = 6


def _meas(k, rng_ops):
    vm, ang, p0, q0 = rng_ops
    fault = 1000 <= k < 1400
    v = (0.3 if fault else 1.0) * vm * (1 + 0.002 * np.sin(k * 0.1 + ang * 10)) * np.exp(1j * (ang + 1e-4 * k))
    i = np.conj((p0 + 1j * q0) * (1 + 0.01 * np.cos(k * 0.05)) / (vm * np.exp(1j * ang))) * (3.0 if fault else 1.0)
    s = v * np.conj(i)
    d = dict(v_d=v.real, v_q=v.imag, i_d=i.real, i_q=i.imag, p=s.real, q=s.imag, v_dc=np.ones(N),
             omega_meas=1 + 1e-4 * np.sin(k * 0.01) * np.ones(N))
    if k % 97 == 0:
        d["q"] = d["q"].copy()
        d["q"][k % N] = np.nan
    return SimpleNamespace(**d)


def _trajectory(engine, dtype, steps=2200):
    rng = np.random.default_rng(1)
    ops = (rng.uniform(0.98, 1.03, N), rng.uniform(0, 0.15, N), rng.uniform(0.2, 0.9, N), rng.uniform(-0.2, 0.2, N))
    dv = DiscreteVisc(N, ViscParams(), ts=0.67e-3, method="tustin", dtype=dtype, engine=engine)
    dv.initialise([0, 1, 2, 3, 4], _meas(0, ops))
    rows, limited = [], []
    for k in range(1, steps):
        if k == 500:
            dv.set_params([1, 2], h=5.0, v_ref=1.02)
        if k == 700:
            dv.deactivate([3])
        if k == 800:
            dv.initialise([3, 5], _meas(k, ops))
        if k == 900:
            dv.set_params(0, supp=1.0)
        if k == 1600:
            dv.set_params([4], bumpless=False, m_q=0.07)
        if k % 3 == 0:
            dv.track(_meas(k, ops), index=[5])
        o = dv.step(_meas(k, ops))
        rows.append(np.concatenate([o.v_ref_d, o.v_ref_q, o.i_ref_d, o.i_ref_q, o.delta, o.omega, o.e_mag,
                                    o.v_f, o.p_e, o.valid]))
        limited.append(o.limited)
    snap = dv.snapshot(2)
    return np.array(rows), np.array(limited), np.array([snap[key] for key in sorted(snap)])


# float32: measured max 6.6e-7 (outputs) and 4.8e-7 (states), no limiter flag differing; bound ~5x that
@pytest.mark.parametrize("dtype, tol", [(np.float64, 0.0), (np.float32, 3e-6)])
def test_jit_engine_matches_the_blocks(dtype, tol):
    ref, lim_ref, snap_ref = _trajectory("blocks", dtype)
    got, lim, snap = _trajectory("jit", dtype)
    assert 0.05 < lim_ref.mean() < 0.95  # the limiter really engaged and released
    # float64: bit-identical; float32: the compiled cosf/sinf differ from numpy's by an ulp now and then
    assert np.max(np.abs(got - ref)) <= tol and np.max(np.abs(snap - snap_ref)) <= tol
    assert np.mean(lim != lim_ref) <= (0 if tol == 0 else 1e-3)


def test_engine_is_checked():
    with pytest.raises(ValueError):
        DiscreteVisc(2, engine="fortran")
    with pytest.raises(ValueError):
        DiscreteVisc(2, method="euler", engine="jit")


def test_without_numba_auto_fails_loudly_and_blocks_still_run(monkeypatch):
    """numba is a declared dependency: a Tustin controller never falls back to the slow path
    silently (engine "auto" raises); the reference engine and the other methods do not need it."""
    assert engines.jit is tustin_jit  # installed here: the compiled step is what "auto" uses
    assert isinstance(DiscreteVisc(2).engine, engines.CompiledEngine)
    monkeypatch.setattr(engines, "jit", None)
    for engine in ("auto", "jit"):
        with pytest.raises(RuntimeError, match="numba"):
            DiscreteVisc(2, engine=engine)
    assert isinstance(DiscreteVisc(2, engine="blocks").engine, engines.BlockEngine)
    assert isinstance(DiscreteVisc(2, method="euler").engine, engines.BlockEngine)


def test_compiled_step_cache_follows_the_law_kernels_source():
    """numba stamps its on-disk cache with tustin_jit.py only; the step's closure carries a hash of
    law_kernels.py (which it compiles in) and of the measurement rows, so an edit there cannot load
    a stale step."""
    text = inspect.getsource(law_kernels) + repr(MEAS_FIELDS)
    key = int(hashlib.sha256(text.encode()).hexdigest()[:15], 16)
    assert [c.cell_contents for c in tustin_jit.tustin_step.py_func.__closure__] == [key]
    assert [c.cell_contents for c in tustin_jit.tustin_step_slots.py_func.__closure__] == [key]


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_stepping_a_list_of_slots_equals_stepping_a_mask(dtype):
    """The SDC bank steps the slots of a round (tustin_step_slots); the same samples stepped with
    a mask over the whole bank (tustin_step) give bit-identical states, outputs and validity --
    limiter, NaN samples and slots left out of some rounds included."""
    ops = (np.linspace(0.98, 1.03, N), np.linspace(0.0, 0.15, N), np.linspace(0.2, 0.9, N), np.linspace(-0.2, 0.2, N))
    by_slots, by_mask = (DiscreteVisc(N, ViscParams(), dtype=dtype) for _ in range(2))
    for dv in (by_slots, by_mask):
        dv.initialise(None, _meas(0, ops))
    engaged = False
    for k in range(1, 1500):
        m = _meas(k, ops)
        rows = np.array([getattr(m, f) for f in MEAS_FIELDS])
        slots = np.array([s for s in range(N) if (k + s) % 5 and np.isfinite(rows[:, s]).all()], dtype=np.intp)
        ok, outputs, limited = by_slots.advance_slots(slots, rows[:, slots])
        stepping = np.zeros(N, dtype=bool)
        stepping[slots] = True
        full = np.where(stepping, rows, 0.0)
        ok_mask = by_mask.advance(full, stepping)
        assert ok.tolist() == ok_mask[slots].tolist()
        assert np.array_equal(outputs, np.array([by_mask.last[f] for f in engines.OUT_FIELDS])[:, slots])
        assert limited.tolist() == by_mask.last_limited[slots].tolist()
        engaged = engaged or bool(limited.any())
    assert engaged  # the deep dip of the samples 1000..1400 drove the limiter
    for f in engines.OUT_FIELDS:
        assert np.array_equal(by_slots.last[f], by_mask.last[f])
    for name, block in by_slots.blocks.items():
        for state, value in block.s.items():
            assert np.array_equal(value, by_mask.blocks[name].s[state]), (name, state)
