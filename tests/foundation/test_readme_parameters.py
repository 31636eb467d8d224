"""Every parameter is declared once and everything else is derived from that declaration.

A method's parameters are the `param` fields of its config dataclass; the node's descriptors,
the validation on set, the method's construction and the package READMEs' parameter tables
(generated between ``<!-- parameters: KEY -->`` markers by ``parameter_tables``) all come from
them. These tests hold each of those to the field."""

from __future__ import annotations

from dataclasses import fields

import pytest

pytest.importorskip("rclpy")
pytestmark = pytest.mark.ros

from pathlib import Path  # noqa: E402

from tracker_msgs_py.params import (  # noqa: E402
    NESTED_KEY,
    PARAM_KEY,
    config_from_params,
    markdown_value,
)

SRC = Path(__file__).resolve().parents[2] / "src"


def configured_methods() -> list:
    """Every registered method whose parameters come from a config dataclass."""
    return [m for m in _methods() if m.config is not None]


def _methods() -> list:
    from tracker_detect.detectors import DETECTORS
    from tracker_filter.trackers import TRACKERS

    for registry, role in ((DETECTORS, "detector"), (TRACKERS, "tracker")):
        ROLE.update({m.name: role for m in registry})
    return [*DETECTORS, *TRACKERS]


ROLE: dict[str, str] = {}  # method name -> "detector" or "tracker"


def test_the_readme_tables_are_generated_from_the_declarations():
    from tracker_ptz_sim.bringup.parameter_tables import readmes, regenerate

    stale = [f"{p.name}: {key}" for p in readmes(SRC) for key in regenerate(p.read_text())[1]]
    assert stale == [], "stale tables; run `parameter_tables` (tracker_ptz_sim): " + str(stale)


def test_every_table_is_in_a_readme_once():
    from tracker_ptz_sim.bringup.parameter_tables import TABLES, documented_keys

    keys = documented_keys(SRC)
    assert sorted(keys) == sorted(TABLES), "each table exactly once in the package READMEs"


def test_some_methods_declare_their_parameters_as_config_fields():
    assert {m.name for m in configured_methods()} >= {"byte"}


@pytest.mark.parametrize("method", configured_methods(), ids=lambda m: m.name)
def test_each_field_is_the_parameter_everywhere(method):
    """Field -> ParamSpec -> ROS descriptor, validation, construction and README row."""
    from rcl_interfaces.msg import ParameterDescriptor

    from tracker_ptz_sim.bringup.parameter_tables import table

    declared = list(_declared(method.config))
    specs = {spec.name: spec for spec in method.parameters}
    assert [f.name for f, _, _ in declared] == list(specs), "every field is a parameter, in order"
    rows = {
        line.split("|")[1].strip().strip("`"): line
        for key in TABLES_OF.get(method.name, [f"{ROLE[method.name]}/{method.name}"])
        for line in table(key).splitlines()[2:]
    }
    defaults = method.defaults()
    config = config_from_params(method.config, defaults)
    for f, default, path in declared:
        spec, meta = specs[f.name], f.metadata[PARAM_KEY]
        held = _follow(config, path)
        assert spec.default == _ros(default) and getattr(held, f.name) == default
        assert (spec.min, spec.max, spec.choices) == (meta.min, meta.max, meta.choices)
        descriptor: ParameterDescriptor = spec.descriptor()
        assert descriptor.read_only == meta.read_only and meta.description in descriptor.description
        if meta.min is not None and meta.max is not None and not isinstance(default, bool):
            ros_range = descriptor.integer_range or descriptor.floating_point_range
            assert (ros_range[0].from_value, ros_range[0].to_value) == (meta.min, meta.max)
        for outside in _outside(spec):
            assert spec.check(outside), f"{f.name}={outside!r} accepted by the node"
            with pytest.raises(ValueError, match=f.name):
                config_from_params(method.config, defaults | {f.name: outside})
        assert f.name in rows and f"| {markdown_value(spec.default)} |" in rows[f.name]


#: the README tables a method's parameters are in, when not its own "role/method" table alone (a
#: later table's row wins): the first detector's and tracker's are the node's; person_motion's has only
#: what it does not share with its parts
TABLES_OF = {
    "ssim": ["detector"],
    "gated_hungarian": ["tracker"],
    "person_motion": ["detector/ssim_background", "detector/person", "detector/person_motion"],
}


def _declared(cls, overrides=None, path=()):
    """(field, its default here, the path of nested config fields to it), in declaration order."""
    for f in fields(cls):
        if PARAM_KEY in f.metadata:
            yield f, (overrides or {}).get(f.name, f.default), path
        elif NESTED_KEY in f.metadata:
            inner, inner_defaults = f.metadata[NESTED_KEY]
            yield from _declared(inner, inner_defaults, (*path, f.name))


def _follow(config, path):
    for name in path:
        config = getattr(config, name)
    return config


def _ros(value):
    return list(value) if isinstance(value, tuple) else value


def _outside(spec) -> list:
    """Values just outside what `spec` allows (none for an unbounded parameter)."""
    if isinstance(spec.default, bool):
        return []
    if spec.choices:
        return ["not-a-choice"]
    step = 1 if isinstance(spec.default, int) else 1e-3 * max(1.0, abs(spec.max or spec.min or 1))
    values = []
    if spec.min is not None:
        values.append(type(spec.default)(spec.min - step))
    if spec.max is not None:
        values.append(type(spec.default)(spec.max + step))
    return values
