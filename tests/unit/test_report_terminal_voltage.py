"""A network run records no terminal voltage: F3net.a and C1.b take it as |V| = |S| / |I| from the
recorded p, q, i of each converter (report/exp_grid_net.py ``terminal_voltage``)."""

from __future__ import annotations

import numpy as np
import pytest

from report.exp_grid_net import terminal_voltage


def test_terminal_voltage_is_apparent_power_over_current():
    v = np.array([1.0, 1.02, 0.97])
    i = np.array([0.8, 1.1, 0.0005])  # the last below 1e-3 p.u.: undefined
    phi = np.array([0.3, -0.2, 0.0])
    ts = {"wt.p": v * i * np.cos(phi), "wt.q": v * i * np.sin(phi), "wt.i": i}
    got = terminal_voltage(ts, ["wt"])
    assert got[:2] == pytest.approx(v[:2]) and np.isnan(got[2])
    ts2 = {**ts, "wu.p": 0.5 * ts["wt.p"], "wu.q": 0.5 * ts["wt.q"], "wu.i": i}  # half the voltage
    assert terminal_voltage(ts2, ["wt", "wu"])[:2] == pytest.approx(0.75 * v[:2])
