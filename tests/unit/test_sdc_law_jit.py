"""The continuous ViSC law compiled (sdc_unit.law_jit.law_rhs, one turbine's columns) against the
same equations on arrays (sdc_unit.law.evaluate): both run sdc_unit.law_kernels.law_rhs, so
derivatives and outputs must be bit-identical in float64 -- limited and unlimited turbines, every
flag on and off, per-turbine parameter arrays. And the plant's cached hd_visc kernels carry the hash
of what they compile in (law_kernels.py and the plant kernels' sources) in their cache key, as do
the plant's other cached entry points (plant/kernels.py)."""

import hashlib
import inspect

import numpy as np
import pytest
from numba import njit

from plant import (
    condenser,
    integrator,
    kernels,
    layout,
    slots,
    turbine,
    turbine_kernels,
    turbine_laws,
    visc_kernels,
)
from sdc_unit import law, law_kernels
from sdc_unit.law_jit import law_rhs
from sdc_unit.params import ViscParams
from sdvisc.vocabulary import MEAS_FIELDS

N = 240


@njit
def _columns(x, m, c, dx, out):
    for k in range(x.shape[1]):
        law_rhs(x[:, k], m[:, k], c[:, k], dx[:, k], out[:, k])


def _case(rng, scale):
    """States around the operating point (scale 0.05: none limited) to far off it (most limited)."""
    x = rng.normal(size=(law.NX, N)) * 0.3 * scale
    x[law.IX_VFD] += 1.0
    m = rng.normal(size=(len(law_kernels.MEAS_ROWS), N))
    m[law_kernels.M_OMEGA] = 1.0 + 0.01 * m[law_kernels.M_OMEGA]
    return x, m


PARAMS = {
    "default": ViscParams(),
    "flags": ViscParams(supp=True, omega_s_measured=True, ff_filtered=True, freeze_vf_when_limited=True,
                        avr_antiwindup=False, r_v=0.01),
    "arrays": ViscParams(h=np.linspace(2.0, 5.0, N), m_q=np.linspace(0.01, 0.1, N), supp=np.arange(N) % 2 == 0,
                         omega_s_measured=np.arange(N) % 3 == 0, v_ref=np.linspace(0.98, 1.02, N)),
}


def test_layouts_are_the_laws():
    assert law_kernels.MEAS_ROWS == tuple(law.Measurements.__dataclass_fields__) == MEAS_FIELDS
    assert set(law_kernels.PARAM_ROWS) - {"omega0"} <= set(ViscParams.field_names())
    assert set(law_kernels.OUT_ROWS) <= set(law.Outputs.__dataclass_fields__)


@pytest.mark.parametrize("name", sorted(PARAMS))
def test_compiled_law_is_bit_identical_to_the_numpy_law(name):
    p = PARAMS[name]
    rng = np.random.default_rng(7)
    limited = []
    for scale in (0.05, 1.0, 10.0):
        x, m = _case(rng, scale)
        dx_np, out_np = law.evaluate(x, law.Measurements(*m), p)
        dx, rows = np.empty_like(x), np.empty((len(law_kernels.OUT_ROWS), N))
        _columns(x, m, law.param_rows(p, N), dx, rows)
        assert np.array_equal(dx, dx_np)
        out = law.outputs_from_rows(x, rows)
        for field in law.Outputs.__dataclass_fields__:
            assert np.array_equal(getattr(out, field), getattr(out_np, field)), field
        assert np.array_equal(law.derivatives(x, law.Measurements(*m), p), dx_np)
        limited.append(int(out.limited.sum()))
    assert limited[0] < N and limited[-1] > 0, limited  # both branches of the limiter ran


def _key(*modules) -> int:
    text = "".join(inspect.getsource(mod) for mod in (law_kernels, *modules))
    return int(hashlib.sha256(text.encode()).hexdigest()[:15], 16)


def test_plant_visc_kernels_cache_key_follows_their_sources():
    key = _key(kernels, turbine_kernels, turbine_laws, integrator, slots, turbine, condenser, layout)
    for entry in (visc_kernels.evaluate_visc, visc_kernels.step_visc):
        assert [c.cell_contents for c in entry.py_func.__closure__] == [key]


def test_plant_kernels_cache_key_follows_their_sources():
    """The turbines' equations (turbine_kernels.py, turbine_laws.py) are compiled into the cached
    entry points of plant/kernels.py: an edit of either must change their key."""
    key = _key(turbine_kernels, turbine_laws, integrator, slots, turbine, condenser, layout)
    for entry in (kernels.evaluate, kernels.evaluate_given_network, kernels.step, kernels.evaluate_network,
                  kernels.hold_slow_terms):
        assert [c.cell_contents for c in entry.py_func.__closure__] == [key]
