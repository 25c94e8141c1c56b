"""The ``cluster:`` scenario key without servers (scenarios/cluster_spec.py, the loader's checks) and
the command lines a run sends to a server (scenarios/remote_process.py, scenarios/netprep.py)."""

from __future__ import annotations

import shlex
import subprocess
from pathlib import Path

import pytest
from pydantic import ValidationError

from scenarios.cluster_spec import HEAD, ClusterSpec, place
from scenarios.loader import ScenarioError, load_scenario
from scenarios.netprep import SHELL_LINE_MAX, neighbour_lines, remote_batches
from scenarios.remote_process import remote_command
from topologies import topos
from topologies.base import describe

BASE = """name: c
topology: {name: paper, clusters: 1, turbines: 2}
duration_s: 3.0
plant: {model: minimal}
"""


def paper_desc():
    return describe(topos["paper"](clusters=1, turbines=2))


def test_by_role_puts_openflow_switches_on_the_servers_in_turn_and_each_sdc_with_its_switch():
    where = place(paper_desc(), {"ctl": "intake", "sctl": "intake"}, ClusterSpec(emulate=2))
    assert [where[s] for s in ("s1", "s2", "s3", "s4")] == ["srv1", "srv2", "srv1", "srv2"]  # dpid order
    assert where["sdc1"] == where["s1"] and where["sdc2"] == where["s2"]
    # the plant's side, the OWFCC and the app's intake stay on the head
    assert {where[n] for n in ("l2", "wt1_1", "wt1_2", "owfcc", "ctl", "sctl")} == {HEAD}


def test_an_explicit_placement_wins_node_by_node():
    spec = ClusterSpec(emulate=2, placement={"s3": "srv2", "s1": "srv1", "sdc2": "head"})
    where = place(paper_desc(), {}, spec)
    assert (where["s1"], where["s3"], where["sdc2"]) == ("srv1", "srv2", HEAD)
    assert where["sdc1"] == "srv1"  # with its switch


def test_by_cluster_puts_each_farm_cluster_switch_on_its_server():
    desc = describe(topos["farm"](clusters=5, turbines=2, layout="compact"))
    where = place(desc, {}, ClusterSpec(emulate=2, placement="by_cluster"))
    assert [where[f"c{c}"] for c in range(1, 6)] == ["srv1", "srv2", "srv1", "srv2", "srv1"]
    assert {where["sub1"], where["sub2"]} == {"srv1", "srv2"}  # the substation by role
    assert where["sdc1"] == where["sub1"] and where["wt3_1"] == HEAD


def test_real_servers_by_name():
    spec = ClusterSpec(servers={"rack-a": {"address": "192.0.2.10"}, "rack-b": {"address": "192.0.2.11", "user": "lab"}})
    assert spec.server_names() == ["rack-a", "rack-b"]
    assert place(paper_desc(), {}, spec)["s2"] == "rack-b"


@pytest.mark.parametrize("cluster, words", [
    ({}, "one of them"),
    ({"emulate": 2, "servers": {"a": {"address": "192.0.2.1"}}}, "one of them"),
    ({"servers": {"head": {"address": "192.0.2.1"}}}, "something else"),
    ({"servers": {"a": {"address": "not-an-ip"}}}, "IPv4"),
    ({"emulate": 2, "lan": "10.9.0.0/28"}, "64 addresses"),
    ({"emulate": 2, "tunnel": "gre"}, "vxlan"),
])
def test_bad_cluster_keys_are_refused(cluster, words):
    with pytest.raises(ValidationError, match=words):
        ClusterSpec.model_validate(cluster)


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "c.yaml"
    path.write_text(BASE + text)
    return path


def test_the_loader_names_every_placement_problem_with_its_line(tmp_path):
    path = write(tmp_path, """cluster:
  emulate: 2
  placement: {wt1_1: srv1, l2: srv2, s9: srv1, s1: srv3}
timeline:
  - {t: 1.0, do: server_down, server: srv7}
""")
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    text = str(err.value)
    assert "cluster.placement.wt1_1: wt1_1 is a turbine host: it stays on the head" in text
    assert "cluster.placement.l2: l2 is the plant side's layer-2 switch" in text
    assert "cluster.placement.s9: no host or switch 's9'" in text
    assert "cluster.placement.s1: no server 'srv3'" in text
    assert "timeline.0.server: no server 'srv7'" in text
    assert f"{path}:7:" in text  # the line of the timeline entry


def test_server_down_needs_stand_in_servers(tmp_path):
    with pytest.raises(ScenarioError, match="only with emulate"):
        load_scenario(write(tmp_path, """cluster: {servers: {a: {address: 192.0.2.1}}}
timeline:
  - {t: 1.0, do: server_down, server: a}
"""))
    with pytest.raises(ScenarioError, match="server_down needs cluster"):
        load_scenario(write(tmp_path, "timeline:\n  - {t: 1.0, do: server_down, server: srv1}\n"))


def test_options_that_act_on_this_machine_only_are_refused_across_servers(tmp_path):
    with pytest.raises(ScenarioError) as err:
        load_scenario(write(tmp_path, "switch_ports: afxdp\nswitch_links: patch\ncluster: {emulate: 2}\n"))
    assert "switch_ports: afxdp" in str(err.value) and "switch_links: patch" in str(err.value)


def test_the_shipped_cluster_scenarios_load():
    root = Path(__file__).resolve().parents[2] / "scenarios"
    for name in ("cluster_smoke", "cluster_link_failure_dr", "cluster_server_loss"):
        sc = load_scenario(root / f"{name}.yaml")
        assert sc.cluster is not None and sc.cluster.emulate == 2


def test_a_remote_service_gets_the_run_environment_and_writes_its_pid(tmp_path):
    pidfile = tmp_path / "svc.pid"
    cmd = remote_command(4242, ["python3", "-m", "x", "--config", "/a b/c.json"],
                         {"PYTHONUNBUFFERED": "1", "SDVISC_RUN": "1", "HOME": "/root", "OPENBLAS_NUM_THREADS": "1"},
                         pidfile)
    words = shlex.split(cmd.split("; ", 1)[1])
    assert words[:4] == ["exec", "env", "OPENBLAS_NUM_THREADS=1", "PYTHONUNBUFFERED=1"]
    assert "HOME=/root" not in words  # only the run's own variables
    assert words[words.index("mnexec"):] == ["mnexec", "-a", "4242", "python3", "-m", "x", "--config", "/a b/c.json"]
    # the shell part runs: the PID file gets the shell's PID, which exec hands to the service
    out = subprocess.run(["sh", "-c", cmd.replace("mnexec -a 4242 ", "")
                          .replace("python3 -m x --config '/a b/c.json'", "sh -c 'echo $$'")],
                         capture_output=True, text=True, timeout=10)
    assert out.stdout.strip() == pidfile.read_text().strip()


def test_static_arp_for_a_host_on_a_server_fits_its_shell_lines():
    peers = [(f"wt{i}_1", f"10.0.{i}.1", f"02:00:00:00:{i // 256:02x}:{i % 256:02x}") for i in range(1, 60)]
    lines = neighbour_lines("wt1_1", "wt1_1-eth0", peers, [("10.0.0.254", "02:00:00:00:00:fe")])
    commands = remote_batches(lines)
    assert len(commands) > 1 and all(len(c) < SHELL_LINE_MAX for c in commands)
    # what the commands feed to "ip -batch" is every line, once, in order
    fed = []
    for c in commands:
        printf = c.split(" | ")[0]
        fed += subprocess.run(["sh", "-c", printf], capture_output=True, text=True, timeout=10).stdout.splitlines()
    assert fed == lines


def test_a_server_user_other_than_root_runs_the_service_under_sudo(tmp_path):
    args = ["python3", "-m", "sdc_unit.service", "--config", "/x.json"]
    as_root = remote_command(7, args, {"SDVISC_RUN": "1"}, tmp_path / "p")
    assert shlex.split(remote_command(7, args, {"SDVISC_RUN": "1"}, tmp_path / "p", user="lab")) == \
        ["sudo", "-n", "sh", "-c", as_root]


def test_a_real_server_without_a_key_is_opened_with_sshs_own_keys():
    from host_tools.servers import Server, ssh_options

    assert "-i" not in ssh_options(None) and "IdentitiesOnly=yes" not in ssh_options(None)
    assert ssh_options("/k")[:2] == ["-i", "/k"] and "BatchMode=yes" in ssh_options(None)
    server = Server(name="rack-a", index=1, ip="192.0.2.10", key=None, user="lab")
    assert server.ssh[-1] == "lab@192.0.2.10" and "-i" not in server.ssh
