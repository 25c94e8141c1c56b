"""The weak-grid stability criterion of F7 and F9 (report/stability.py) on made-up V_pcc traces —
damped to 1.0 = stable, damped to 0.6 = damped but not stable, a growing oscillation = neither; the
time V_pcc leaves the normal band for good (F9.d) — and F7's and F9's verdicts on made-up values."""

from __future__ import annotations

import numpy as np
import pytest

from report.stability import AWAY_S, PTP_DAMPED, V_NORMAL, Stability, of_run, stability, time_away

T_EVENT = 1.0
T = np.arange(0.0, 5.0, 1e-3)
AFTER = np.clip(T - T_EVENT, 0.0, None)


def _ringing(final: float, decay: float, amplitude: float = 0.2, hz: float = 3.0) -> np.ndarray:
    """1.0 before the event, then ``final`` with an oscillation of ``amplitude`` growing (decay < 0)
    or decaying (decay > 0) at ``hz``."""
    osc = amplitude * np.exp(-decay * AFTER) * np.sin(2 * np.pi * hz * AFTER)
    return np.where(T < T_EVENT, 1.0, final + osc)


def test_damped_back_to_rated_is_stable():
    s = stability(T, _ringing(1.0, decay=2.0, amplitude=0.3), T_EVENT)
    assert s.damped and s.in_band and s.stable and s.state == "stable"
    assert s.v_min < V_NORMAL[0] and s.t_away is None  # the first swings leave the band, then it is back


def test_damped_at_a_low_voltage_is_damped_but_not_stable():
    s = stability(T, _ringing(0.6, decay=4.0), T_EVENT)
    assert s.damped and not s.in_band and not s.stable
    assert s.state.startswith("damped at 0.60") and s.t_away == pytest.approx(T_EVENT, abs=0.01)


def test_a_growing_oscillation_is_neither():
    s = stability(T, _ringing(1.0, decay=-0.8, amplitude=0.03), T_EVENT)
    assert s.ptp_last_s > PTP_DAMPED and not s.damped and not s.stable and s.state == "oscillating"
    # it first swings out of the band once its amplitude passes 0.1 p.u., and keeps doing so: away from then on
    first_out = T[(T > T_EVENT) & (np.abs(_ringing(1.0, decay=-0.8, amplitude=0.03) - 1.0) > 0.1)][0]
    assert s.t_away == pytest.approx(first_out, abs=1e-9)


def test_a_diverged_run_is_neither_and_says_so():
    v = _ringing(1.0, decay=4.0)
    v[-10:] = np.nan
    s = of_run({"t": T, "v_pcc": v}, T_EVENT)
    assert not s.damped and not s.in_band and not s.stable and "diverged" in s.describe()


def test_above_the_band_is_not_stable_either():
    assert not stability(T, _ringing(1.15, decay=4.0), T_EVENT).stable
    assert stability(T, _ringing(V_NORMAL[1] - 0.01, decay=4.0, amplitude=0.0), T_EVENT).stable


def test_time_away_ignores_the_dip_of_the_event_and_finds_the_later_deviation():
    """Near normal until 3 s (a short dip at the event, back within 0.2 s), then it drifts down to 0.6."""
    v = np.where(T < T_EVENT, 1.0, 1.0 - 0.2 * np.exp(-20 * AFTER))  # dip to 0.8, back in the band in ~0.035 s
    v = np.where(T < 3.0, v, 1.0 - 0.4 * (1 - np.exp(-3 * (T - 3.0))))
    t_away = time_away(T, v, T_EVENT)
    assert t_away == pytest.approx(3.0 + np.log(0.4 / 0.3) / 3, abs=2e-3)  # where 1 − 0.4 (1 − e^−3τ) = 0.9


def test_back_in_the_band_for_long_enough_is_not_away():
    v = np.where((T > T_EVENT) & (T < 2.0), 0.7, 1.0)  # out of the band for 1 s, then back for 3 s
    assert time_away(T, v, T_EVENT) is None
    short = np.where((T > T_EVENT) & (T < T[-1] - AWAY_S / 2), 0.7, 1.0)  # back only for the last AWAY_S / 2
    assert time_away(T, short, T_EVENT) == pytest.approx(T[T > T_EVENT][0])


# ------------------------------------------------------------------ F7 and F9 verdicts on made-up values
def _state(t_away: float | None, v_end: float = 0.6) -> Stability:
    return Stability(v_end=v_end, ptp_last_s=0.0, v_min=0.5, finite=True, t_away=t_away)


def test_f9d_judges_the_time_away_at_wt1_cs1_by_the_ten_per_cent_rule():
    """F9.d reads WT1_CS1 (turbine 0, the paper's caption), not the PCC: its terminal voltage leaves
    the band for good at the time given; the PCC's state only goes beside it."""
    from report.exp_weak import _f9d

    others = {3: _state(None, 1.0)}
    s = {0: _state(1.0), 3: _state(None, 1.0)}  # the PCC stays in the band: it does not decide

    def run3(t_away):
        t = np.arange(0.0, 5.0, 0.01)
        v = np.where(t < (t_away if t_away is not None else 99.0), 1.0, 0.7)
        return {"t": t, "v_wt": np.c_[v, np.ones_like(v)]}

    assert _f9d(s, others, run3(3.2)).verdict == "yes"
    assert _f9d(s, others, run3(2.2)).verdict == "partly"  # 27 % early
    assert _f9d(s, others, run3(1.02)).verdict == "no"
    never = _f9d(s, others, run3(None))
    assert never.verdict == "no" and never.measured["t_away_wt1_cs1_s"] is None and "does not leave" in never.testbed


def test_f7c_yes_on_the_stable_boundary_partly_on_the_oscillation_only_one():
    from report.exp_weak import F7_CONFIGS, SDVISC, VIRTUAL_FRICTION_DEFAULT, _f7c

    main = SDVISC[VIRTUAL_FRICTION_DEFAULT]
    ev = {n: "runs" for n in F7_CONFIGS}

    def vals(visc_stable, visc_damped):
        v = {n: {"stable": 2.0, "damped": 1.8} for n in F7_CONFIGS}
        v[main] = {"stable": visc_stable, "damped": visc_damped}
        return v

    assert _f7c(vals(1.5, 1.4), ev).verdict == "yes"
    assert _f7c(vals(2.5, 1.4), ev).verdict == "partly"
    assert _f7c(vals(None, None), ev).verdict == "no"


def test_a_boundary_above_the_unsupported_one_is_not_reproduced():
    from report.boundary import Boundary
    from report.exp_weak import _boundary_finding

    damped = Boundary(1.5, (1.49, 1.51))
    assert _boundary_finding(Boundary(1.6, (1.59, 1.61)), damped, 1.58, "runs").verdict == "yes"
    assert _boundary_finding(Boundary(1.6, (1.59, 1.61)), damped, 1.58, "runs", below=1.55).verdict == "no"
    none = _boundary_finding(Boundary(None, None, note="no change"), damped, 1.58, "runs")
    assert none.verdict == "no" and "oscillation only: 1.500" in none.testbed


def test_a_terminal_over_1p1_is_not_stable():
    """Damped, V_pcc in the band, but a turbine terminal at 1.105 over the last second: not stable
    (issue 39: no 'stable' case with a terminal above 1.1 p.u.); at 1.09 it is."""
    t = np.arange(0.0, 5.0, 0.01)
    v = np.ones_like(t)
    for v_t, ok in ((1.105, False), (1.09, True)):
        st = stability(t, v, 1.0, np.c_[np.full_like(t, v_t), np.ones_like(t)])
        assert st.damped and st.in_band and st.stable is ok
