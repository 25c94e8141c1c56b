"""The plant's right-hand side: the compiled kernels where they apply, else the general numpy path.

``RightHandSide`` is a part of :class:`plant.sim.Plant` (a mixin; it uses the plant's network
``net``, turbines ``tb``, condenser ``sc``, state layout and operating values). ``_evaluate(X, xl)``
returns ``(dX, dxl, aux)``: the derivatives of the plant state X, of the ViSC law states xl of the
hd_visc turbines (sdc_unit.law) and, on request, ``aux``, the algebraic results of the evaluation
(node voltages, currents, measurements, ...) that measurements()/outputs() read.

Two implementations of the same equations (docs/plant.md):

* compiled (plant/kernels.py via plant/compiled.py): the usual case, every limiter and the
  DC-link batteries included, and hd_visc turbines, whose law (sdc_unit.law_kernels, compiled by
  sdc_unit.law_jit) runs between the network solve and the rest of the right-hand side
  (plant/visc_kernels.py); with ``Plant.compiled_law = False`` the law runs in numpy
  (``sdc_unit.law``) between two kernels instead, the reference of the compiled law in
  tests/unit/test_plant_jit.py;
* general (``_rhs_general`` + ``TurbineBank.rhs`` + ``Condenser.rhs``): unplugged turbines, the
  slow terms evaluated at every stage (``rhs_real``), ``jit=False``. It is the reference of the
  compiled path (tests/unit/test_plant_jit.py, test_plant_limits.py). The limiters and the
  battery current are written once for both (plant/turbine_laws.py).
"""

from __future__ import annotations

import cmath

import numpy as np

from plant import turbine as T
from plant.condenser import NX as SC_NX
from plant.layout import GRID_PM, GRID_SPEED, PLL_ANGLE, PLL_INTEGRATOR
from sdc_unit import law
from sdvisc.vocabulary import OMEGA0


class RightHandSide:
    """The right-hand side of :class:`plant.sim.Plant` (see the module docstring)."""

    def _evaluate(self, X, xl, want_aux: bool = False):
        """(dX, dxl, aux or None) of state X and law state xl."""
        if self._compiled is not None and self._compiled.covers(self.tb, self.net):
            return self._evaluate_compiled(X, xl, want_aux)
        return self._rhs_general(X, xl, want_aux)

    def _evaluate_compiled(self, X, xl, want_aux: bool):
        compiled = self._compiled
        if not self.visc_idx.size:
            dX, aux = compiled.evaluate(X, self.tb, self._v_pcc_last)
            return dX, None, aux if want_aux else None
        if self.compiled_law:
            return compiled.evaluate_visc(X, xl, self.tb, self._v_pcc_last, *self._law_arrays(), want_aux)
        node_v, sources = compiled.solve_network(X, self._v_pcc_last)
        v_ext, dxl, law_out = self._visc(self.layout.turbines(X), node_v[: self.n], xl, self.tb.v_hold)
        r = compiled.evaluate_given_network(X, node_v, sources, self.tb, v_ext, want_aux)
        if want_aux:
            r[1]["law_out"] = law_out
        return r[0], dxl, r[1]

    def _mode_info(self):
        """(ext mask, any ext, indices of the remote turbines), recomputed only when the mode array
        changed."""
        key = self.tb.mode.tobytes()
        if self._mode_key != key:
            ext = self.tb.mode != T.GFL
            self._mode_val = (ext, bool(ext.any()), np.nonzero(self.tb.mode == T.REMOTE)[0])
            self._mode_key = key
        return self._mode_val

    def _meas_arrays(self, S, v, idx):
        """Measurements (sdvisc.vocabulary.MEAS_FIELDS) of turbines idx: what the law sees."""
        i = S[T.IF, idx]
        vv = v[idx]
        s = vv * np.conj(i)
        vdc = np.sqrt(np.maximum(S[T.W, idx].real, 1e-4))
        ev = self.tb.pll_error(S[:, idx], vv)
        om = 1.0 + self.params.turbine.kp_pll * ev + S[T.XP, idx].real
        return {"v_d": vv.real, "v_q": vv.imag, "i_d": i.real, "i_q": i.imag, "p": s.real, "q": s.imag,
                "v_dc": vdc, "omega_meas": om}

    def _law_arrays(self):
        """(hd_visc turbines, their law parameters as rows ``law.param_rows``) for the compiled law;
        the rows are packed again only when the ViscParams object or the number of turbines changed
        (ViscParams is frozen: a new V* or droop is a new object)."""
        p, k = self.visc_params, self.visc_idx.size
        packed = self._law_c
        if packed is None or packed[0] is not p or packed[1] != k:
            packed = self._law_c = (p, k, law.param_rows(p, k))
        return self.visc_idx, packed[2]

    def _visc(self, S, v, xl, vext):
        """hd_visc turbines: (converter voltages incl. the law's, law derivatives, law outputs)."""
        meas = law.Measurements(**self._meas_arrays(S, v, self.visc_idx))
        dxl, law_out = law.evaluate(xl, meas, self.visc_params)
        off = ~self.net.plugged[self.visc_idx]
        if off.any():  # a disconnected ViSC is blocked: its law state is frozen too
            dxl = np.where(off, 0.0, dxl)
        vext = vext.copy()
        vext[self.visc_idx] = law_out.v_ref_d + 1j * law_out.v_ref_q
        return vext, dxl, law_out

    # ------------------------------------------------------------------ general path
    def _tail_rhs(self, tail, vp, vsc, e_grid, e_sc):
        """Condenser, grid source and PCC PLL (tail: list of floats): (derivatives, I_sc, f_pcc [p.u.])."""
        net, g, tp = self.net, self.params.grid, self.params.turbine
        if net.sc_connected:
            i_dyn = net.sc_current(vsc, e_sc)  # the stator branch's current with the dynamic-phasor network
            d, i_sc = self.sc.rhs(tail[:SC_NX], vsc, abs(vp) if self.sc.p.avr_bus == "pcc" else abs(vsc), e_sc,
                                  None if i_dyn is None else i_dyn / net.k_sc)
        else:
            d, i_sc = [0.0] * SC_NX, 0.0j
        if g.h_grid > 0:
            wg, pm = tail[SC_NX + GRID_SPEED], tail[SC_NX + GRID_PM]
            ig = (e_grid - vp) * net.y_grid
            pe = (e_grid * ig.conjugate()).real * g.s_base_mva / g.s_grid_mva
            d += [OMEGA0 * (wg - 1.0), (pm - pe - g.d_grid * (wg - 1.0)) / (2.0 * g.h_grid),
                  (self.pm0 - (wg - 1.0) / g.r_gov - pm) / g.t_gov]
        else:
            d += (0.0, 0.0, 0.0)
        pll = self.layout.pcc_pll - self.layout.condenser
        xpp = tail[pll + PLL_INTEGRATOR]
        ev = (vp * cmath.exp(-1j * tail[pll + PLL_ANGLE])).imag / max(abs(vp), 0.1)
        d += (OMEGA0 * (tp.kp_pll * ev + xpp), tp.ki_pll * ev)
        return d, i_sc, 1.0 + tp.kp_pll * ev + xpp

    def _sources(self, tail):
        """(E_grid, E''_sc, I_load) of the state whose tail (condenser, grid, PLL) is given."""
        g, net = self.params.grid, self.net
        thg = tail[SC_NX]
        e_grid = g.e_grid * cmath.exp(1j * thg) if thg != 0.0 else complex(g.e_grid)
        e_sc = self.sc.e_net(tail[:SC_NX]) if net.sc_connected else 0.0j
        if net.sc_connected and net.hist is not None:  # the rotor's transformer EMF, at the last step's current
            e_sc += self.sc.flux_emf(tail[:SC_NX], net.sc_current_last() / net.k_sc)
        vl = self._v_pcc_last
        i_load = self.load_s.conjugate() * vl / max(abs(vl) ** 2, 0.49) if self.load_s else 0.0j
        return e_grid, e_sc, i_load

    def _rhs_general(self, X, xl, want_aux: bool = False):
        n, net, tb = self.n, self.net, self.tb
        S = self.layout.turbines(X)
        tail = self.layout.tail(X)
        e_grid, e_sc, i_load = self._sources(tail)
        i_t = S[T.IF].copy() if net.all_plugged else np.where(net.plugged, S[T.IF], 0.0)
        node_v = net.zred @ net.reduced_u(i_t, e_grid, e_sc, i_load)
        if net.w_red is not None:  # the dynamic-phasor network's history (plant/dynamic_network.py)
            node_v += net.w_red
        v = node_v[:n]
        vp, vsc = node_v[n:].tolist()
        ext, any_ext, _ = self._mode_info()
        vext = tb.v_hold
        if any_ext and self.params.turbine.remote_apply == "i_ref":
            tp = self.params.turbine
            ih = tb.i_hold
            vext = np.where(tb.mode == T.REMOTE, v + (tp.rf + 1j * tp.lf) * ih + tp.kpc * (ih - S[T.IF]), vext)
        dxl = law_out = None
        if self.visc_idx.size:
            vext, dxl, law_out = self._visc(S, v, xl, vext)
        dX = np.empty_like(X)
        dS, aux = tb.rhs(S, v, vext, ext, any_ext, out=self.layout.turbines(dX))
        if not net.all_plugged:
            dS[:, ~net.plugged] = 0.0
        dX[self.layout.condenser:], i_sc, f_pcc_pu = self._tail_rhs(tail, vp, vsc, e_grid, e_sc)
        if not want_aux:
            return dX, dxl, None
        aux.update(node_v=node_v, v=v, i=i_t, i_sc=i_sc, e_grid=e_grid, e_sc=e_sc, i_load=i_load, law_out=law_out,
                   v_pcc=vp, v_sc=vsc, f_pcc_pu=f_pcc_pu)
        return dX, dxl, aux

    def _full_v(self, aux):
        """All node voltages of a cached evaluation (outputs only; the dynamics use the reduced solve)."""
        if "V" not in aux:
            net = self.net
            aux["V"] = net.zcols @ net.reduced_u(aux["i"], aux["e_grid"], aux["e_sc"], aux["i_load"])
            if net.w_full is not None:
                aux["V"] += net.w_full
        return aux["V"]
