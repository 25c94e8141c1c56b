"""The model a plant service paces (:func:`build_model`, a :class:`plant.backend.PlantBackend`): the
scenario's ``plant.model`` with the settings of its plant section — the grid source's inertia, batteries on DC links, P* from t = 0 —
applied before t = 0, and the relative ``set`` of a timeline (:func:`apply_set`)."""

from __future__ import annotations

from sdvisc import wire
from sdvisc.config import PlantConfig
from sdvisc.vocabulary import PLANT_TURBINES_PER_CLUSTER as FARM_TURBINES_PER_CLUSTER
from sdvisc.vocabulary import plant_index


def farm_index(name: str, n_farm: int, onshore_units: int = 0, given: int | None = None) -> int:
    """Converter index of host ``name`` in the farm model: ``given``, the topology's ``plant_index`` of
    it (``TurbineEndpoint.plant_index``), or for an endpoint written without one
    :func:`sdvisc.vocabulary.plant_index` (``wt<c>_<n>``: ``(c-1)*10 + n-1``). The onshore units
    follow the farm's ``n_farm`` turbines (``PlantParams.onshore_units``): host ``wt6_<k>`` of the
    50-turbine farm is converter 50 + k - 1 (sdvisc.vocabulary.ONSHORE_CLUSTER)."""
    c, n = wire.parse_turbine(name)
    index = plant_index(c, n) if given is None else given
    if (given is None and n > FARM_TURBINES_PER_CLUSTER) or index >= n_farm + onshore_units:
        units = f" and {onshore_units} onshore unit{'s' * (onshore_units > 1)}" if onshore_units else ""
        raise ValueError(f"turbine host {name} has no converter in the {n_farm}-turbine farm model{units}")
    return index


def endpoint_indices(cfg: PlantConfig) -> dict[str, int]:
    """Each turbine endpoint's converter as the topology's description gives it (``plant_index``);
    two endpoints on one converter are refused."""
    given = {t.name: t.plant_index for t in cfg.turbines if t.plant_index is not None}
    seen: dict[int, str] = {}
    for name, index in given.items():
        if index in seen:
            raise ValueError(f"turbine hosts {seen[index]} and {name} are both converter {index} of the plant model")
        seen[index] = name
    return given


def build_model(cfg: PlantConfig, names: list[str]):
    """The plant model and the model index of each turbine endpoint (by host name).

    ``minimal``: one model turbine per turbine host. ``full``: the 50-turbine farm of
    :mod:`plant.sim`; a turbine host is the farm turbine its ``plant_index`` says (the topology's,
    :func:`farm_index`), the other farm
    turbines run without a network endpoint (grid following); with ``cfg.onshore_units`` the plant has
    that many aggregated onshore units after its turbines (``PlantParams.onshore_units``), host
    ``wt6_<k>`` being unit k (converter 50 + k - 1, ``plant.cases.COMPARISON_UNIT`` for k = 1). The full model takes ``cfg.grid``
    (the grid source, ``GridParams``), ``cfg.p_star`` (P* from t = 0: the steady state is computed
    for it, as plant/cases.py ``visc_plant`` does) and ``cfg.batteries`` (connected at t = 0; the
    packs float on the DC link at ``battery_soc_init``).
    """
    kind = cfg.model
    step_s = cfg.step_s
    if kind == "minimal":
        if cfg.grid.given() or cfg.batteries or cfg.p_star or cfg.onshore_units:
            raise ValueError("grid, batteries, p_star and onshore units need the full plant model")
        from plant.minimal import MinimalPlant

        model = MinimalPlant(len(names), step_s, remote_loss_fallback_s=cfg.remote_loss_fallback_s,
                             remote_apply=cfg.remote_apply)
        return model, list(range(len(names)))
    if kind == "full":
        from dataclasses import replace

        from plant.jitstep import warm_up
        from plant.params import PlantParams
        from plant.sim import Plant

        base = PlantParams()
        turbine = replace(base.turbine, remote_apply=cfg.remote_apply,
                          remote_loss_fallback_s=cfg.remote_loss_fallback_s)
        battery = base.battery if cfg.battery_soc_init is None else replace(base.battery, soc_init=cfg.battery_soc_init)
        params = replace(base, turbine=turbine, grid=replace(base.grid, **cfg.grid.given()), battery=battery,
                         onshore_units=cfg.onshore_units)
        n_farm = params.n_clusters * FARM_TURBINES_PER_CLUSTER

        given = endpoint_indices(cfg)

        def index(name: str) -> int:
            return farm_index(name, n_farm, cfg.onshore_units, given.get(name))

        indices = [index(name) for name in names]
        warm_up(replace(params, onshore_units=0), step_s)  # kernels loaded before t = 0, not at the first CTRL packet
        plant = Plant(params, n_turbines=n_farm, step_s=step_s)  # + the onshore units, after the farm's turbines
        if cfg.p_star:
            for name, p in cfg.p_star.items():
                plant.set_power_ref(index(name), p=p)
            plant.reinitialise()
        if cfg.batteries:
            plant.set_battery([index(name) for name in cfg.batteries], True)
        for scr in [None, *cfg.prepare_scr]:  # the states the run enters: no LU in a paced step
            plant.net.prepare(fault_on=True, **({} if scr is None else {"scr": scr}))
            if scr is not None:
                plant.net.prepare(scr=scr)
        return plant, indices
    if kind == "emt":
        return _emt_model(cfg, names)
    raise ValueError(f"unknown plant model {kind!r}")


def _emt_model(cfg: PlantConfig, names: list[str]):
    """``emt``: the comparison arrangement on DPsim (:class:`plant.emt.service_backend.EmtServiceBackend`):
    the onshore unit (host ``wt6_1``, converter n_farm) is its SDViSC, the farm's turbines one aggregated
    injection (their hosts have indices but no converter of their own). Takes ``cfg.grid`` (the operating
    point's grid source), ``remote_apply``, ``remote_loss_fallback_s`` and ``duration_s``; refuses what it
    cannot model (batteries, a P* other than the unit's 0, other than one onshore unit)."""
    from plant.emt.service_backend import EmtServiceBackend
    from plant.params import PlantParams

    if cfg.batteries:
        raise ValueError("plant.model emt has no batteries (its farm is one aggregated injection at the PCC)")
    if cfg.onshore_units == 0:
        return _emt_farm_model(cfg, names)
    if cfg.onshore_units != 1:
        raise ValueError(f"plant.model emt is the paper's comparison arrangement: it needs topology.onshore_units: 1 "
                         f"(its SDViSC, host wt6_1), not {cfg.onshore_units}")
    n_farm = PlantParams().n_clusters * FARM_TURBINES_PER_CLUSTER
    given = endpoint_indices(cfg)
    indices = [farm_index(name, n_farm, 1, given.get(name)) for name in names]
    refused = {name: p for name, p in cfg.p_star.items()
               if p != 0.0 or farm_index(name, n_farm, 1, given.get(name)) != n_farm}
    if refused:
        raise ValueError(f"plant.model emt runs its SDViSC at P* = 0 and has no farm turbine of its own: "
                         f"p_star {refused} cannot be applied")
    model = EmtServiceBackend(n_farm, cfg.step_s, grid=cfg.grid.given(), remote_apply=cfg.remote_apply,
                              remote_loss_fallback_s=cfg.remote_loss_fallback_s, duration_s=cfg.duration_s)
    return model, indices


def _emt_farm_model(cfg: PlantConfig, names: list[str]):
    """``emt`` without onshore units: F8's farm arrangement with the four SDViSCs of cluster 3
    (:class:`plant.emt.farm_service.EmtFarmServiceBackend`); every turbine host is a farm turbine (its
    ``plant_index``), only wt3_1..wt3_4 have a converter of their own. Refuses a P* other than 0."""
    from plant.emt.farm_service import N_FARM, EmtFarmServiceBackend

    given = endpoint_indices(cfg)
    indices = [farm_index(name, N_FARM, 0, given.get(name)) for name in names]
    refused = {name: p for name, p in cfg.p_star.items() if p != 0.0}
    if refused:
        raise ValueError(f"plant.model emt's farm arrangement runs its SDViSCs at P* = 0: p_star {refused} cannot be applied")
    model = EmtFarmServiceBackend(cfg.step_s, grid=cfg.grid.given(), remote_apply=cfg.remote_apply,
                                  remote_loss_fallback_s=cfg.remote_loss_fallback_s, duration_s=cfg.duration_s)
    return model, indices


def apply_set(model, event: dict) -> dict:
    """A timeline ``set``: ``set_<param>(value)``, or ``set_<param>(get_<param>() + delta)``;
    returns what was applied (``value``, and ``before`` for a delta)."""
    param = event["param"]
    setter = getattr(model, f"set_{param}", None)
    if setter is None:
        raise ValueError(f"plant has no settable parameter {param!r}")
    if event.get("delta") is None:
        setter(event["value"])
        return {"value": event["value"]}
    getter = getattr(model, f"get_{param}", None)
    if getter is None:
        raise ValueError(f"plant cannot change {param!r} by a delta (no get_{param})")
    before = float(getter())
    setter(before + float(event["delta"]))
    return {"before": before, "value": before + float(event["delta"])}
