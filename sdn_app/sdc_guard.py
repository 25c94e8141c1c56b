"""SDC liveness and failover: heartbeats in, death decided on evidence, turbines moved to the
backup SDC. Pure: each call takes ``now`` and returns :mod:`sdn_app.flows` actions.

The detector itself is :class:`sdn_app.liveness.SdcLiveness` (phi-accrual on observed arrivals,
hysteresis, restarts). Here: the controller's own stalls (nothing at all arrives for
:data:`STALL_S`: no decision, and silences are counted from the stall's end), corroboration by the
served turbines' own AK reports, and the failover (path to the backup with address rewriting,
``TAKEOVER`` to the backup).
"""

from __future__ import annotations

from sdn_app.liveness import SdcLiveness
from sdn_app.messages import Messenger
from sdn_app.routing import Routing
from sdn_app.state import SdnState
from sdvisc import wire

SETTLE_S = 0.2  # no SDC-death decision this soon after our own flow changes (unless the silence began before them)
CORROBORATE_S = 0.020  # every served turbine's loss must have lasted this long to confirm an SDC death
HEARTBEAT_PERIOD_S = 0.010  # the SDC's nominal heartbeat period (sdc_unit.service.HEARTBEAT_S)
IDLE_SDC_DEAD_FACTOR = 3.0  # an SDC serving no turbine (no corroboration possible): this many sdc_dead_s
STALL_S = 0.015  # no datagram at all (packet-in or intake socket) from anyone for this long: our own (or the switches') stall
MAX_STALL_S = 0.5  # ... but a silence this long is no stall any more (nothing is left that talks to us)


class SdcGuard:
    """See the module docstring."""

    def __init__(self, state: SdnState, routing: Routing, messenger: Messenger) -> None:
        self.state = state
        self.routing = routing
        self.messenger = messenger
        self.liveness = SdcLiveness(HEARTBEAT_PERIOD_S, state.config.sdc_dead_s)
        self.suspects: set[str] = set()  # silent SDCs not (yet) confirmed dead: one event per episode
        self.t_last_arrival = float("-inf")
        self.t_resumed = float("-inf")  # end of the last stall: a datagram after none for STALL_S
        hosts = state.config.topology.hosts
        self.sdc_by_addr = {(hosts[n].ip, hosts[n].mac): n for n in (state.config.primary_sdc,
                                                                    state.config.backup_sdc) if n in hosts}

    @property
    def dead(self) -> set[str]:
        return self.liveness.dead

    # ------------------------------------------------------------------ the controller's own view
    def note_arrival(self, now: float) -> None:
        """Something reached the controller at ``now``."""
        if now - self.t_last_arrival > STALL_S:
            self.t_resumed = now
        self.t_last_arrival = max(self.t_last_arrival, now)

    def stalled(self, now: float) -> bool:
        """Nothing at all has reached the controller for a while: its own stall or the switches'
        (a silence then says nothing about any one sender)."""
        return STALL_S < now - self.t_last_arrival < MAX_STALL_S

    # ------------------------------------------------------------------ heartbeats
    def on_heartbeat(self, msg: wire.Message, src_ip: str, src_mac: str, now: float, where=None) -> list:
        st = self.state
        sdc = self.sdc_by_addr.get((src_ip, src_mac))
        if sdc is None or st.wrong_ingress(sdc, where):
            st.counters["drop_heartbeat_unknown"] += 1
            return []
        st.counters["heartbeats"] += 1
        actions: list = []
        for change in self.liveness.on_heartbeat(sdc, msg["seq"], now, self.t_resumed):
            if change == "alive":
                st.event(now, "sdc_alive", sdc=sdc)
            elif change == "restarted":  # the process came back without its instances: start them again
                served = sorted(n for n, p in st.paths.items() if p.sdc == sdc)
                st.event(now, "sdc_restarted", sdc=sdc, turbines=served)
                for name in served:
                    actions += self.messenger.reengage(name, sdc, now)
        return actions

    # ------------------------------------------------------------------ decisions
    def check(self, now: float) -> list:
        """Decide which silent SDCs are dead, and fail over."""
        st = self.state
        known = self.liveness.known()
        silent = {sdc for sdc in known if self.liveness.silent(sdc, now, self.t_resumed)}
        self.suspects &= silent
        if silent and self.stalled(now):
            st.counters["sdc_check_stalled"] += 1
            return []
        if len(known) > 1 and silent == set(known):
            # every SDC silent at once: far likelier our own stall (a busy event loop, a switch busy
            # revalidating) than all SDCs dying together; decide nothing until heartbeats are seen
            st.counters["sdc_check_all_stale"] += 1
            return []
        actions: list = []
        for sdc in sorted(silent - self.dead):
            t_last = self.liveness.tracks[sdc].t_last
            if now - self.routing.t_flow_change < SETTLE_S and t_last >= self.routing.t_flow_change:
                # the switches just received flow changes from us; Open vSwitch's userspace datapath
                # delays their packet-ins (heartbeats, AK) for tens of ms while it revalidates
                st.counters["sdc_check_settling"] += 1
                continue
            served = sorted(n for n, p in st.paths.items() if p.sdc == sdc)
            if not self._death_corroborated(sdc, served, now):
                st.counters["sdc_suspect_not_corroborated"] += 1
                if sdc not in self.suspects:
                    self.suspects.add(sdc)
                    st.event(now, "sdc_suspect", sdc=sdc, silence_ms=round((now - t_last) * 1e3, 1),
                             phi=round(self.liveness.phi(sdc, now, self.t_resumed), 1), turbines=served)
                continue
            self.liveness.declare_dead(sdc)
            self.suspects.discard(sdc)
            st.event(now, "sdc_dead", sdc=sdc, t_last_heartbeat=t_last, turbines=served)
            if sdc == st.active_sdc:
                actions += self._failover(sdc, served, now, t_last)
        return actions

    def _death_corroborated(self, sdc: str, served: list[str], now: float) -> bool:
        """A silent SDC is dead when every turbine it serves has itself reported that its control
        packets stopped (AK = 0 with a loss of ``CORROBORATE_S``; a missing AK is no report), or
        has sent no AK at all since the silence began while other packets arrive; one serving no
        turbine, after a longer silence."""
        dr = self.state.dr
        if not served:
            silence = self.liveness.silence(sdc, now, self.t_resumed)
            return silence >= IDLE_SDC_DEAD_FACTOR * self.state.config.sdc_dead_s
        return all(dr.reported_loss(n) >= CORROBORATE_S
                   or dr.loss_since(n, now, resumed=self.t_resumed) is not None and dr.tracks[n].t_loss is None
                   for n in served)

    def _failover(self, dead: str, served: list[str], now: float, t_last: float) -> list:
        st = self.state
        backup = st.config.backup_sdc
        if (not st.config.failover or backup is None or backup in self.dead
                or backup not in self.liveness.tracks):
            st.event(now, "failover_unavailable", sdc=dead, turbines=served,
                     reason="failover off" if not st.config.failover else "no live backup SDC")
            return []
        st.active_sdc = backup
        actions: list = []
        for name in served:
            path = st.path_to(backup, name)
            if path is None:
                st.event(now, "failover_no_path", wt=name, sdc=backup)
                continue
            actions += self.routing.install(name, backup, path, now)
            actions += self.messenger.command(now, backup, wire.PORT_SDC, wire.Command.TAKEOVER, st.wid(name),
                                              sdc=backup)
            st.dr.start(name, now, await_path=True)
        st.counters["sdc_failovers"] += 1
        st.event(now, "sdc_failover", sdc=dead, backup=backup, turbines=served, t_loss=t_last, t_detect=now)
        return actions
