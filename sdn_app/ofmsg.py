"""Turn the pure actions of :mod:`sdn_app.flows` into OpenFlow 1.3 messages (no I/O here)."""

from __future__ import annotations

from sdn_app import flows as fl


def _action(a, ofp, parser):
    if isinstance(a, fl.Output):
        if a.port == fl.TO_CONTROLLER:
            return parser.OFPActionOutput(ofp.OFPP_CONTROLLER, ofp.OFPCML_NO_BUFFER)
        if a.port == fl.IN_PORT:
            return parser.OFPActionOutput(ofp.OFPP_IN_PORT, 0)
        return parser.OFPActionOutput(a.port, 0)
    if isinstance(a, fl.Group):
        return parser.OFPActionGroup(a.group_id)
    if isinstance(a, fl.SetField):
        return parser.OFPActionSetField(**{a.name: a.value})
    raise TypeError(f"unknown flow action {a!r}")


def to_messages(action, datapath) -> list:
    """OpenFlow messages for one action, built with ``datapath``'s parser (tests may pass a stub
    object with ``ofproto``/``ofproto_parser`` attributes)."""
    ofp = datapath.ofproto
    parser = datapath.ofproto_parser
    if isinstance(action, fl.FlowAdd):
        acts = [_action(a, ofp, parser) for a in action.actions]
        instructions = [parser.OFPInstructionActions(ofp.OFPIT_APPLY_ACTIONS, acts)] if acts else []
        return [parser.OFPFlowMod(
            datapath=datapath, cookie=action.cookie, priority=action.priority,
            match=parser.OFPMatch(**action.match), instructions=instructions,
            command=ofp.OFPFC_ADD, buffer_id=ofp.OFP_NO_BUFFER,
        )]
    if isinstance(action, fl.FlowDelete):
        return [parser.OFPFlowMod(
            datapath=datapath, cookie=action.cookie, cookie_mask=0xFFFFFFFFFFFFFFFF,
            command=ofp.OFPFC_DELETE, out_port=ofp.OFPP_ANY, out_group=ofp.OFPG_ANY,
            match=parser.OFPMatch(),
        )]
    if isinstance(action, fl.PacketOut):
        return [parser.OFPPacketOut(
            datapath=datapath, buffer_id=ofp.OFP_NO_BUFFER, in_port=ofp.OFPP_CONTROLLER,
            actions=[parser.OFPActionOutput(action.port, 0)], data=action.data,
        )]
    if isinstance(action, fl.GroupAdd):
        buckets = [parser.OFPBucket(weight=0, watch_port=watch, watch_group=ofp.OFPG_ANY,
                                    actions=[_action(a, ofp, parser) for a in acts])
                   for watch, acts in action.buckets]
        return [parser.OFPGroupMod(datapath, ofp.OFPGC_ADD, ofp.OFPGT_FF, action.group_id, buckets)]
    if isinstance(action, fl.Barrier):
        return [parser.OFPBarrierRequest(datapath)]
    if isinstance(action, fl.GroupDelete):
        return [parser.OFPGroupMod(datapath, ofp.OFPGC_DELETE, ofp.OFPGT_FF, action.group_id, [])]
    raise TypeError(f"unknown action {action!r}")
