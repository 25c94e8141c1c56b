"""What a scenario may ask of each plant model, read from the model classes themselves.

The plant service (``PlantCore.apply_event`` in plant/service/core.py) applies a timeline ``set`` action as
``getattr(model, f"set_{param}")(value)`` with one number (or, with a ``delta``,
``set_<param>(get_<param>() + delta)``), and ``load_step``/``fault``/``scr`` by
calling ``load_step``/``fault``/``set_scr``. ``sdvisc check`` uses these helpers to reject, before a
run, what the chosen model could not apply, so the lists cannot drift from the models.
"""

from __future__ import annotations

import importlib
import inspect

# plant.model value -> (module, class); the same choice as plant/service/main.py build_model
MODELS = {"minimal": ("plant.minimal", "MinimalPlant"), "full": ("plant.sim", "Plant"),
          "emt": ("plant.emt.service_backend", "EmtServiceBackend")}
# timeline action -> the model method the plant service calls for it
ACTIONS = {"load_step": "load_step", "fault": "fault", "scr": "set_scr"}
_NUMBER = (float, int, bool)
_POSITIONAL = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)


def model_class(model: str) -> type:
    """The plant class used for ``plant.model: <model>``."""
    module, name = MODELS[model]
    return getattr(importlib.import_module(module), name)


def _takes_one_number(func) -> bool:
    try:
        sig = inspect.signature(func, eval_str=True)
    except (NameError, TypeError, ValueError):  # an annotation we cannot resolve: not a plain number
        return False
    params = list(sig.parameters.values())[1:]  # after self
    if not params or params[0].kind not in _POSITIONAL or params[0].annotation not in _NUMBER:
        return False
    rest_required = [p for p in params[1:] if p.default is p.empty
                     and p.kind not in (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)]
    return not rest_required


def settable_params(cls: type) -> list[str]:
    """Sorted ``<param>`` names of ``cls``'s ``set_<param>(value)`` methods that take one number
    (float, int or bool) and nothing else required: what a timeline ``set`` action can change."""
    return sorted(name[4:] for name, func in inspect.getmembers(cls, inspect.isfunction)
                  if name.startswith("set_") and _takes_one_number(func))


def relative_params(cls: type) -> list[str]:
    """Sorted settable ``<param>`` names that ``cls`` can also read back with a ``get_<param>()``
    method taking no argument: what a timeline ``set`` can change by a ``delta``."""
    def readable(name: str) -> bool:
        func = getattr(cls, f"get_{name}", None)
        if not inspect.isfunction(func):
            return False
        rest = list(inspect.signature(func).parameters.values())[1:]
        return all(p.default is not p.empty or p.kind in (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
                   for p in rest)

    return [name for name in settable_params(cls) if readable(name)]


def supported_actions(cls: type) -> list[str]:
    """The plant timeline actions (``load_step``, ``fault``, ``scr``) ``cls`` can apply."""
    return [action for action, method in ACTIONS.items() if callable(getattr(cls, method, None))]
