#!/usr/bin/env bash
# Container entry point: start the Open vSwitch daemons (userspace datapath), then run sdvisc.
set -euo pipefail
/usr/share/openvswitch/scripts/ovs-ctl start --system-id=random >/var/log/ovs-ctl.log 2>&1 || true
ovs-vsctl --timeout=10 show >/dev/null || { echo "Open vSwitch did not start" >&2; cat /var/log/ovs-ctl.log >&2; exit 1; }
exec sdvisc "$@"
