"""The plant: network + turbines + condenser + grid source, fixed-step integration.

Time exists only as ``step counter * step_s``; there is no wall clock here.  One call of
``step()`` advances ``step_s`` with ``substeps`` ETD2 (default), Heun (RK2) or RK4 sub-steps on
the whole state (turbines, condenser, grid source, PCC PLL and, for ``hd_visc`` turbines, the ViSC
law state). The network is algebraic and solved at every stage with one reduced mat-vec of the
pre-inverted Y (network.py). The slow mechanical terms are held over ``slow_every`` steps
(docs/plant.md, Integration); the usual case of the right-hand side runs in fastrhs.py, and the
usual case of a whole step compiled in jitstep.py (``jit=False``: numpy only).
"""

from __future__ import annotations

import cmath
from collections.abc import Callable

import numpy as np

from plant import turbine as T
from plant.condenser import NX as SC_NX
from plant.condenser import Condenser
from plant.fastrhs import FastRHS
from plant.jitstep import JitPath
from plant.network import Network
from plant.params import PlantParams
from sdvisc.vocabulary import F_NOMINAL_HZ, OMEGA0

_LAW_INIT_NAMES = ("initial_state", "init_state", "steady_state", "init")


def _law():
    try:
        from sdc_unit import law  # noqa: PLC0415
    except ImportError as exc:  # pragma: no cover - depends on the other package
        raise RuntimeError("sdc_unit.law not available") from exc
    return law


def _get(out, key):
    return out[key] if isinstance(out, dict) else getattr(out, key)


def _tree(a, b, f):
    if isinstance(a, dict):
        return {k: f(a[k], b[k]) for k in a}
    return f(a, b)


class Plant:
    """Software stand-in for the RTDS wind-farm model (see docs/plant.md)."""

    def __init__(self, params: PlantParams | None = None, n_turbines: int = 50, step_s: float = 0.67e-3,
                 substeps: int = 1, method: str = "etd2", slow_every: int = 10, jit: bool = True):
        self.params = params or PlantParams()
        self.n = n = int(n_turbines)
        self.step_s = float(step_s)
        self.substeps = int(substeps)
        if method not in ("etd2", "rk2", "rk4"):
            raise ValueError("method must be 'etd2', 'rk2' or 'rk4'")
        self.method = method
        self.k = 0
        self.net = Network(self.params, n)
        self.tb = T.TurbineBank(self.params.turbine, n, self.params.v_wind)
        self.sc = Condenser(self.params.condenser)
        self.load_s = 0.0j
        self.visc_idx = np.array([], dtype=int)
        self.xl = None
        self.visc_params = self.params.visc_params
        self.o_sc = T.NS * n
        self.o_g = self.o_sc + SC_NX
        self.o_pll = self.o_g + 3
        self.size = self.o_pll + 2
        self._cache = None
        self._etd = None
        self._mode_key = None
        self._fast = FastRHS(self)
        self._jit = JitPath(self) if jit else None  # jit=False: numpy only (the reference)
        self.slow_every = max(1, int(slow_every))
        self._slow_keep = False
        self._slow_next = 0
        self._init_steady_state()

    # ================================================================== initialisation
    def _init_steady_state(self) -> None:
        n, net, g = self.n, self.net, self.params.grid
        v = np.ones(n, dtype=complex)
        vall = np.ones(net.n_nodes, dtype=complex)
        for _ in range(200):
            i = np.conj((self.tb.p_star(self.tb.wr0()) + 1j * self.tb.q_cmd) / v)
            inj = net.injections(i, g.e_grid, vall[net.sc], 0.0)
            vnew = net.solve(inj)
            if np.max(np.abs(vnew - vall)) < 1e-13:
                vall = vnew
                break
            vall = vnew
            v = np.where(net.plugged, vall[:n], 1.0)
        self.X = np.zeros(self.size, dtype=complex)
        S = self.tb.init_state(v, i)
        self.X[: self.o_sc] = S.ravel()
        vreg = abs(vall[net.pcc]) if self.params.condenser.avr_bus == "pcc" else abs(vall[net.sc])
        self.X[self.o_sc:self.o_g] = self.sc.init_state(vall[net.sc], vreg)
        self.X[self.o_g] = 0.0
        self.X[self.o_g + 1] = 1.0
        ig = (g.e_grid - vall[net.pcc]) * net.y_grid
        self.pm0 = (g.e_grid * np.conj(ig)).real * g.s_base_mva / g.s_grid_mva
        self.X[self.o_g + 2] = self.pm0
        self.X[self.o_pll] = np.angle(vall[net.pcc])
        self._v_pcc_last = vall[net.pcc]
        self._cache = None

    def reinitialise(self) -> None:
        """Recompute the steady state for the present P*/Q* (all turbines grid-following, t kept)."""
        self.tb.mode[:] = T.GFL
        self.visc_idx = np.array([], dtype=int)
        self.xl = None
        self._etd = None
        self.net.ensure()
        self._init_steady_state()

    # ================================================================== right-hand side
    def _mode_info(self):
        """(ext mask, any ext, any remote), recomputed only when the mode array changed."""
        key = self.tb.mode.tobytes()
        if self._mode_key != key:
            ext = self.tb.mode != T.GFL
            self._mode_val = (ext, bool(ext.any()), bool((self.tb.mode == T.REMOTE).any()))
            self._mode_key = key
        return self._mode_val

    def _rhs(self, X, xl, want_aux: bool = False):
        r = self._fast.rhs(X, xl, want_aux)  # usual case, same equations (plant/fastrhs.py)
        return r if r is not None else self._rhs_general(X, xl, want_aux)

    def _visc(self, S, v, xl, vext):
        """hd_visc turbines: (converter voltages incl. the law's, law derivatives, law outputs)."""
        law = _law()
        meas = law.Measurements(**self._meas_arrays(S, v, self.visc_idx, None))
        law_out = law.outputs(xl, meas, self.visc_params)
        dxl = law.derivatives(xl, meas, self.visc_params)
        off = ~self.net.plugged[self.visc_idx]
        if off.any():  # a disconnected ViSC is blocked: its law state is frozen too
            dxl = np.where(off, 0.0, dxl)
        vext = vext.copy()
        vext[self.visc_idx] = np.asarray(_get(law_out, "v_ref_d")) + 1j * np.asarray(_get(law_out, "v_ref_q"))
        return vext, dxl, law_out

    def _tail_rhs(self, tail, vp, vsc, e_grid, e_sc):
        """Derivatives of the condenser, grid source and PCC PLL (tail: list of floats): (list, I_sc, f_pcc)."""
        net, g, tp = self.net, self.params.grid, self.params.turbine
        if net.sc_connected:
            d, i_sc = self.sc.rhs(tail[:SC_NX], vsc, abs(vp) if self.sc.p.avr_bus == "pcc" else abs(vsc), e_sc)
        else:
            d, i_sc = [0.0] * SC_NX, 0.0j
        if g.h_grid > 0:
            wg, pm = tail[SC_NX + 1], tail[SC_NX + 2]
            ig = (e_grid - vp) * net.y_grid
            pe = (e_grid * ig.conjugate()).real * g.s_base_mva / g.s_grid_mva
            d += [OMEGA0 * (wg - 1.0), (pm - pe - g.d_grid * (wg - 1.0)) / (2.0 * g.h_grid),
                  (self.pm0 - (wg - 1.0) / g.r_gov - pm) / g.t_gov]
        else:
            d += (0.0, 0.0, 0.0)
        xpp = tail[SC_NX + 4]
        ev = (vp * cmath.exp(-1j * tail[SC_NX + 3])).imag / max(abs(vp), 0.1)
        d += (OMEGA0 * (tp.kp_pll * ev + xpp), tp.ki_pll * ev)
        return d, i_sc, 1.0 + tp.kp_pll * ev + xpp

    def _rhs_general(self, X, xl, want_aux: bool = False):
        n, net, tb, g = self.n, self.net, self.tb, self.params.grid
        S = X[: self.o_sc].reshape(T.NS, n)
        tail = X.real[self.o_sc:].tolist()  # condenser, grid source, PCC PLL: Python floats
        xsc = tail[:SC_NX]
        thg = tail[SC_NX]
        e_grid = g.e_grid * cmath.exp(1j * thg) if thg != 0.0 else complex(g.e_grid)
        e_sc = self.sc.e_net(xsc) if net.sc_connected else 0.0j
        vl = self._v_pcc_last
        i_load = self.load_s.conjugate() * vl / max(abs(vl) ** 2, 0.49) if self.load_s else 0.0j
        u = np.empty(n + 2, dtype=complex)  # source vector of the reduced solve (Network.factorize)
        u[:n] = S[T.IF] if net.all_plugged else np.where(net.plugged, S[T.IF], 0.0)
        i_t = u[:n]
        u[n] = e_grid * net.y_grid - i_load
        u[n + 1] = e_sc * net.y_sc
        Vr = net.zred @ u
        v = Vr[:n]
        vp, vsc = Vr[n:].tolist()
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
        dS, aux = tb.rhs(S, v, vext, ext, any_ext, out=dX[: self.o_sc].reshape(T.NS, n))
        if not net.all_plugged:
            dS[:, ~net.plugged] = 0.0
        dX[self.o_sc:], i_sc, f_pcc = self._tail_rhs(tail, vp, vsc, e_grid, e_sc)
        if want_aux:
            aux.update(Vr=Vr, v=v, i=i_t, i_sc=i_sc, e_grid=e_grid, e_sc=e_sc, i_load=i_load, law_out=law_out,
                       v_pcc=vp, v_sc=vsc, f_pcc=f_pcc)
            return dX, dxl, aux
        return dX, dxl, None

    def _full_v(self, aux):
        """All node voltages of a cached evaluation (outputs only; the dynamics use the reduced solve)."""
        if "V" not in aux:
            net = self.net
            aux["V"] = net.zcols @ net.reduced_u(aux["i"], aux["e_grid"], aux["e_sc"], aux["i_load"])
        return aux["V"]

    def _meas_arrays(self, S, v, idx, aux):
        i = S[T.IF, idx]
        vv = v[idx]
        s = vv * np.conj(i)
        vdc = np.sqrt(np.maximum(S[T.W, idx].real, 1e-4))
        ev = self.tb.pll_error(S[:, idx], vv)
        om = 1.0 + self.params.turbine.kp_pll * ev + S[T.XP, idx].real
        return {"v_d": vv.real, "v_q": vv.imag, "i_d": i.real, "i_q": i.imag, "p": s.real, "q": s.imag,
                "v_dc": vdc, "omega_meas": om}

    # ================================================================== integration
    def _eval_cached(self):
        if self._cache is None:
            # slow terms: re-evaluated every ``slow_every`` steps and after any command/event
            if not self._slow_keep or self.tb.slow is None or self.k >= self._slow_next:
                (self._jit or self.tb).hold_slow(self.X[: self.o_sc].reshape(T.NS, self.n))
                self._slow_next = self.k + self.slow_every
            self._slow_keep = False
            r = self._jit.evaluate() if self._jit is not None else None  # compiled usual case
            self._cache = r if r is not None else self._rhs(self.X, self.xl, want_aux=True)
        return self._cache

    def step(self, remote_inputs=None) -> None:
        """Advance one step of ``step_s``. ``remote_inputs``: (index_array, v_ref_d, v_ref_q) or None."""
        if remote_inputs is not None:
            self.apply_remote(*remote_inputs)
        self._check_fallback()
        self.net.ensure()
        h = self.step_s / self.substeps
        k1, l1, aux = self._eval_cached()  # also holds the aerodynamics of this step (TurbineBank.hold_slow)
        X, xl = self.X, self.xl
        if self.method == "etd2":
            E, phi1, phi2 = self._etd_coeffs(h)
            if self.substeps == 1 and xl is None:  # the usual case: the loop below, unrolled
                self._v_pcc_last = aux["v_pcc"]
                if self._jit is not None and self._jit.step(k1, (E, phi1, phi2)):
                    return
                a = phi1 * k1
                a += X
                k2 = self._rhs(a, None)[0]
                k2 -= E * k1
                k2 *= phi2
                a += k2
                self._advance(a, None)
                return
        for s in range(self.substeps):
            if s == 0:
                k1, l1, aux = self._eval_cached()
            else:
                k1, l1, aux = self._rhs(X, xl, want_aux=True)
            self._v_pcc_last = aux["v_pcc"]
            if self.method == "etd2":
                # Cox-Matthews ETD2RK with the diagonal linear part -c:  a = E X + phi1 (k1 + c X),
                # X+ = a + phi2 (k2 + c a - k1 - c X); since phi1 c = 1 - E this is
                # a = X + phi1 k1,  X+ = a + phi2 (k2 - E k1)  (c = 0: Heun)
                a = phi1 * k1
                a += X
                k2, l2, _ = self._rhs(a, self._axpy(xl, h, l1))
                k2 -= E * k1
                k2 *= phi2
                X = a + k2
                if xl is not None:
                    xl = _tree(xl, _tree(l1, l2, lambda p, q: p + q), lambda p, q: p + (0.5 * h) * q)
            elif self.method == "rk2":
                k2, l2, _ = self._rhs(X + h * k1, self._axpy(xl, h, l1))
                X = X + (0.5 * h) * (k1 + k2)
                if xl is not None:
                    xl = _tree(xl, _tree(l1, l2, lambda a, b: a + b), lambda a, b: a + (0.5 * h) * b)
            else:
                k2, l2, _ = self._rhs(X + (0.5 * h) * k1, self._axpy(xl, 0.5 * h, l1))
                k3, l3, _ = self._rhs(X + (0.5 * h) * k2, self._axpy(xl, 0.5 * h, l2))
                k4, l4, _ = self._rhs(X + h * k3, self._axpy(xl, h, l3))
                X = X + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
                if xl is not None:
                    inc = _tree(_tree(l1, l4, lambda a, b: a + b), _tree(l2, l3, lambda a, b: a + b),
                                lambda a, b: a + 2.0 * b)
                    xl = _tree(xl, inc, lambda a, b: a + (h / 6.0) * b)
        self._advance(X, xl)

    def _advance(self, X, xl) -> None:
        """Store the new state, count the step and evaluate it (the next step's first stage)."""
        self.X, self.xl = X, xl
        self.k += 1
        self._cache = None
        self._slow_keep = True  # only the step itself may keep the held slow terms
        self._v_pcc_last = self._eval_cached()[2]["v_pcc"]

    def _etd_coeffs(self, h):
        """Exponential (ETD2RK, Cox-Matthews) coefficients for the stiff current-control pole.

        The split uses c = OMEGA0 kpc / lf on the filter current of plugged turbines with a local
        current loop (grid-following, and remote with remote_apply = "i_ref")
        (the closed current loop is di/dt = -c (i - i*) + ...), c = 0 elsewhere (-> Heun).
        """
        self._mode_info()  # refreshes self._mode_key; every change of `plugged` refactorises the network
        key = (h, self._mode_key, self.net.n_factorizations, self.params.turbine.remote_apply)
        if self._etd is not None and self._etd[0] == key:
            return self._etd[1]
        tp = self.params.turbine
        c = np.zeros(self.size)
        loop = self.tb.mode == T.GFL
        if tp.remote_apply == "i_ref":
            loop = loop | (self.tb.mode == T.REMOTE)
        gfl = loop & self.net.plugged
        c[: self.n] = np.where(gfl, OMEGA0 * tp.kpc / tp.lf, 0.0)
        ch = c * h
        E = np.exp(-ch)
        safe = np.where(c > 0, c, 1.0)
        phi1 = np.where(c > 0, (1.0 - E) / safe, h)
        phi2 = np.where(c > 0, (E - 1.0 + ch) / (safe * safe * h), 0.5 * h)
        self._c = c
        # complex coefficient arrays: multiplying the complex state by them needs no casting
        self._etd = (key, (E.astype(complex), phi1.astype(complex), phi2.astype(complex)))
        return self._etd[1]

    @staticmethod
    def _axpy(x, h, dx):
        if x is None:
            return None
        return _tree(x, dx, lambda a, b: a + h * b)

    @property
    def t(self) -> float:
        return self.k * self.step_s

    # ================================================================== measurement / outputs
    def measurements(self) -> dict:
        """Per-turbine measurement arrays (turbine p.u.): v_d, v_q, i_d, i_q, p, q, v_dc, omega_meas."""
        _, _, aux = self._eval_cached()
        m = aux.get("meas")
        if m is None:
            v, i = aux["v"], aux["i"]
            s, om = aux.get("s"), aux.get("om")  # the fast path (fastrhs.py) provides both
            if om is None:
                s = v * i.conj()
                om = aux["ev"] * self.params.turbine.kp_pll
                om += self.X[T.XP * self.n:(T.XP + 1) * self.n].real
                om += 1.0
            m = aux["meas"] = {"v_d": v.real, "v_q": v.imag, "i_d": i.real, "i_q": i.imag, "p": s.real,
                               "q": s.imag, "v_dc": aux["vdc"], "omega_meas": om}
        return dict(m)

    def outputs(self) -> dict:
        """Scalar and per-turbine quantities for time series (see docs/plant.md for units)."""
        _, _, aux = self._eval_cached()
        net, n = self.net, self.n
        S = self.X[: self.o_sc].reshape(T.NS, n)
        V, v, i = self._full_v(aux), aux["v"], aux["i"]
        s_wt = v * np.conj(i)
        i_sc = aux["i_sc"]
        s_sc = V[net.sc] * np.conj(i_sc)
        ig = (aux["e_grid"] - V[net.pcc]) * net.y_grid  # from the source into the pcc
        s_grid = -V[net.pcc] * np.conj(ig)  # flowing pcc -> grid
        xsc = self.X[self.o_sc:self.o_g].real
        # phase quantities during the single-phase fault (sequence networks; see network.py)
        i_f, v2, v0 = net.fault_sequences(V)
        a = np.exp(2j * np.pi / 3.0)
        rot = np.array([1.0, a * a, a])  # phases a, b, c of the positive sequence
        v_ph = np.abs(V[net.pcc] * rot + v2[net.pcc] * rot.conj() + v0)
        # condenser: negative-sequence current -V2/(ra + j x''); YNd1 step-up shifts I1 by -30 deg and
        # I2 by +30 deg on the machine side; no zero sequence reaches the machine
        i2_sc = -v2[net.sc] / self.sc.z2 if net.sc_connected else 0.0j
        sh = np.exp(-1j * np.pi / 6.0)
        i_sc_ph = np.abs(i_sc * sh * rot + i2_sc * sh.conjugate() * rot.conj())
        visc_delta = np.full(n, np.nan)
        visc_e = np.full(n, np.nan)
        lo = aux["law_out"]
        if lo is not None:
            visc_delta[self.visc_idx] = np.asarray(_get(lo, "delta"))
            visc_e[self.visc_idx] = np.asarray(_get(lo, "e_mag"))
        return {
            "t": self.t,
            "v_pcc": abs(V[net.pcc]), "f_pcc_hz": F_NOMINAL_HZ * float(aux["f_pcc"]), "v_os": abs(V[net.os_mv]),
            "v_sc": abs(V[net.sc]), "f_grid": float(self.X[self.o_g + 1].real),
            "p_grid": s_grid.real, "q_grid": s_grid.imag,
            "p_wt": s_wt.real, "q_wt": s_wt.imag, "i_wt": np.abs(i),
            "p_sc": s_sc.real, "q_sc": s_sc.imag, "i_sc": abs(i_sc),
            "sc_delta": xsc[0], "sc_omega": xsc[1], "sc_e": abs(aux["e_sc"]) if net.sc_connected else 0.0,
            "sc_efd": xsc[6],
            "visc_delta": visc_delta, "visc_e": visc_e,
            "v_dc": aux["vdc"], "pitch": S[T.B].real.copy(), "omega_r": S[T.WR].real.copy(),
            "v_pcc_ph": v_ph, "i_sc_ph_max": float(np.max(i_sc_ph)), "i_fault": abs(i_f),
            "p_me": aux["pme"], "losses": net.series_losses(V),
            # aliases shared with plant.minimal (used by plant.recorder)
            "p": s_wt.real, "q": s_wt.imag, "i_mag": np.abs(i), "mode": self.tb.mode.copy(),
        }

    # ================================================================== commands / events
    def apply_remote(self, index_array, v_ref_d, v_ref_q, i_ref_d=None, i_ref_q=None) -> None:
        """Store the received references (common frame, turbine p.u.); i_ref is used only with
        ``TurbineParams.remote_apply == "i_ref"``."""
        idx = np.atleast_1d(np.asarray(index_array, dtype=int))
        self.tb.v_hold[idx] = np.asarray(v_ref_d) + 1j * np.asarray(v_ref_q)
        if i_ref_d is not None and i_ref_q is not None:
            self.tb.i_hold[idx] = np.asarray(i_ref_d) + 1j * np.asarray(i_ref_q)
        self.tb.last_rx_step[idx] = self.k
        self._cache = None

    def _check_fallback(self) -> None:
        tb = self.tb
        if not self._mode_info()[2]:
            return
        rem = np.nonzero(tb.mode == T.REMOTE)[0]
        S = self.X[: self.o_sc].reshape(T.NS, self.n)
        over = rem[np.abs(S[T.IF, rem]) > self.params.turbine.trip_current]
        late = rem[(self.k - tb.last_rx_step[rem]) * self.step_s >= self.params.turbine.remote_loss_fallback_s]
        if not tb.fallback_enabled:
            late = late[:0]
        if late.size and over.size:  # (late and over are sorted and unique already)
            late = np.setdiff1d(late, over)
        if late.size or over.size:
            _, _, aux = self._eval_cached()
            both = np.concatenate([late, over])
            tb.bumpless_gfl(S, aux["v"], both, aux["vconv"][both])
            tb.fell_back[late] = True
            tb.fallbacks[late] += 1
            tb.trips[over] += 1
            self._cache = None

    @property
    def fallbacks(self) -> np.ndarray:
        """Per turbine: how many times remote mode fell back to grid-following (lost references)."""
        return self.tb.fallbacks

    @property
    def trips(self) -> np.ndarray:
        """Per turbine: remote-mode over-current trips back to grid-following."""
        return self.tb.trips

    def set_remote_fallback(self, enabled: bool) -> None:
        """Enable/disable the fall-back of ``remote`` turbines to grid-following on lost references."""
        self.tb.fallback_enabled = bool(enabled)

    def set_mode(self, index, mode: str) -> None:
        """Set the control mode of turbines ``index``: grid_following, hd_visc or remote (bumpless)."""
        if mode not in T.MODES:
            raise ValueError(f"mode must be one of {sorted(T.MODES)}")
        idx = np.atleast_1d(np.asarray(index, dtype=int))
        _, _, aux = self._eval_cached()
        S = self.X[: self.o_sc].reshape(T.NS, self.n)
        code = T.MODES[mode]
        if code == T.GFL:
            self.tb.bumpless_gfl(S, aux["v"], idx, aux["vconv"][idx])
        elif code == T.REMOTE:
            self.tb.v_hold[idx] = aux["vconv"][idx]
            self.tb.i_hold[idx] = S[T.IF, idx]
            self.tb.last_rx_step[idx] = self.k
            self.tb.fell_back[idx] = False
            self.tb.mode[idx] = T.REMOTE
        self.tb.mode[idx] = code
        new_visc = np.nonzero(self.tb.mode == T.HD_VISC)[0]
        if not np.array_equal(new_visc, self.visc_idx):
            self._init_law(new_visc, S, aux["v"])
        self._cache = None

    def _init_law(self, idx, S, v) -> None:
        self.visc_idx = idx
        if idx.size == 0:
            self.xl = None
            return
        law = _law()
        if self.visc_params is None:
            from sdc_unit.params import ViscParams  # noqa: PLC0415
            self.visc_params = ViscParams()
        meas = law.Measurements(**self._meas_arrays(S, v, idx, None))
        for name in _LAW_INIT_NAMES:
            f = getattr(law, name, None)
            if callable(f):
                self.xl = f(meas, self.visc_params)
                return
        raise RuntimeError(f"sdc_unit.law exposes none of {_LAW_INIT_NAMES} to initialise its state")

    def set_visc_params(self, params) -> None:
        """Replace the ViscParams used by hd_visc turbines (e.g. a new V* or droop)."""
        self.visc_params = params
        self._cache = None

    def set_battery(self, index, on: bool = True) -> None:
        self.tb.battery[np.atleast_1d(index)] = bool(on)
        self._cache = None

    def set_power_ref(self, index, p=None, q=None, mppt: bool = False) -> None:
        """Grid-following P*/Q* (turbine p.u.); ``mppt=True`` returns P* to the MPPT curve."""
        idx = np.atleast_1d(index)
        if p is not None:
            self.tb.p_cmd[idx] = p
            self.tb.mppt[idx] = False
        if q is not None:
            self.tb.q_cmd[idx] = q
        if mppt:
            self.tb.mppt[idx] = True
        self._cache = None

    def set_avr_ref(self, v: float) -> None:
        """Synchronous-condenser AVR voltage reference, p.u."""
        self.sc.v_ref = float(v)
        self._cache = None

    def set_grid_emf(self, e: float) -> None:
        """Grid source EMF magnitude, p.u. (a grid-side voltage step)."""
        self.params.grid.e_grid = float(e)
        self._cache = None

    def set_grid_voltage(self, magnitude: float) -> None:
        """Alias of set_grid_emf (interface shared with plant.minimal)."""
        self.set_grid_emf(magnitude)

    def load_step(self, mw: float, mvar: float = 0.0) -> None:
        """Add a constant-PQ load of ``mw`` (+ j ``mvar``) at the PCC (cumulative)."""
        self.load_s += complex(mw, mvar) / self.params.grid.s_base_mva
        self._cache = None

    def fault(self, on: bool, z_f: complex = 0.0, **_) -> None:
        """Single-phase-to-ground fault at the PCC (sequence-network equivalent), z_f in network p.u."""
        self.net.set_fault(on, z_f)
        self._refresh()

    def set_scr(self, value: float) -> None:
        self.net.set_scr(value)
        self._refresh()

    def set_sc_connected(self, on: bool) -> None:
        self.net.set_sc_connected(on)
        self._refresh()

    def plug(self, index, on: bool) -> None:
        """Connect/disconnect turbines (their transformer branch); a disconnected converter is blocked."""
        idx = np.atleast_1d(np.asarray(index, dtype=int))
        S = self.X[: self.o_sc].reshape(T.NS, self.n)
        if not on:
            S[T.IF, idx] = 0.0
        self.net.set_plugged(idx, on)
        self._refresh()
        if on:
            _, _, aux = self._eval_cached()
            S[T.IF, idx] = 0.0
            S[T.TH, idx] = np.angle(aux["v"][idx])
            S[T.XI, idx] = 0.0
            self._cache = None
            if np.isin(idx, self.visc_idx).any():  # restart the ViSC law from the new operating point
                _, _, aux = self._eval_cached()
                self._init_law(self.visc_idx, S, aux["v"])
                self._cache = None

    def _refresh(self) -> None:
        self.net.ensure()
        self._cache = None

    # ================================================================== offline runs
    def run_offline(self, t_end: float, events: list[tuple[float, Callable]] | None = None,
                    record_every: int = 1) -> dict:
        """Run until t_end (s) as fast as possible; events [(t, callable(plant))]; returns arrays."""
        ev = sorted(events or [], key=lambda e: e[0])
        j = 0
        rec: dict[str, list] = {}
        n_steps = int(round(t_end / self.step_s))
        while self.k < n_steps:
            while j < len(ev) and ev[j][0] <= self.t + 0.5 * self.step_s:
                ev[j][1](self)
                j += 1
            if self.k % record_every == 0:
                for key, val in self.outputs().items():
                    rec.setdefault(key, []).append(val)
            self.step()
        return {k: np.array(v) for k, v in rec.items()}

    # ================================================================== for reference solvers
    def rhs_real(self, _t, y):
        """Real flat right-hand side (plant state + law state) for scipy.integrate.solve_ivp.

        Identical equations to ``step`` except that aerodynamics are evaluated at every call.
        """
        self.tb.slow = None
        X = y[: self.size] + 1j * y[self.size:2 * self.size]
        xl = None if self.xl is None else y[2 * self.size:].reshape(np.shape(self.xl))
        dX, dxl, aux = self._rhs(X, xl, want_aux=True)
        self._v_pcc_last = aux["v_pcc"]
        parts = [dX.real, dX.imag]
        if dxl is not None:
            parts.append(np.ravel(dxl))
        return np.concatenate(parts)

    def state_real(self):
        parts = [self.X.real, self.X.imag]
        if self.xl is not None:
            parts.append(np.ravel(self.xl))
        return np.concatenate(parts)

    def set_state_real(self, y) -> None:
        self.X = y[: self.size] + 1j * y[self.size:2 * self.size]
        if self.xl is not None:
            self.xl = y[2 * self.size:].reshape(np.shape(self.xl))
        self._cache = None
