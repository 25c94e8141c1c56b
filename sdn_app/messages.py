"""The packets the SDN application sends itself (as OpenFlow packet-outs): replies to the OWFCC,
commands to an SDC or a turbine, and frames that teach plain L2 switches where hosts now are.
Pure: each call returns :mod:`sdn_app.flows` actions."""

from __future__ import annotations

from os_ken.lib.packet import ethernet, ipv4, packet, udp

from sdn_app import flows as fl
from sdn_app.state import SdnState
from sdvisc import vocabulary, wire

ETH_TYPE_LEARN = 0x88B5  # IEEE local experimental ethertype: frames that only teach L2 switches


class Messenger:
    """Builds the app's own packets (see the module docstring)."""

    def __init__(self, state: SdnState) -> None:
        self.state = state
        self.request_seq = 0

    def _egress(self, host: str) -> tuple[int, int] | None:
        """(dpid, port) of the OpenFlow switch port from which a packet-out reaches ``host``."""
        st = self.state
        best = None
        for switch in sorted(st.dpids):
            path = st.path_to(switch, host)
            if path is not None and (best is None or len(path) < len(best)):
                best = path
        if best is None:
            return None
        return st.dpids[best[0]], st.graph.edges[best[0], best[1]]["ports"][best[0]]

    def packet_to(self, host: str, dst_port: int, payload: bytes) -> list:
        """A UDP datagram from the controller's virtual address to ``host``:``dst_port``."""
        st = self.state
        egress = self._egress(host)
        if egress is None:
            st.counters["packet_out_unreachable"] += 1
            return []
        info = st.host(host)
        pkt = packet.Packet()
        pkt.add_protocol(ethernet.ethernet(dst=info.mac, src=st.config.controller_vmac, ethertype=fl.ETH_TYPE_IPV4))
        pkt.add_protocol(ipv4.ipv4(dst=info.ip, src=st.config.controller_vip, proto=fl.IP_PROTO_UDP, ttl=64))
        pkt.add_protocol(udp.udp(src_port=wire.PORT_CONTROLLER, dst_port=dst_port))
        pkt.add_protocol(payload)
        pkt.serialize()
        st.counters["packet_out"] += 1
        return [fl.PacketOut(egress[0], egress[1], bytes(pkt.data))]

    def learn_frames(self, path: list[str], src_host: str) -> list:
        """Teach non-OpenFlow switches on ``path`` where ``src_host`` and the controller's virtual
        address now are (frames with their MACs sent from the OpenFlow switch in front of them), so
        an L2 switch with two uplinks follows a reroute at once instead of after MAC ageing — for
        the SDC's packets and for the turbine's AK to the controller alike."""
        st = self.state
        actions = []
        dst_mac = st.host(path[-1]).mac if path[-1] in st.config.topology.hosts else "ff:ff:ff:ff:ff:ff"
        for a, b in zip(path, path[1:]):
            if a in st.dpids and b in st.config.topology.switches and b not in st.dpids:
                for src_mac in (st.host(src_host).mac, st.config.controller_vmac):
                    pkt = packet.Packet()
                    pkt.add_protocol(ethernet.ethernet(dst=dst_mac, src=src_mac, ethertype=ETH_TYPE_LEARN))
                    pkt.add_protocol(b"sdvisc-learn".ljust(46, b"\0"))
                    pkt.serialize()
                    st.counters["packet_out"] += 1
                    actions.append(fl.PacketOut(st.dpids[a], st.graph.edges[a, b]["ports"][a], bytes(pkt.data)))
        return actions

    def _header(self, now: float) -> wire.Header | None:
        if not self.state.config.header:
            return None
        self.request_seq += 1
        return wire.Header.at(self.request_seq, now)

    def reply(self, now: float, req_id: int, status: wire.Status, wid: int, cmd: int, detail: int = 0) -> list:
        """A REPLY to the OWFCC."""
        payload = wire.encode(wire.MsgType.REPLY, {"req_id": req_id, "status": int(status), "wt": wid,
                                                   "cmd": int(cmd), "detail": detail}, header=self._header(now))
        return self.packet_to(self.state.config.owfcc, wire.PORT_OWFCC, payload)

    def command(self, now: float, host: str, port: int, cmd: wire.Command, wid: int, params: dict | None = None,
                sdc: str | None = None) -> list:
        """A REQUEST to an SDC or a turbine (``sdc``: the SDC address it names, default the primary)."""
        st = self.state
        values = {"req_id": self.request_seq + 1, "cmd": int(cmd), "wt": wid,
                  "sdc_ip": wire.ip_to_i32(st.host(sdc or st.config.primary_sdc).ip),
                  **vocabulary.BLANK_REQUEST_PARAMS}
        if params:
            values.update(params)
        return self.packet_to(host, port, wire.encode(wire.MsgType.REQUEST, values, header=self._header(now)))

    def reengage(self, name: str, sdc: str, now: float) -> list:
        """After a long interruption (partition healed, SDC restarted) the turbine has fallen back to
        its own control and the SDC's instance is stale or gone: start the instance afresh (bumpless,
        from the turbine's present operating point) and the turbine's remote mode again."""
        st = self.state
        wid = st.wid(name)
        params = st.paths[name].params if name in st.paths else {}
        return (self.command(now, sdc, wire.PORT_SDC, wire.Command.START_INSTANCE, wid, params, sdc=sdc)
                + self.command(now, name, st.endpoint(name)[1], wire.Command.STREAM_START, wid))
