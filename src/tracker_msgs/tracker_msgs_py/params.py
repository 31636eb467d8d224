"""Parameter conventions shared by the suite's nodes.

A method declares each of its parameters once, as a field of its frozen config dataclass made
with `param(default, description, min=, max=, unit=, ...)`. Everything else is derived from those
fields: `specs_of(Config)` gives the `ParamSpec`s (plain data) the node declares and the package
README's tables are generated from (`markdown_table`); `check_config` checks every field against
its declared range and choices before the config's own `problems()` (the checks between fields);
`config_from_params` builds the typed config from the node's values.
`declare_parameters` declares them with descriptors (description, type, numeric range, allowed
choices), rejects bad start-up values with a clear message, and rejects bad runtime changes
(`ros2 param set`) with a reason while leaving the node's state untouched. Accepted changes are
handed to the node's `on_change` callback.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable, Mapping, Sequence
from dataclasses import MISSING, Field, dataclass, field, fields, is_dataclass, replace
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
    """Raises ValueError listing why `config` is unusable: its fields outside their declared
    range or choices (`param`), then its own `problems()`."""
    problems = field_problems(config) + config.problems()
    if problems:
        raise ValueError(f"invalid {type(config).__name__}: " + "; ".join(problems))


def field_problems(config: object) -> list[str]:
    """Why the `param` fields of `config` are outside what they declare."""
    found = []
    for spec in _own_specs(type(config)):
        reason = spec.check(getattr(config, spec.name))
        if reason:
            found.append(reason)
    return found


def _own_specs(cls: type) -> tuple[ParamSpec, ...]:
    """The `ParamSpec`s of `cls`'s own `param` fields (not its `params_of` ones), made once."""
    specs = _OWN_SPECS.get(cls)
    if specs is None:
        own = (f for f in fields(cls) if PARAM_KEY in f.metadata)
        specs = _OWN_SPECS[cls] = tuple(_spec_of(f) for f in own)
    return specs


_OWN_SPECS: dict[type, tuple[ParamSpec, ...]] = {}


def config_from_params(cls: type[C], values: Mapping[str, Any], **overrides: Any) -> C:
    """The config dataclass `cls` from the parameter values named like its fields (others are
    ignored; a list for a field whose default is a tuple becomes a tuple), its `params_of` fields
    made the same way from the same values, and `overrides`; raises ValueError listing its
    problems."""
    given: dict[str, Any] = {}
    for declared_field in fields(cls):  # type: ignore[arg-type]
        name, metadata = declared_field.name, declared_field.metadata
        if NESTED_KEY in metadata:
            inner_cls, inner_defaults = metadata[NESTED_KEY]
            given[name] = config_from_params(inner_cls, {**inner_defaults, **values})
        elif name in values:
            value = values[name]
            given[name] = tuple(value) if isinstance(declared_field.default, tuple) else value
    config = cls(**given | overrides)
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
    unit: str = ""  # of a number: px, s, px/s, ... ("" for ratios, counts and words)

    @property
    def documentation(self) -> str:
        """The description with its unit, as the descriptor and the README show it."""
        return f"{self.description} [{self.unit}]" if self.unit else self.description

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
            description=self.documentation,
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


PARAM_KEY = "tracker_param"  # a dataclass field's metadata key for its `ParamSpec` parts
NESTED_KEY = "tracker_params_of"  # ... for a nested config whose parameters are the field's


@dataclass(frozen=True)
class _Declared:
    """What `param` records on a field: a `ParamSpec` but for its name and default."""

    description: str
    min: float | None
    max: float | None
    choices: tuple[str, ...] | None
    read_only: bool
    validator: Validator | None
    interval: bool
    unit: str


def param(
    default: Any,
    description: str,
    *,
    min: float | None = None,  # noqa: A002 -- named as ParamSpec's and ROS's range ends
    max: float | None = None,  # noqa: A002
    unit: str = "",
    choices: Sequence[str] | None = None,
    read_only: bool = False,
    validator: Validator | None = None,
    interval: bool = False,
) -> Any:
    """A config dataclass field that is also a node parameter of the same name: its default,
    one-line description, inclusive numeric range, unit, allowed choices, whether it may only be
    set at start-up, an extra check, and whether it is a [min, max] pair. A list default is held
    as a tuple (the config is frozen); the node still sees a list."""
    declared = _Declared(
        description,
        min,
        max,
        tuple(choices) if choices is not None else None,
        read_only,
        validator,
        interval,
        unit,
    )
    value = tuple(default) if isinstance(default, list) else default
    return field(default=value, metadata={PARAM_KEY: declared})


def specs_of(cls: type) -> tuple[ParamSpec, ...]:
    """The `ParamSpec`s of the `param` fields of the config dataclass `cls`, in field order, a
    `params_of` field's in its place."""
    specs = _SPECS.get(cls)
    if specs is None:
        if not is_dataclass(cls):
            raise TypeError(f"{cls!r} is not a config dataclass")
        specs = _SPECS[cls] = tuple(spec for f in fields(cls) for spec in _specs_of_field(f))
        names = [spec.name for spec in specs]
        twice = sorted({name for name in names if names.count(name) > 1})
        if twice:
            raise TypeError(f"{cls.__name__} declares {', '.join(twice)} more than once")
    return specs


def _specs_of_field(declared_field: Field[Any]) -> tuple[ParamSpec, ...]:
    if PARAM_KEY in declared_field.metadata:
        return (_spec_of(declared_field),)
    if NESTED_KEY in declared_field.metadata:
        inner_cls, inner_defaults = declared_field.metadata[NESTED_KEY]
        return tuple(
            replace(spec, default=_ros_value(inner_defaults[spec.name]))
            if spec.name in inner_defaults
            else spec
            for spec in specs_of(inner_cls)
        )
    return ()


def params_of(cls: type[C], **defaults: Any) -> Any:
    """A config field holding the config `cls`, whose parameters are this config's too (the same
    names), with `defaults` in place of its own: a method made of others (motion and a person
    model) declares theirs once, where they are."""
    return field(default=cls(**defaults), metadata={NESTED_KEY: (cls, defaults)})


def _ros_value(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


_SPECS: dict[type, tuple[ParamSpec, ...]] = {}


def _spec_of(declared_field: Field[Any]) -> ParamSpec:
    declared: _Declared = declared_field.metadata[PARAM_KEY]
    default = declared_field.default
    if default is MISSING:
        raise TypeError(f"parameter field {declared_field.name} needs a default")
    return ParamSpec(
        declared_field.name,
        _ros_value(default),
        declared.description,
        declared.min,
        declared.max,
        declared.choices,
        declared.read_only,
        declared.validator,
        declared.interval,
        declared.unit,
    )


def markdown_value(value: Any) -> str:
    """A parameter value as the READMEs' tables write it."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, str):
        return f"`{value}`" if value else "''"
    if isinstance(value, list | tuple):
        if len(value) > LONG_LIST:
            return f"{len(value)} numbers"
        return "[" + ", ".join(markdown_value(v).strip("`") for v in value) + "]"
    return str(value)


LONG_LIST = 8  # matrices: a table cell says how many numbers rather than listing them


def _range_end(end: float | None, default: ParamValue) -> str:
    if end is None:
        return ""
    integer = isinstance(default, int) and not isinstance(default, bool)
    return str(int(end)) if integer else markdown_value(float(end))


def markdown_table(
    specs: Sequence[ParamSpec], presets: Mapping[str, Mapping[str, Any]] | None = None
) -> str:
    """The README table of `specs`: parameter, default, each of `presets`' value where it is not
    the default, unit, range or choices, meaning."""
    presets = presets or {}
    columns = "".join(f" `{name}` |" for name in presets)
    lines = [
        f"| parameter | default |{columns} unit | range / choices | meaning |",
        "|---|---|" + "---|" * len(presets) + "---|---|---|",
    ]
    for spec in specs:
        default = markdown_value(spec.default)
        preset_cells = "".join(f" {_preset_cell(values, spec)} |" for values in presets.values())
        meaning = spec.description.replace("|", "\\|")
        lines.append(
            f"| `{spec.name}` | {default} |{preset_cells} {spec.unit} | {_allowed(spec)} | "
            f"{meaning} |"
        )
    return "\n".join(lines)


def _preset_cell(values: Mapping[str, Any], spec: ParamSpec) -> str:
    value = values.get(spec.name, spec.default)
    same = list(value) == spec.default if isinstance(value, tuple) else value == spec.default
    return "" if same else markdown_value(value)


def _allowed(spec: ParamSpec) -> str:
    """A table's range / choices cell."""
    if spec.choices:
        allowed = ", ".join(f"`{c}`" for c in spec.choices)
    elif spec.min is not None or spec.max is not None:
        allowed = f"[{_range_end(spec.min, spec.default)}, {_range_end(spec.max, spec.default)}]"
    else:
        allowed = ""
    return f"{allowed} (start-up only)".strip() if spec.read_only else allowed


class ParameterError(ValueError):
    """A start-up parameter value a node cannot run with."""


def _parameter_type(default: ParamValue) -> int:
    from rcl_interfaces.msg import ParameterType

    kinds: list[tuple[bool, str]] = [
        (isinstance(default, bool), "BOOL"),
        (isinstance(default, int), "INTEGER"),
        (isinstance(default, float), "DOUBLE"),
        (isinstance(default, str), "STRING"),
        (
            isinstance(default, list) and bool(default) and isinstance(default[0], float),
            "DOUBLE_ARRAY",
        ),
        (
            isinstance(default, list) and bool(default) and isinstance(default[0], int),
            "INTEGER_ARRAY",
        ),
        (isinstance(default, list), "STRING_ARRAY"),
    ]
    for matches, kind in kinds:
        if matches:
            return int(getattr(ParameterType, f"PARAMETER_{kind}"))
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
    values = _declare_start_up_values(node, specs, check_all)

    def validate(params: list[Parameter]) -> SetParametersResult:
        successful, reason = _change_verdict(params, values, by_name, check_all)
        return SetParametersResult(successful=successful, reason=reason)

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


def _declare_start_up_values(
    node: Node,
    specs: Sequence[ParamSpec],
    check_all: Callable[[dict[str, Any]], str | None] | None,
) -> dict[str, Any]:
    """Declare each of `specs` on `node` and return the start-up values by name, each checked
    by its spec and then all together by `check_all`. Raises ParameterError for a bad one."""
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
    return values


def _change_verdict(
    params: list[Parameter],
    values: Mapping[str, Any],
    by_name: Mapping[str, ParamSpec],
    check_all: Callable[[dict[str, Any]], str | None] | None,
) -> tuple[bool, str]:
    """Whether a runtime change of `params` to the current `values` may go ahead, and why not:
    each parameter of `by_name` (others are not ours) is checked by its spec, then the values as
    they would be after the change by `check_all`."""
    proposed = dict(values)
    for param in params:
        spec = by_name.get(param.name)
        if spec is None:
            continue
        value = _as_python(param.value, spec.default)
        reason = spec.check(value)
        if reason:
            return False, reason
        proposed[param.name] = value
    verdict = check_all(proposed) if check_all else None
    return verdict is None, verdict or ""


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
