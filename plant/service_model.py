"""The model a plant service paces (:func:`build_model`, a :class:`plant.backend.PlantBackend`): the
scenario's ``plant.model`` with the settings of its plant section — the grid source's inertia, batteries on DC links, P* from t = 0 —
applied before t = 0, and the relative ``set`` of a timeline (:func:`apply_set`)."""

from __future__ import annotations

from sdvisc import wire
from sdvisc.config import PlantConfig

FARM_TURBINES_PER_CLUSTER = 10


def farm_index(name: str, n_farm: int, onshore_units: int = 0) -> int:
    """Converter index of host ``wt<c>_<n>`` in the farm model: ``(c-1)*10 + n-1``. The onshore units
    follow the farm's ``n_farm`` turbines (``PlantParams.onshore_units``): host ``wt6_<k>`` of the
    50-turbine farm is converter 50 + k - 1 (sdvisc.vocabulary.ONSHORE_CLUSTER)."""
    c, n = wire.parse_turbine(name)
    index = (c - 1) * FARM_TURBINES_PER_CLUSTER + (n - 1)
    if n > FARM_TURBINES_PER_CLUSTER or index >= n_farm + onshore_units:
        units = f" and {onshore_units} onshore unit{'s' * (onshore_units > 1)}" if onshore_units else ""
        raise ValueError(f"turbine host {name} has no converter in the {n_farm}-turbine farm model{units}")
    return index


def build_model(cfg: PlantConfig, names: list[str]):
    """The plant model and the model index of each turbine endpoint (by host name).

    ``minimal``: one model turbine per turbine host. ``full``: the 50-turbine farm of
    :mod:`plant.sim`; host ``wt<c>_<n>`` is farm turbine ``(c-1)*10 + n-1``, the other farm
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

        def index(name: str) -> int:
            return farm_index(name, n_farm, cfg.onshore_units)

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
    if cfg.onshore_units != 1:
        raise ValueError(f"plant.model emt is the paper's comparison arrangement: it needs topology.onshore_units: 1 "
                         f"(its SDViSC, host wt6_1), not {cfg.onshore_units}")
    n_farm = PlantParams().n_clusters * FARM_TURBINES_PER_CLUSTER
    indices = [farm_index(name, n_farm, 1) for name in names]
    refused = {name: p for name, p in cfg.p_star.items() if p != 0.0 or farm_index(name, n_farm, 1) != n_farm}
    if refused:
        raise ValueError(f"plant.model emt runs its SDViSC at P* = 0 and has no farm turbine of its own: "
                         f"p_star {refused} cannot be applied")
    model = EmtServiceBackend(n_farm, cfg.step_s, grid=cfg.grid.given(), remote_apply=cfg.remote_apply,
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
