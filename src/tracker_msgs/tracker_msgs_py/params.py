"""Parameter conventions shared by the suite's nodes.

A node lists its parameters once as `ParamSpec`s (plain data: the functional core describes its
own parameters with them, and the README's parameter tables are checked against them).
`declare_parameters` declares them with descriptors (description, type, numeric range, allowed
choices), rejects bad start-up values with a clear message, and rejects bad runtime changes
(`ros2 param set`) with a reason while leaving the node's state untouched. Accepted changes are
handed to the node's `on_change` callback.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

if TYPE_CHECKING:  # rclpy is imported where a node declares parameters, not by the core
    from rcl_interfaces.msg import ParameterDescriptor
    from rclpy.node import Node
    from rclpy.parameter import Parameter

ParamValue = bool | int | float | str | list
C = TypeVar("C")


class Config(Protocol):
    """The suite's config convention: a frozen dataclass whose fields are named like the
    parameters that set them, and whose `problems()` lists why it is unusable (empty: fine)."""

    def problems(self) -> list[str]: ...


def check_config(config: Config) -> None:
    """Raises ValueError listing `config.problems()`, if any."""
    problems = config.problems()
    if problems:
        raise ValueError(f"invalid {type(config).__name__}: " + "; ".join(problems))


def config_from_params(cls: type[C], values: Mapping[str, Any], **overrides: Any) -> C:
    """The config dataclass `cls` from the parameter values named like its fields (others are
    ignored) and `overrides`; raises ValueError listing its problems."""
    names = {f.name for f in fields(cls)}  # type: ignore[arg-type]
    config = cls(**{k: v for k, v in values.items() if k in names} | overrides)
    check_config(config)  # type: ignore[arg-type]
    return config


Validator = Callable[[Any], str | None]


@dataclass(frozen=True)
class ParamSpec:
    """One node parameter: its default, documentation and constraints."""

    name: str
    default: ParamValue
    description: str
    min: float | None = None  # inclusive numeric range (both ends needed for a ROS range)
    max: float | None = None
    choices: tuple[str, ...] | None = None  # allowed values of a string parameter
    read_only: bool = False  # may only be set at start-up
    validator: Validator | None = None  # returns a reason when the value is unacceptable
    interval: bool = False  # a [min, max] pair: two numbers, min < max

    def check(self, value: Any) -> str | None:
        """Why `value` is not acceptable for this parameter, or None when it is."""
        if isinstance(value, float) and not math.isfinite(value):
            return f"{self.name} must be a finite number, got {value}"
        if isinstance(value, list | tuple) and any(
            isinstance(v, float) and not math.isfinite(v) for v in value
        ):
            return f"{self.name} must hold finite numbers, got {list(value)}"
        if self.interval and not (len(value) == 2 and value[0] < value[1]):
            return f"{self.name} must be [min, max] with min < max, got {list(value)}"
        is_number = isinstance(value, int | float) and not isinstance(value, bool)
        both = self.min is not None and self.max is not None
        if is_number and both and not self.min <= value <= self.max:
            return f"{self.name} must be in [{self.min}, {self.max}], got {value}"
        if is_number and self.min is not None and value < self.min:
            return f"{self.name} must be >= {self.min}, got {value}"
        if is_number and self.max is not None and value > self.max:
            return f"{self.name} must be <= {self.max}, got {value}"
        if self.choices is not None and value not in self.choices:
            return f"{self.name} must be one of {', '.join(self.choices)}; got '{value}'"
        return self.validator(value) if self.validator else None

    def descriptor(self) -> ParameterDescriptor:
        from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor

        descriptor = ParameterDescriptor(
            name=self.name,
            type=_parameter_type(self.default),
            description=self.description,
            read_only=self.read_only,
        )
        if self.choices:
            descriptor.additional_constraints = "one of: " + ", ".join(self.choices)
        if self.min is not None and self.max is not None:
            if isinstance(self.default, bool):
                pass
            elif isinstance(self.default, int):
                descriptor.integer_range = [
                    IntegerRange(from_value=int(self.min), to_value=int(self.max), step=0)
                ]
            elif isinstance(self.default, float):
                descriptor.floating_point_range = [
                    FloatingPointRange(
                        from_value=float(self.min), to_value=float(self.max), step=0.0
                    )
                ]
        return descriptor


class ParameterError(ValueError):
    """A start-up parameter value a node cannot run with."""


def _parameter_type(default: ParamValue) -> int:
    from rcl_interfaces.msg import ParameterType

    if isinstance(default, bool):
        return ParameterType.PARAMETER_BOOL
    if isinstance(default, int):
        return ParameterType.PARAMETER_INTEGER
    if isinstance(default, float):
        return ParameterType.PARAMETER_DOUBLE
    if isinstance(default, str):
        return ParameterType.PARAMETER_STRING
    if isinstance(default, list) and default and isinstance(default[0], float):
        return ParameterType.PARAMETER_DOUBLE_ARRAY
    if isinstance(default, list) and default and isinstance(default[0], int):
        return ParameterType.PARAMETER_INTEGER_ARRAY
    if isinstance(default, list):
        return ParameterType.PARAMETER_STRING_ARRAY
    raise TypeError(f"unsupported parameter default {default!r}")


def declare_parameters(
    node: Node,
    specs: Sequence[ParamSpec],
    on_change: Callable[[dict[str, Any]], None] | None = None,
    check_all: Callable[[dict[str, Any]], str | None] | None = None,
) -> dict[str, Any]:
    """Declare `specs` on `node` and return their start-up values by name.

    `on_change(changed)` is called after a runtime change was accepted, with the new values of the
    changed parameters. `check_all(values)` may veto combinations (e.g. min < max) and sees the
    values as they would be after the change. Raises ParameterError for a bad start-up value.
    """
    from rcl_interfaces.msg import SetParametersResult

    by_name = {spec.name: spec for spec in specs}
    _widen_overrides(node, by_name)
    _widen_at_run_time(node, by_name)
    values: dict[str, Any] = {}
    for spec in specs:
        try:
            param = node.declare_parameter(spec.name, spec.default, spec.descriptor())
        except Exception as error:  # rclpy raises several types for range/type violations
            raise ParameterError(f"parameter {spec.name}: {error}") from error
        value = _as_python(param.value, spec.default)
        reason = spec.check(value)
        if reason:
            raise ParameterError(reason)
        values[spec.name] = value
    if check_all:
        reason = check_all(dict(values))
        if reason:
            raise ParameterError(reason)

    def validate(params: list[Parameter]) -> SetParametersResult:
        proposed = dict(values)
        for param in params:
            spec = by_name.get(param.name)
            if spec is None:
                continue
            value = _as_python(param.value, spec.default)
            reason = spec.check(value)
            if reason:
                return SetParametersResult(successful=False, reason=reason)
            proposed[param.name] = value
        reason = check_all(proposed) if check_all else None
        return SetParametersResult(successful=reason is None, reason=reason or "")

    def apply(params: list[Parameter]) -> None:
        changed = {
            p.name: _as_python(p.value, by_name[p.name].default)
            for p in params
            if p.name in by_name
        }
        values.update(changed)
        if changed and on_change:
            on_change(changed)

    node.add_on_set_parameters_callback(validate)
    node.add_post_set_parameters_callback(apply)
    return values


def _widened(param: Parameter, by_name: Mapping[str, ParamSpec]) -> Parameter:
    """An integer (or integer array) given for a decimal parameter, as that decimal: users type
    `max_speed:=2`, and rclpy would refuse it as the wrong type."""
    from rclpy.parameter import Parameter

    spec = by_name.get(param.name)
    if spec is None:
        return param
    default = spec.default
    if isinstance(default, float) and param.type_ == Parameter.Type.INTEGER:
        return Parameter(param.name, Parameter.Type.DOUBLE, float(param.value))
    decimals = isinstance(default, list) and bool(default) and isinstance(default[0], float)
    if decimals and param.type_ == Parameter.Type.INTEGER_ARRAY:
        return Parameter(param.name, Parameter.Type.DOUBLE_ARRAY, [float(v) for v in param.value])
    return param


_RUN_TIME_SPECS: weakref.WeakKeyDictionary[Node, dict[str, ParamSpec]] = weakref.WeakKeyDictionary()


def _widen_at_run_time(node: Node, by_name: Mapping[str, ParamSpec]) -> None:
    """`_widened` for values set at run time, by one pre-set callback per node over every spec
    declared on it: rclpy concatenates what each pre-set callback returns, so a second callback
    would hand the original integer on as well."""
    known = _RUN_TIME_SPECS.get(node)
    if known is None:
        known = _RUN_TIME_SPECS[node] = {}
        node.add_pre_set_parameters_callback(lambda params: [_widened(p, known) for p in params])
    known.update(by_name)


def _widen_overrides(node: Node, by_name: Mapping[str, ParamSpec]) -> None:
    """`_widened` for the start-up values (command line, params files), which rclpy checks
    against the declared type before any callback runs."""
    overrides = node._parameter_overrides  # noqa: SLF001 -- rclpy has no public hook for this
    for name in by_name.keys() & overrides.keys():
        overrides[name] = _widened(overrides[name], by_name)


def _as_python(value: Any, default: ParamValue) -> Any:
    """rclpy hands integers for double parameters given as '1'; keep the declared type."""
    if isinstance(default, float) and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if isinstance(default, list) and not isinstance(value, list):
        return list(value)
    return value


WILDCARD_SECTIONS = ("/**", "**")  # a params file's section for every node


def parameters_for_every_node(ros_args: Sequence[str]) -> set[str]:
    """The parameter names that a command line's ROS arguments (its `--ros-args` sections) give
    every node rather than one by name: the `/**` section of each `--params-file` and each
    `-p name:=value` without a node name. A node that does not use one of them (reliable_images
    for a node without image inputs) is not wrong to ignore it; a parameter given to the node by
    name and not declared is a mistake. Unreadable files count as giving nothing (rcl has
    already refused them)."""
    import yaml

    names: set[str] = set()
    tokens = ros_sections(ros_args)
    for flag, value in zip(tokens, tokens[1:], strict=False):
        if flag == "--params-file":
            try:
                with open(value, encoding="utf-8") as file:
                    sections = yaml.safe_load(file) or {}
            except (OSError, yaml.YAMLError):
                continue
            for section in WILDCARD_SECTIONS:
                given = (sections.get(section) or {}).get("ros__parameters") or {}
                names.update(flatten_parameters(given))
        elif flag in ("-p", "--param"):
            name, sep, _ = value.partition(":=")
            if sep and ":" not in name:
                names.add(name)
    return names


def ros_sections(argv: Sequence[str]) -> list[str]:
    """The tokens of `argv` inside its `--ros-args` sections (each ends at `--` or at the end),
    where rcl reads its arguments; the rest belongs to the program."""
    tokens: list[str] = []
    inside = False
    for token in argv:
        if token == "--ros-args":
            inside = True
        elif token == "--":
            inside = False
        elif inside:
            tokens.append(token)
    return tokens


def flatten_parameters(values: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """A params file's nested parameter maps as rcl reads them: {a: {b: 1}} -> {"a.b": 1}."""
    flat: dict[str, Any] = {}
    for name, value in values.items():
        if isinstance(value, Mapping):
            flat.update(flatten_parameters(value, f"{prefix}{name}."))
        else:
            flat[f"{prefix}{name}"] = value
    return flat
