"""Controller redundancy roles (pure): who sends, and when the slave takes over."""

from __future__ import annotations

import pytest

from sdn_app.redundancy import RoleState


def test_slave_takes_over_after_the_master_goes_silent():
    r = RoleState(role="slave", takeover_s=0.05, t_start=0.0)
    assert not r.sends
    r.on_peer_heartbeat(1, now=10.00)
    assert not r.should_take_over(10.049)
    assert r.should_take_over(10.051)
    assert r.take_over() == 2 and r.role == "master" and r.sends
    assert not r.should_take_over(20.0)  # a master never "takes over" again


def test_slave_without_any_master_takes_over_after_the_grace():
    r = RoleState(role="slave", takeover_s=0.05, startup_grace_s=2.0, t_start=100.0)
    assert not r.should_take_over(101.0)
    assert r.should_take_over(102.06)


def test_generation_follows_the_peer_and_roles_are_checked():
    r = RoleState(role="slave")
    r.on_peer_heartbeat(5, now=1.0)
    assert r.take_over() == 6
    assert RoleState(role="equal").sends and RoleState(role="master").sends
    with pytest.raises(ValueError):
        RoleState(role="boss")
