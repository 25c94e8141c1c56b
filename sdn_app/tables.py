"""The SDN application's three lookup tables (paper Section III-B-2), pure data with checked transitions.

* **T1** turbine → IP, MAC, attachment (switch, port) and the UDP port of its endpoint (turbines of
  one GTNET-SKT card share the IP, MAC and attachment, each on its own UDP port);
* **T2** operating mode ``x/y``: ``x`` current mode (1 = ViSC), ``y`` ViSC enabled; ``1/0`` is impossible;
* **T3** communication state ``x/y``: ``x`` communication with the SDC on, ``y`` a link meeting the
  requirement exists.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from sdvisc.wire_layouts import PORT_TURBINE


class TableError(ValueError):
    """An impossible table entry or transition (e.g. T2 ``1/0``)."""


@dataclass(frozen=True)
class TurbineAddress:
    """A T1 row."""

    name: str
    cluster: int
    number: int
    ip: str
    mac: str
    switch: str
    port: int
    udp_port: int = PORT_TURBINE


@dataclass(frozen=True)
class TwoDigit:
    """A ``x/y`` table state."""

    first: int
    second: int

    def __post_init__(self):
        if self.first not in (0, 1) or self.second not in (0, 1):
            raise TableError(f"table digits must be 0 or 1, got {self.first}/{self.second}")

    def __str__(self) -> str:
        return f"{self.first}/{self.second}"

    @classmethod
    def parse(cls, text: str) -> TwoDigit:
        try:
            a, b = text.split("/")
            return cls(int(a), int(b))
        except ValueError as exc:
            raise TableError(f"expected 'x/y' with x, y in 0/1, got {text!r}") from exc


class Tables:
    """T1–T3 for every known turbine, with the paper's encodings and their invariants."""

    def __init__(self) -> None:
        self.t1: dict[str, TurbineAddress] = {}
        self.t2: dict[str, TwoDigit] = {}
        self.t3: dict[str, TwoDigit] = {}

    # --- T1 -----------------------------------------------------------------------------------
    def plug(self, address: TurbineAddress, *, visc_enabled: bool = True) -> None:
        """A turbine joins (plug-and-play): T1 row added, T2 ``0/enabled``, T3 ``0/0``."""
        self.t1[address.name] = address
        self.t2[address.name] = TwoDigit(0, int(visc_enabled))
        self.t3[address.name] = TwoDigit(0, 0)

    def unplug(self, name: str) -> None:
        """A turbine leaves: its rows are removed from all three tables."""
        for table in (self.t1, self.t2, self.t3):
            table.pop(name, None)

    def lookup(self, name: str) -> TurbineAddress | None:
        return self.t1.get(name)

    # --- T2 -----------------------------------------------------------------------------------
    def set_mode(self, name: str, visc: bool) -> None:
        """Set the current mode; ViSC (``1/y``) needs ``y`` = 1 (enabled)."""
        enabled = self.t2[name].second
        if visc and not enabled:
            raise TableError(f"{name}: T2 1/0 is impossible (ViSC not enabled)")
        self.t2[name] = TwoDigit(int(visc), enabled)

    def set_enabled(self, name: str, enabled: bool) -> None:
        """Enable/disable ViSC; disabling a turbine in ViSC mode is refused (switch it off first)."""
        current = self.t2[name].first
        if current and not enabled:
            raise TableError(f"{name}: cannot disable ViSC while it runs (T2 would be 1/0)")
        self.t2[name] = TwoDigit(current, int(enabled))

    def visc_enabled(self, name: str) -> bool:
        return bool(self.t2[name].second)

    def in_visc(self, name: str) -> bool:
        return bool(self.t2[name].first)

    # --- T3 -----------------------------------------------------------------------------------
    def set_comm(self, name: str, *, comm_on: bool | None = None, link_ok: bool | None = None) -> None:
        old = self.t3[name]
        self.t3[name] = TwoDigit(
            old.first if comm_on is None else int(comm_on),
            old.second if link_ok is None else int(link_ok),
        )

    def comm(self, name: str) -> TwoDigit:
        return self.t3[name]

    def as_dict(self) -> dict:
        """JSON-ready view: ``{"T1": {...}, "T2": {name: "x/y"}, "T3": {name: "x/y"}}``."""
        return {
            "T1": {n: asdict(a) for n, a in sorted(self.t1.items())},
            "T2": {n: str(v) for n, v in sorted(self.t2.items())},
            "T3": {n: str(v) for n, v in sorted(self.t3.items())},
        }
