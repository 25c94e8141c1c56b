"""Issue 42 item 3: with SIGHUP ignored by the parent (nohup, some CI runners and service managers)
every child inherits SIG_IGN; Mininet ends a node's shell with SIGHUP and waits without a timeout, so
``ClusterNet.stop()`` waited for ever for a server node's ssh client. Here the ClusterNet test and a
cluster scenario run in a process started with SIGHUP ignored: both end, and leave nothing."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest

from tests.integration.helpers import ROOT, assert_no_leftovers, time_scale_args

pytestmark = pytest.mark.network


def nohup() -> None:
    signal.signal(signal.SIGHUP, signal.SIG_IGN)


def test_the_cluster_net_test_ends_with_sighup_ignored():
    test = "tests/integration/test_cluster_servers.py::test_paper_topology_across_two_servers_carries_udp_over_a_vxlan_tunnel"
    try:
        res = subprocess.run([sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", test], cwd=ROOT,
                             capture_output=True, text=True, timeout=600, preexec_fn=nohup,
                             env=dict(os.environ, PYTHONUNBUFFERED="1"))
    except subprocess.TimeoutExpired as exc:
        pytest.fail(f"the ClusterNet test did not end in 600 s under nohup: {exc.stdout}")
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-2000:]
    assert "1 passed" in res.stdout
    assert_no_leftovers()


def test_a_cluster_scenario_ends_with_sighup_ignored(tmp_path):
    try:
        res = subprocess.run([sys.executable, "-m", "scenarios.cli", "run", "scenarios/cluster_smoke.yaml", "--out",
                              str(tmp_path), "--quiet", *time_scale_args()], cwd=ROOT, capture_output=True, text=True,
                             timeout=600, preexec_fn=nohup, env=dict(os.environ, PYTHONUNBUFFERED="1"))
    except subprocess.TimeoutExpired as exc:
        pytest.fail(f"sdvisc run did not end in 600 s under nohup: {exc.stdout}")
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-2000:]
    assert (tmp_path / "summary.json").exists()
    assert_no_leftovers()
