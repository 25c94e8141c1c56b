"""The static ARP a run installs: one permanent entry per other addressed host and for the
controller's virtual IP (what Mininet's staticArp did pair by pair)."""

from __future__ import annotations

from scenarios.netprep import neighbour_lines


def test_one_permanent_entry_per_other_host_and_the_controller():
    peers = [("wt1_1", "10.0.0.1", "00:00:00:00:00:01"), ("sdc1", "10.0.0.2", "00:00:00:00:00:02"),
             ("owfcc", "10.0.0.3", "00:00:00:00:00:03")]
    lines = neighbour_lines("sdc1", "sdc1-eth0", peers, [("10.0.0.254", "00:00:00:00:00:fe")])
    assert lines == [
        "neigh replace 10.0.0.1 lladdr 00:00:00:00:00:01 dev sdc1-eth0 nud permanent",
        "neigh replace 10.0.0.3 lladdr 00:00:00:00:00:03 dev sdc1-eth0 nud permanent",
        "neigh replace 10.0.0.254 lladdr 00:00:00:00:00:fe dev sdc1-eth0 nud permanent",
    ]


def test_controller_records_of_the_runs_bridges_from_the_ovsdb_json():
    from scenarios.netprep import controller_uuids

    listing = {"headings": ["name", "controller"], "data": [
        ["s1", ["uuid", "aaaa"]],
        ["s2", ["set", [["uuid", "bbbb"], ["uuid", "cccc"]]]],
        ["l1", ["set", []]],
        ["other", ["uuid", "dddd"]],
    ]}
    assert controller_uuids(listing, {"s1", "s2", "l1"}) == ["aaaa", "bbbb", "cccc"]
