"""Launch the SDViSC SDN application on os-ken: ``python -m sdn_app --config FILE``.

os-ken 4.x has no ``osken-manager`` command any more, so this does what it did: parse os-ken's
options, set up logging, load the app with the OpenFlow handler and run until killed.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys

from sdvisc.config import AppConfig, ConfigError, load_config


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sdn_app", description=__doc__)
    parser.add_argument("--config", required=True, help="JSON app configuration written by the runner")
    parser.add_argument("--ofp-port", type=int, default=6653, help="OpenFlow listen port (default 6653)")
    parser.add_argument("--listen-host", default="127.0.0.1", help="OpenFlow listen address")
    parser.add_argument("--log-level", default="INFO", choices=["DEBUG", "INFO", "WARNING", "ERROR"])
    parser.add_argument("--role", default="equal", choices=["equal", "master", "slave"],
                        help="OpenFlow role (master/slave for a redundant pair)")
    parser.add_argument("--instance", type=int, default=1, help="instance number (file names, events)")
    parser.add_argument("--peer", help="LISTEN:SEND UDP ports on 127.0.0.1 for the master's heartbeat")
    args = parser.parse_args(argv)

    try:
        load_config(AppConfig, args.config)
    except ConfigError as exc:
        print(f"sdn_app: {exc}", file=sys.stderr)
        return 1
    os.environ["SDVISC_SDN_CONFIG"] = os.path.abspath(args.config)
    os.environ["SDVISC_SDN_ROLE"] = args.role
    os.environ["SDVISC_SDN_INSTANCE"] = str(args.instance)
    if args.peer:
        os.environ["SDVISC_SDN_PEER"] = args.peer

    from os_ken.lib import hub

    hub.patch(thread=False)
    from os_ken import cfg
    from os_ken.base.app_manager import AppManager

    cfg.CONF(args=[f"--ofp-tcp-listen-port={args.ofp_port}", f"--ofp-listen-host={args.listen_host}"],
             project="os_ken")
    logging.basicConfig(level=getattr(logging, args.log_level),
                        format="%(asctime)s %(name)s %(levelname)s %(message)s")
    import sdn_app.app

    def on_term(*_):
        """The first SIGTERM ends the run wherever the main thread is (loading the apps, joining them);
        later ones only mark it, so the closing below is never cut short."""
        if not sdn_app.app.STOPPING:
            sdn_app.app.STOPPING = True
            sys.exit(0)

    signal.signal(signal.SIGTERM, on_term)
    # what AppManager.run_apps does, minus its final thread.kill() (os-ken 4.2's HubThread has none);
    # a SIGTERM while the apps are still being instantiated (a loaded machine) ends here too, never
    # outside main() where os-ken's blocked threads would keep the interpreter from exiting
    manager = AppManager.get_instance()
    try:
        manager.load_apps(["sdn_app.app", "os_ken.controller.ofp_handler"])
        services = manager.instantiate_apps(**manager.create_contexts())
        hub.joinall(services)
    except SystemExit:
        pass
    finally:
        sdn_app.app.STOPPING = True
        manager.close()  # the app writes its last state and closes its files
    return 0


def exit_now(code: int) -> None:
    """Leave without joining os-ken's threads: its OpenFlow server and each switch's receive loop
    block forever in accept/recv (hub.patch(thread=False): real threads), so a normal exit waited
    for the runner's SIGKILL, 5 s after every run. Logs and stdio are flushed first."""
    logging.shutdown()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":
    try:
        exit_code = main()
    except SystemExit as stop:  # (argparse's --help and errors)
        exit_code = 0 if stop.code is None else stop.code if isinstance(stop.code, int) else 1
    exit_now(exit_code)
