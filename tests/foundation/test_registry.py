"""Registries: methods by name, their defaults and presets, and plug-ins other packages declare
as entry points (a broken one is reported, never fatal)."""

from __future__ import annotations

from importlib.metadata import EntryPoint

import pytest

from tracker_msgs_py import registry as registry_module
from tracker_msgs_py.params import ParamSpec
from tracker_msgs_py.registry import Method, Registry

GOOD = Method("echo", "returns its values", build=dict, parameters=(ParamSpec("k", 2, "a", 1, 5),))


def test_methods_by_name_with_defaults_presets_and_checks():
    reg: Registry[dict] = Registry("thing")
    reg.register(
        Method("a", "one", build=dict, parameters=GOOD.parameters, presets={"p": {"k": 4}})
    )
    assert reg.names() == ("a",) and "a" in reg
    method = reg.get("a")
    assert method.defaults() == {"k": 2} and method.defaults("p") == {"k": 4}
    assert method.problems({"k": 9}) == "k must be in [1, 5], got 9"
    with pytest.raises(ValueError, match="no preset 'q'"):
        method.defaults("q")
    with pytest.raises(ValueError, match=r"unknown thing 'b' \(registered: a\)"):
        reg.get("b")
    with pytest.raises(ValueError, match="already registered"):
        reg.register(Method("a", "again", build=dict))


def test_entry_point_plugins_load_and_broken_ones_are_reported(monkeypatch):
    points = [
        EntryPoint("echo", "test_registry:GOOD", "g"),
        EntryPoint("missing", "no_such_module_xyz:THING", "g"),
        EntryPoint("wrong", "math:pi", "g"),
    ]
    monkeypatch.setattr(registry_module, "entry_points", lambda group: points)
    monkeypatch.syspath_prepend(str(__import__("pathlib").Path(__file__).parent))
    reg: Registry[dict] = Registry("thing")
    problems = reg.load_entry_points("g")
    assert reg.names() == ("echo",)
    assert len(problems) == 2
    assert "missing: cannot load" in problems[0] and "math:pi is not a Method" in problems[1]
