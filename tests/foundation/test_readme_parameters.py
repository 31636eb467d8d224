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

from tracker_msgs_py.params import PARAM_KEY, config_from_params, markdown_value  # noqa: E402

SRC = Path(__file__).resolve().parents[2] / "src"


def configured_methods() -> list:
    """Every registered method whose parameters come from a config dataclass."""
    from tracker_detect.detectors import DETECTORS
    from tracker_filter.trackers import TRACKERS

    return [m for registry in (DETECTORS, TRACKERS) for m in registry if m.config is not None]


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

    from tracker_ptz_sim.bringup.parameter_tables import TABLES, table

    declared = [f for f in fields(method.config) if PARAM_KEY in f.metadata]
    specs = {spec.name: spec for spec in method.parameters}
    assert [f.name for f in declared] == list(specs), "every field is a parameter, in order"
    rows = {
        line.split("|")[1].strip().strip("`"): line
        for key in TABLES
        for line in table(key).splitlines()[2:]
        if key.endswith(method.name) or key in ("detector", "tracker")
    }
    defaults = method.defaults()
    config = config_from_params(method.config, defaults)
    for f in declared:
        spec, meta = specs[f.name], f.metadata[PARAM_KEY]
        default = list(f.default) if isinstance(f.default, tuple) else f.default
        assert spec.default == default and getattr(config, f.name) == f.default
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
        assert f.name in rows and f"| {markdown_value(default)} |" in rows[f.name]


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
