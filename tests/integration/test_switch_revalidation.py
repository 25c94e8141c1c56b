"""Open vSwitch's revalidation period for a run (host_tools/ovs_revalidation.py, scenario key
``switch_revalidation_ms``) on the real switch: in force while the run lasts, the value from before
put back afterwards — also after a run that was killed (``sdvisc clean``) — and a link failure is
still handled at once (port changes revalidate without waiting for the period)."""

from __future__ import annotations

import pytest
import yaml

from host_tools import ovs_revalidation
from tests.integration.helpers import ROOT, assert_no_leftovers, run_scenario, sdvisc

pytestmark = pytest.mark.network
SC = ROOT / "scenarios"


def _with(tmp_path, name: str, **changes) -> str:
    data = yaml.safe_load((SC / name).read_text())
    data.update(changes)
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return str(path)


def test_a_run_spaces_out_revalidation_and_puts_the_value_back(tmp_path):
    before = ovs_revalidation.current()
    s = run_scenario(_with(tmp_path, "link_failure_dr.yaml", switch_revalidation_ms=7000), tmp_path / "out",
                     "--time-scale", "4")  # as test_sdn_scenarios runs link_failure_dr
    assert s["switch_revalidation"] == {"applied": True, "max_revalidator_ms": 7000, "previous": before}
    (rec,) = s["recoveries"]  # the link's port went down: DR and the new path, as without the setting
    assert rec["cause"] == "dr" and rec["recovery_ms"] is not None and rec["recovery_ms"] < 100
    assert ovs_revalidation.current() == before
    assert_no_leftovers()


def test_a_killed_runs_setting_is_undone_by_clean():
    before = ovs_revalidation.current()
    ovs_revalidation.apply(9000)  # as a run that was killed after applying it
    assert ovs_revalidation.current() == "9000" and ovs_revalidation.changed()
    res = sdvisc("clean")
    assert res.returncode == 0 and "max-revalidator restored" in res.stdout
    assert ovs_revalidation.current() == before and not ovs_revalidation.changed()
    assert_no_leftovers()
