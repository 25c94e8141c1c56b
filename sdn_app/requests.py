"""The OWFCC's requests (paper Section III: ``ViSC_WT_i``): look T1 up, check T2 (enabled) and T3
(a link exists), choose a path, install it both ways, command the SDC and the turbine, answer the
OWFCC; ``visc_off`` and parameter changes likewise; refusals are answered with a reason. Only
the OWFCC may ask (its registered addresses and, where it sits on an OpenFlow port, that port).
Pure: each call takes ``now`` and returns :mod:`sdn_app.flows` actions."""

from __future__ import annotations

from sdn_app.messages import Messenger
from sdn_app.recovery import Recovery
from sdn_app.routing import Routing
from sdn_app.state import SdnState
from sdvisc import wire
from sdvisc.vocabulary import REQUEST_PARAM_WORDS


class Requests:
    """See the module docstring."""

    def __init__(self, state: SdnState, routing: Routing, messenger: Messenger, recovery: Recovery) -> None:
        self.state = state
        self.routing = routing
        self.messenger = messenger
        self.recovery = recovery

    def on_request(self, msg: wire.Message, src_ip: str, src_mac: str, now: float, where=None) -> list:
        st, reply = self.state, self.messenger.reply
        owfcc = st.host(st.config.owfcc)
        if src_ip != owfcc.ip or src_mac != owfcc.mac or st.wrong_ingress(st.config.owfcc, where):
            st.counters["drop_request_not_owfcc"] += 1
            return []
        st.counters["requests"] += 1
        cmd, wid, req_id = msg["cmd"], msg["wt"], msg["req_id"]
        if not wire.is_turbine_id(wid):
            st.counters["drop_unknown_turbine"] += 1
            st.event(now, "request_refused", wt=wid, cmd=wire.Command(cmd).name, reason="not a turbine id")
            return reply(now, req_id, wire.Status.UNKNOWN_TURBINE, wid, cmd)
        name = wire.turbine_name(wid)
        if st.tables.lookup(name) is None:
            st.event(now, "request_refused", wt=name, cmd=wire.Command(cmd).name, reason="unknown turbine")
            return reply(now, req_id, wire.Status.UNKNOWN_TURBINE, wid, cmd)
        if cmd == wire.Command.VISC_ON:
            return self._visc_on(msg, name, now)
        if cmd == wire.Command.VISC_OFF:
            return self._visc_off(msg, name, now)
        if cmd == wire.Command.SET_PARAMS:
            if not st.tables.in_visc(name):
                return reply(now, req_id, wire.Status.REFUSED, wid, cmd, detail=1)
            params = {k: msg[k] for k in REQUEST_PARAM_WORDS}
            st.event(now, "set_params", wt=name, **params)
            return (self.messenger.command(now, st.paths[name].sdc, wire.PORT_SDC, wire.Command.SET_PARAMS, wid, params)
                    + reply(now, req_id, wire.Status.OK, wid, cmd))
        return reply(now, req_id, wire.Status.BAD_REQUEST, wid, cmd)

    def _visc_on(self, msg: wire.Message, name: str, now: float) -> list:
        st, reply = self.state, self.messenger.reply
        wid, req_id, cmd = msg["wt"], msg["req_id"], msg["cmd"]
        if not st.tables.visc_enabled(name):
            st.event(now, "request_refused", wt=name, cmd="VISC_ON", reason="ViSC not enabled (T2 x/0)")
            return reply(now, req_id, wire.Status.NOT_ENABLED, wid, cmd)
        st.refresh_link_ok(name)
        sdc = st.active_sdc
        path = st.path_to(sdc, name)
        if path is None or not st.tables.comm(name).second:
            st.event(now, "request_refused", wt=name, cmd="VISC_ON", reason="no path (T3 x/0)")
            return reply(now, req_id, wire.Status.NO_PATH, wid, cmd)
        actions: list = self.routing.remove(name)  # an idempotent re-request re-installs
        actions += self.routing.install(name, sdc, path, now)
        st.tables.set_mode(name, True)
        st.tables.set_comm(name, comm_on=True, link_ok=True)
        st.dr.start(name, now, armed=False)
        self.recovery.forget(name)
        params = {k: msg[k] for k in REQUEST_PARAM_WORDS}
        st.paths[name].params = params
        st.event(now, "visc_on", wt=name, sdc=sdc, path=path, flows=st.counters["flow_mods"])
        actions += self.messenger.command(now, sdc, wire.PORT_SDC, wire.Command.START_INSTANCE, wid, params)
        actions += self.messenger.command(now, name, st.endpoint(name)[1], wire.Command.STREAM_START, wid)
        actions += reply(now, req_id, wire.Status.OK, wid, cmd)
        return actions

    def _visc_off(self, msg: wire.Message, name: str, now: float) -> list:
        st, reply = self.state, self.messenger.reply
        wid, req_id, cmd = msg["wt"], msg["req_id"], msg["cmd"]
        if not st.tables.in_visc(name):
            return reply(now, req_id, wire.Status.OK, wid, cmd, detail=1)
        sdc = st.paths[name].sdc if name in st.paths else st.active_sdc
        actions = self.messenger.command(now, name, st.endpoint(name)[1], wire.Command.STREAM_STOP, wid)
        actions += self.messenger.command(now, sdc, wire.PORT_SDC, wire.Command.STOP_INSTANCE, wid)
        actions += self.routing.remove(name)
        st.dr.stop(name)
        self.recovery.forget(name)
        st.tables.set_mode(name, False)
        st.tables.set_comm(name, comm_on=False)
        st.event(now, "visc_off", wt=name)
        return actions + reply(now, req_id, wire.Status.OK, wid, cmd)
