"""The compiled path: packs what the kernels (plant/kernels.py) need and runs them.

``CompiledPath`` holds no reference to the plant: every call gets the state and the arrays it
reads passed in, and returns new arrays (an evaluation never overwrites arrays handed out
earlier). The plant decides where it applies (``covers``) and keeps its own bookkeeping. With
hd_visc turbines the evaluation and the step are those of plant/visc_kernels.py (the ViSC law
compiled in). Batteries are evaluated at the SOC ``turbines.batt.soc`` the plant holds over a step.
"""

from __future__ import annotations

import numpy as np

from plant import kernels, visc_kernels
from plant.condenser import NX as SC_NX
from plant.integrator import etd2_correct, etd2_predict
from plant.layout import GRID_NX, PLL_NX, StateLayout
from plant.slots import Const, Row, Scalar, Slow, battery_constants, pack, slow_constants, turbine_gains
from plant.turbine import NS
from sdc_unit.law import outputs_from_rows
from sdc_unit.law_kernels import NX as LAW_NX
from sdc_unit.law_kernels import OUT_ROWS, PARAM_ROWS
from sdvisc.vocabulary import MEAS_FIELDS


class SlowTerms(dict):
    """``TurbineBank.slow_terms``'s dict from the compiled slow terms; P* - jQ* built on demand."""

    __slots__ = ("rows",)

    def __missing__(self, key):
        if key != "sref":
            raise KeyError(key)
        val = self["sref"] = self.rows[Slow.s_ref_re] + 1j * self.rows[Slow.s_ref_im]
        return val


_ROW_KEYS = {"vdc": Row.v_dc, "pme": Row.p_me, "ibatt": Row.i_batt}
_SCALAR_KEYS = {"i_sc": Scalar.i_sc, "e_grid": Scalar.e_grid, "e_sc": Scalar.e_sc, "i_load": Scalar.i_load}


class CompiledAux(dict):
    """The results of a compiled evaluation as the plant's ``aux`` dict (plant/equations.py),
    each entry built on first access from the buffer ``out`` and ``rows``; the measurement dict
    and ``v_pcc`` at once (the plant reads them after every step). ``law``: (law states, law
    output rows) of the hd_visc turbines, or None."""

    __slots__ = ("_source",)

    def __init__(self, out, rows, n: int, size: int, law=None):
        o = 2 * size  # out = [X+ | dX | node_v | scalars] (kernels.split)
        self["v_pcc"] = complex(out[o + n])
        self["meas"] = dict(zip(MEAS_FIELDS, rows))
        self._source = (out, rows, n, o, law)

    def __missing__(self, key):
        out, rows, n, o, law = self._source
        if key == "v":
            val = out[o:o + n]
        elif key == "node_v":
            val = out[o:o + n + 2]
        elif key == "i":
            val = rows[Row.i_d] + 1j * rows[Row.i_q]
        elif key == "vconv":
            val = rows[Row.v_conv_re] + 1j * rows[Row.v_conv_im]
        elif key in _ROW_KEYS:
            val = rows[_ROW_KEYS[key]]
        elif key == "pbatt":
            val = rows[Row.v_dc] * rows[Row.i_batt]
        elif key == "v_sc":
            val = complex(out[o + n + 1])
        elif key in _SCALAR_KEYS:
            val = complex(out[o + n + 2 + _SCALAR_KEYS[key]])
        elif key == "f_pcc_pu":
            val = out[o + n + 2 + Scalar.f_pcc_pu].real
        elif key == "law_out":
            val = None if law is None else outputs_from_rows(*law)
        else:
            raise KeyError(key)
        self[key] = val
        return val


class CompiledPath:
    """The usual case of the plant's evaluations and steps, compiled."""

    def __init__(self, turbine_params, layout: StateLayout, batteries):
        self.n, self.size = layout.n, layout.size
        self.constants = np.zeros(len(Const))
        pack(turbine_gains(turbine_params), self.constants)
        pack(slow_constants(turbine_params), self.constants)
        pack(battery_constants(batteries), self.constants)
        self.held = None  # the SlowTerms of the last hold_slow
        self._out_size = 2 * self.size + self.n + 2 + kernels.N_SCALARS  # kernels.split
        self._rows_shape = (len(Row), self.n)
        self.z_planes = None
        self._z_source = None
        load_kernels()

    # ---------------------------------------------------------------- values
    def hold_slow(self, X, turbines) -> SlowTerms:
        """Evaluate the slow mechanical terms of state X (``TurbineBank.slow_terms``, compiled)."""
        rows = np.empty((len(Slow), self.n))
        kernels.hold_slow_terms(X, self.constants, turbines.v_wind, turbines.mppt, turbines.p_cmd,
                                 turbines.q_cmd + turbines.q_wpp, rows)
        rows[Slow.battery_on] = turbines.battery
        held = SlowTerms(paero=rows[Slow.p_aero], pav=rows[Slow.p_avail], inv2hw=rows[Slow.inv_2hw],
                         db=rows[Slow.d_beta], dxb=rows[Slow.d_xbeta], any_batt=bool(turbines.battery.any()))
        held.rows = rows
        self.held = held
        return held

    def set_values(self, values: dict[str, float]) -> None:
        """The operating values (plant.slots.operating_values)."""
        pack(values, self.constants)

    def covers(self, turbines, net) -> bool:
        """True if the compiled path applies: its own slow terms held, all plugged (and the
        network's reduced impedance copied into ``z_planes`` whenever it was rebuilt)."""
        held = self.held
        if held is None or turbines.slow is not held or not net.all_plugged:
            return False
        if net.zred is not self._z_source:
            self.z_planes = np.ascontiguousarray(np.stack([net.zred.real.T, net.zred.imag.T]))
            self._z_source = net.zred
        return True

    def _buffers(self):
        return np.empty(self._out_size, dtype=complex), np.empty(self._rows_shape)

    # ---------------------------------------------------------------- evaluations
    def evaluate(self, X, turbines, v_load: complex):
        """(dX, aux) of state X."""
        out, rows = self._buffers()
        kernels.evaluate(X, v_load, self.constants, self.held.rows, turbines.mode, turbines.v_hold, turbines.i_hold,
                         turbines.batt.soc, self.z_planes, out, rows)
        return out[self.size:2 * self.size], CompiledAux(out, rows, self.n, self.size)

    def solve_network(self, X, v_load: complex):
        """(node voltages [terminals, PCC, SC], sources) of state X: the first half of an
        evaluation, for hd_visc turbines whose law needs the terminal voltages."""
        node_v = np.empty(self.n + 2, dtype=complex)
        sources = kernels.evaluate_network(X, v_load, self.constants, self.z_planes, node_v)
        return node_v, sources

    def evaluate_given_network(self, X, node_v, sources, turbines, v_ext, want_aux: bool):
        """(dX, aux or None) of state X with its network solved and the converter voltages
        ``v_ext`` (held remote references and the law's)."""
        out, rows = self._buffers()
        o = 2 * self.size
        dX, scalars = out[self.size:o], out[o + self.n + 2:]
        out[o:o + self.n + 2] = node_v
        kernels.evaluate_given_network(X, node_v, sources, self.constants, self.held.rows, turbines.mode, v_ext,
                                       turbines.i_hold, turbines.batt.soc, dX, rows, scalars,
                                       want_aux)
        return dX, (CompiledAux(out, rows, self.n, self.size) if want_aux else None)

    def evaluate_visc(self, X, xl, turbines, v_load: complex, visc_idx, law_c, want_aux: bool):
        """(dX, dxl, aux or None) of state X and law states xl of the hd_visc turbines ``visc_idx``
        (law parameters ``law_c``, rows PARAM_ROWS)."""
        out, rows = self._buffers()
        xl = np.ascontiguousarray(xl)
        dxl, law_rows = np.empty_like(xl), np.empty((len(OUT_ROWS), xl.shape[1]))
        visc_kernels.evaluate_visc(X, xl, v_load, self.constants, self.held.rows, turbines.mode, turbines.v_hold,
                                   turbines.i_hold, turbines.batt.soc, self.z_planes, visc_idx, law_c,
                                   out, dxl, rows, law_rows, want_aux)
        aux = CompiledAux(out, rows, self.n, self.size, (xl, law_rows)) if want_aux else None
        return out[self.size:2 * self.size], dxl, aux

    def step_evaluating_first_stage(self, X, coefficients, turbines, v_load: complex, evaluate_next: bool):
        """One ETD2 step of X (``Etd2Coefficients``) whose first stage is evaluated in the same
        compiled call (no hd_visc turbines, no connected batteries): (X+, (dX+, aux+) or None, the
        first stage's PCC voltage). The same step as ``evaluate`` followed by ``step``."""
        out, rows = self._buffers()
        v_pcc = kernels.step_evaluating_first_stage(X, coefficients.rows, v_load, self.constants, self.held.rows,
                                                    turbines.mode, turbines.v_hold, turbines.i_hold,
                                                    turbines.batt.soc, self.z_planes, out, rows, evaluate_next)
        if not evaluate_next:
            return out[:self.size], None, v_pcc
        return out[:self.size], (out[self.size:2 * self.size], CompiledAux(out, rows, self.n, self.size)), v_pcc

    def step(self, X, k1, coefficients, turbines, soc_next, v_load: complex, evaluate_next: bool, law=None):
        """One ETD2 step of X (first stage k1, ``Etd2Coefficients``) and, with hd_visc turbines
        (``law`` = (xl, l1, their Etd2Coefficients, visc_idx, law_c)), of their law states:
        (X+, xl+, (dX+, aux+) or None, dxl+). The second stage is evaluated at the batteries' SOC
        ``turbines.batt.soc``, X+ at ``soc_next`` (the next step's)."""
        out, rows = self._buffers()
        xl_next = dxl = law_rows = None
        soc = turbines.batt.soc
        if law is None:
            kernels.step(X, k1, coefficients.rows, v_load, self.constants, self.held.rows, turbines.mode,
                         turbines.v_hold, turbines.i_hold, soc, soc_next, self.z_planes, out, rows, evaluate_next)
        else:
            xl, l1, law_coefficients, visc_idx, law_c = law
            xl, l1 = np.ascontiguousarray(xl), np.ascontiguousarray(l1)
            xl_next, dxl, law_rows = np.empty_like(xl), np.empty_like(xl), np.empty((len(OUT_ROWS), xl.shape[1]))
            visc_kernels.step_visc(X, k1, coefficients.rows, xl, l1, law_coefficients.rows, v_load, self.constants,
                                   self.held.rows, turbines.mode, turbines.v_hold, turbines.i_hold, soc,
                                   soc_next, self.z_planes, visc_idx, law_c, out, xl_next, dxl, rows, law_rows, evaluate_next)
        x_next = out[:self.size]
        if not evaluate_next:
            return x_next, xl_next, None, None
        aux = CompiledAux(out, rows, self.n, self.size, None if law is None else (xl_next, law_rows))
        return x_next, xl_next, (out[self.size:2 * self.size], aux), dxl


_loaded = False


def load_kernels() -> None:
    """Call every kernel once on a one-turbine dummy (argument types as in a run), so that numba
    loads them from its cache (or compiles them) when a plant is built, not in its first step."""
    global _loaded
    if _loaded:
        return
    size = NS + SC_NX + GRID_NX + PLL_NX
    X, constants, slow = np.ones(size, dtype=complex), np.ones(len(Const)), np.ones((len(Slow), 1))
    mode, v_ext, z_planes = np.zeros(1, dtype=np.int64), np.ones(1, dtype=complex), np.ones((2, 3, 3))
    out, rows = np.empty(2 * size + 3 + kernels.N_SCALARS, dtype=complex), np.empty((len(Row), 1))
    soc = np.ones(1)
    kernels.evaluate(X, 1j, constants, slow, mode, v_ext, v_ext, soc, z_planes, out, rows)
    kernels.step(X, out[size:2 * size], np.ones((3, 2 * size)), 1j, constants, slow, mode, v_ext, v_ext, soc,
                 soc.copy(), z_planes, out, rows, True)
    kernels.step_evaluating_first_stage(X, np.ones((3, 2 * size)), 1j, constants, slow, mode, v_ext, v_ext, soc,
                                        z_planes, out, rows, True)
    node_v = np.ones(3, dtype=complex)
    sources = kernels.evaluate_network(X, 1j, constants, z_planes, node_v)
    kernels.evaluate_given_network(X, node_v, sources, constants, slow, mode, v_ext, v_ext, soc,
                                   out[size:2 * size], rows, out[2 * size + 3:], False)
    kernels.hold_slow_terms(X, constants, np.ones(1), np.ones(1, dtype=bool), np.ones(1), np.ones(1), slow)
    xl, law_c, law_coefficients = np.ones((LAW_NX, 1)), np.ones((len(PARAM_ROWS), 1)), np.ones((3, LAW_NX))
    visc_idx, law_rows = np.zeros(1, dtype=np.int64), np.empty((len(OUT_ROWS), 1))
    visc_kernels.evaluate_visc(X, xl, 1j, constants, slow, mode, v_ext, v_ext, soc, z_planes, visc_idx, law_c,
                               out, xl.copy(), rows, law_rows, True)
    visc_kernels.step_visc(X, out[size:2 * size], np.ones((3, 2 * size)), xl, xl.copy(), law_coefficients, 1j,
                           constants, slow, mode, v_ext, v_ext, soc, soc.copy(), z_planes, visc_idx, law_c, out,
                           xl.copy(), xl.copy(), rows, law_rows, True)
    kernels.remote_needs_action(X, np.zeros(1, dtype=np.intp), np.zeros(1, dtype=np.int64), 1, 1.0, 1.0, 1.0, True)
    kernels.store_remote(v_ext, v_ext.copy(), np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.intp), np.ones(1),
                         np.ones(1), np.ones(1), np.ones(1), True, 1)
    flat = np.ones(4)
    etd2_predict(flat, flat, flat, flat)
    etd2_correct(flat, flat, flat, flat, flat, flat)
    _loaded = True
