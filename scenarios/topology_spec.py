"""The scenario's ``topology`` section: a topology's name (one of :data:`topologies.topos`, or of a
custom file as ``mn --custom`` takes it), the switches Mininet does not build, and the topology's
own options, checked against the pydantic model the topology declares (topologies/options.py)."""

from __future__ import annotations

from pathlib import Path

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    SerializeAsAny,
    ValidationError,
    ValidationInfo,
    model_validator,
)
from pydantic_core import InitErrorDetails, PydanticCustomError

from scenarios.external_spec import ExternalSwitchSpec


class TopologySpec(BaseModel):
    """The ``topology`` section: ``name`` (a topology of :data:`topologies.topos`, or of the ``custom``
    file), the switches Mininet does not build, and the topology's own options beside them
    (``topology: {name: farm, clusters: 5, layout: tower}``), checked against the pydantic model the
    topology declares (topologies/options.py); ``options`` holds them, validated."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)  # (as every section of the file)

    name: str = Field("paper", description="a topology of topologies.topos, or of the custom file")
    custom: str | None = Field(None, description=(
        "a Python file exporting topos = {name: TopoClass}, as for mn --custom; relative to the scenario file"))
    external_switches: dict[str, ExternalSwitchSpec] = Field(default_factory=dict, description=(
        "OpenFlow switches of this topology that Mininet does not build: hardware switches (or, emulated, plain "
        "Open vSwitch bridges) the SDN app controls all the same (scenarios/external_spec.py)"))
    options: SerializeAsAny[dict | BaseModel] = Field(default_factory=dict, description=(
        "the topology's options (its options_model), given beside name in the file"))

    @model_validator(mode="before")
    @classmethod
    def _options_beside_name(cls, data):
        if not isinstance(data, dict):
            return data
        own = {"name", "custom", "external_switches"}
        nested = data["options"] if isinstance(data.get("options"), dict) else None  # (a dump read back)
        given = {k: v for k, v in data.items() if k not in own and not (k == "options" and nested is not None)}
        return {**{k: v for k, v in data.items() if k in own}, "options": {**(nested or {}), **given}}

    @model_validator(mode="after")
    def _options_of_the_topology(self, info: ValidationInfo):
        from topologies.custom import CustomFileError, TopologyNotFound, topology_class
        from topologies.options import options_of

        if self.custom is not None:
            base = Path((info.context or {}).get("scenario_dir", "."))
            self.custom = str((base / self.custom).resolve())
        try:
            cls = topology_class(self.name, self.custom)
        except TopologyNotFound as exc:
            key = "custom" if isinstance(exc, CustomFileError) else "name"
            raise ValidationError.from_exception_data("TopologySpec", [InitErrorDetails(
                type=PydanticCustomError("topology", str(exc)), loc=(key,), input=getattr(self, key))]) from None
        given = self.options if isinstance(self.options, dict) else self.options.model_dump()
        self.options = options_of(cls).model_validate(given)
        return self

    def topo_class(self):
        """The Mininet ``Topo`` class of this topology."""
        from topologies.custom import topology_class

        return topology_class(self.name, self.custom)

    def params(self) -> dict:
        """The topology's options as keyword arguments of its class."""
        return self.options.model_dump()

    def option(self, key: str, default=None):
        """One option of the topology (``default`` if it has no such option)."""
        return getattr(self.options, key, default)

    def label(self) -> str:
        """The topology and its options, for messages: ``farm (clusters=5, turbines=10, ...)``."""
        return f"{self.name} ({', '.join(f'{k}={v}' for k, v in self.params().items())})"
