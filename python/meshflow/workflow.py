"""A builder for the workflow JSON the engine takes (docs/workflows.md).

    from meshflow import Workflow, check, run

    wf = (Workflow()
          .run("remove-smallest-components")
          .run("laplacian-smoothing", iterations=2)
          .while_(check("hole-count") > 0, [run("fill-holes", max_hole_edges=200)],
                  max_iterations=3)
          .if_(check("is-manifold") == False, [run("remove-degenerate-triangles")]))
    wf.to_dict()   # {"steps": [{"run": ...}, {"while": {...}, "do": [...]}, ...]}

Keyword parameters have ``_`` turned into ``-`` (``keep_boundary`` → ``keep-boundary``) and
a trailing ``_`` dropped (``lambda_`` → ``lambda``); ``params={...}`` passes names as given.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Iterable


def _param_name(name: str) -> str:
    return name.rstrip("_").replace("_", "-")


def _params(params: dict | None, kwargs: dict) -> dict:
    out = dict(params or {})
    for k, v in kwargs.items():
        out[_param_name(k)] = v
    return out


class Condition:
    """``{"check": SERVICE, "params": {...}, "op": OP, "value": V}``; made by comparing a
    :class:`Check` with a value (``check("hole-count") > 0``)."""

    def __init__(self, check: "Check", op: str, value: Any):
        self.check, self.op, self.value = check, op, value

    def to_dict(self) -> dict:
        d = {"check": self.check.service}
        if self.check.params:
            d["params"] = dict(self.check.params)
        d["op"] = self.op
        d["value"] = self.value
        if self.check.plugin:
            d["plugin"] = self.check.plugin
        return d

    def __bool__(self):
        raise TypeError("a meshflow condition is evaluated by the engine, not in Python")

    def __repr__(self):
        return f"Condition({json.dumps(self.to_dict())})"


class Check:
    """A check service with parameters; compare it to make a :class:`Condition`."""

    __hash__ = None  # == makes a Condition

    def __init__(self, service: str, params: dict | None = None, plugin: str | None = None, **kwargs):
        self.service = service
        self.params = _params(params, kwargs)
        self.plugin = plugin

    def __lt__(self, v): return Condition(self, "<", v)
    def __le__(self, v): return Condition(self, "<=", v)
    def __gt__(self, v): return Condition(self, ">", v)
    def __ge__(self, v): return Condition(self, ">=", v)
    def __eq__(self, v): return Condition(self, "==", v)  # type: ignore[override]
    def __ne__(self, v): return Condition(self, "!=", v)  # type: ignore[override]

    def __repr__(self):
        return f"check({self.service!r}, params={self.params!r})"


def check(service: str, params: dict | None = None, plugin: str | None = None, **kwargs) -> Check:
    """A check to compare: ``check("hole-count") > 0``."""
    return Check(service, params, plugin, **kwargs)


def run(service: str, params: dict | None = None, plugin: str | None = None, **kwargs) -> dict:
    """One filter step: ``{"run": SERVICE, "params": {...}, "plugin": DIGEST}``."""
    step: dict = {"run": service}
    p = _params(params, kwargs)
    if p:
        step["params"] = p
    if plugin:
        step["plugin"] = plugin
    return step


def _cond(cond) -> dict:
    if isinstance(cond, Condition):
        return cond.to_dict()
    if isinstance(cond, dict):
        return dict(cond)
    raise TypeError(f"a condition is check(...) compared with a value, not {type(cond).__name__}")


def _steps(steps) -> list:
    if isinstance(steps, Workflow):
        return steps.to_dict()["steps"]
    if isinstance(steps, dict):
        return [steps]
    out = []
    for s in steps:
        if isinstance(s, Workflow):
            out.extend(s.to_dict()["steps"])
        elif isinstance(s, dict):
            out.append(s)
        else:
            raise TypeError(f"a step is run(...), a dict or a Workflow, not {type(s).__name__}")
    return out


def if_(cond, then, else_=None) -> dict:
    step = {"if": _cond(cond), "then": _steps(then)}
    if else_:
        step["else"] = _steps(else_)
    return step


def while_(cond, do, max_iterations: int | None = None) -> dict:
    step: dict = {"while": _cond(cond), "do": _steps(do)}
    if max_iterations is not None:
        step["max-iterations"] = max_iterations
    return step


class Workflow:
    """A workflow built step by step; every method returns the workflow, so calls chain."""

    def __init__(self, steps: Iterable | None = None, *, input: str | None = None,
                 transfer: str | None = None, quantize: int | None = None,
                 placement: str | None = None):
        self.steps: list = _steps(steps) if steps is not None else []
        self.input, self.transfer, self.quantize, self.placement = input, transfer, quantize, placement

    def run(self, service: str, params: dict | None = None, plugin: str | None = None, **kwargs) -> "Workflow":
        self.steps.append(run(service, params, plugin, **kwargs))
        return self

    def while_(self, cond, do, max_iterations: int | None = None) -> "Workflow":
        self.steps.append(while_(cond, do, max_iterations))
        return self

    def if_(self, cond, then, else_=None) -> "Workflow":
        self.steps.append(if_(cond, then, else_))
        return self

    def then(self, *steps) -> "Workflow":
        """Appends steps made elsewhere (dicts, other workflows)."""
        self.steps.extend(_steps(list(steps)))
        return self

    def to_dict(self) -> dict:
        d: dict = {}
        if self.input is not None:
            d["input"] = self.input
        if self.transfer is not None:
            d["transfer"] = self.transfer
        if self.quantize is not None:
            d["quantize"] = self.quantize
        if self.placement is not None:
            d["placement"] = self.placement
        d["steps"] = [json.loads(json.dumps(s)) for s in self.steps]
        return d

    def to_json(self, **kwargs) -> str:
        return json.dumps(self.to_dict(), **kwargs)

    @classmethod
    def from_dict(cls, d) -> "Workflow":
        if isinstance(d, list):
            return cls(d)
        return cls(d["steps"], input=d.get("input"), transfer=d.get("transfer"),
                   quantize=d.get("quantize"), placement=d.get("placement"))

    @classmethod
    def load(cls, path) -> "Workflow":
        """Reads a workflow JSON file (``examples/workflows/repair.json``)."""
        return cls.from_dict(json.loads(Path(path).read_text()))

    def __repr__(self):
        return f"Workflow({self.to_json()})"


def workflow_dict(workflow) -> dict | list:
    """A workflow given as a :class:`Workflow`, a dict, a list of steps, a JSON string or a
    path to a JSON file, as the engine's JSON."""
    if isinstance(workflow, Workflow):
        return workflow.to_dict()
    if isinstance(workflow, (dict, list)):
        return workflow
    if isinstance(workflow, Path) or (isinstance(workflow, str) and not workflow.lstrip().startswith(("{", "["))):
        return json.loads(Path(workflow).read_text())
    if isinstance(workflow, str):
        return json.loads(workflow)
    raise TypeError(f"a workflow is a Workflow, dict, list, JSON text or path, not {type(workflow).__name__}")
