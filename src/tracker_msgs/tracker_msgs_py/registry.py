"""Registries of interchangeable methods: one per role (tracker, filter, detector). No rclpy.

A method is a name, a one-line description, its own parameters (`ParamSpec`s, whose defaults are
the method's defaults), optional named presets, and a `build` function from parameter values to
the object. A method with a config dataclass (`Method.of`) derives all of that from the config's
`param` fields: its parameters are `specs_of(config)`, and `build` makes the typed config from
the values and hands it to the method's constructor.

A node's `method` parameter picks one; adding a method is a new module plus one `register` call,
never a change to a node. Another installed package can add methods without
touching this suite, as pluginlib does for C++: it declares each `Method` object as a Python entry
point in the role's group (e.g. ``tracker_suite.trackers``), and the node loads the group.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from typing import Any, Generic, TypeVar

from tracker_msgs_py.params import ParamSpec, config_from_params, specs_of

T = TypeVar("T")
T_co = TypeVar("T_co", covariant=True)  # a Method of a subtype serves a role of its supertype
C = TypeVar("C")


@dataclass(frozen=True)
class Method(Generic[T_co]):
    """One registered method. `build(values)` gets every parameter of the method by name (plus
    whatever the role adds, e.g. a tracker's first id) and raises ValueError for a bad combination.
    """

    name: str
    description: str
    build: Callable[..., T_co]
    parameters: tuple[ParamSpec, ...] = ()
    presets: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    #: compiles the method's kernels (numba) ahead of its first frame; a node calls it before it
    #: subscribes, so a lockstep replay's first frames do not wait for a compiler
    warm_up: Callable[[], None] | None = None
    #: the config dataclass the parameters come from (None: `parameters` are written out)
    config: type | None = None

    @classmethod
    def of(
        cls,
        name: str,
        description: str,
        config: type[C],
        make: Callable[..., T_co],
        presets: Mapping[str, Mapping[str, Any]] | None = None,
        warm_up: Callable[[], None] | None = None,
    ) -> Method[T_co]:
        """The method whose parameters are the `param` fields of `config`, built by
        `make(config_instance, **role_arguments)` (a tracker's first id, ...)."""

        def build(values: Mapping[str, Any], *role_arguments: Any, **named: Any) -> T_co:
            return make(config_from_params(config, values), *role_arguments, **named)

        return cls(name, description, build, specs_of(config), presets or {}, warm_up, config)

    def configure(self, values: Mapping[str, Any]) -> Any:
        """The method's config from parameter values (raises ValueError); for a detector's or
        tracker's `reconfigure`. Only for a method made with `Method.of`."""
        if self.config is None:
            raise TypeError(f"{self.name} has no config dataclass")
        return config_from_params(self.config, values)

    def defaults(self, preset: str = "") -> dict[str, Any]:
        """Parameter values of `preset` ("" = the parameters' own defaults)."""
        values = {spec.name: spec.default for spec in self.parameters}
        if preset:
            if preset not in self.presets:
                known = ", ".join(self.presets) or "none"
                raise ValueError(f"{self.name} has no preset '{preset}' (presets: {known})")
            values.update(self.presets[preset])
        return values

    def problems(self, values: Mapping[str, Any]) -> str | None:
        """Why `values` cannot build this method, or None."""
        for spec in self.parameters:
            if spec.name not in values:
                return f"{self.name}: missing parameter {spec.name}"
            reason = spec.check(values[spec.name])
            if reason:
                return reason
        return None


class Registry(Generic[T]):
    """The methods of one role, by name, in registration order."""

    def __init__(self, role: str) -> None:
        self.role = role
        self._methods: dict[str, Method[T]] = {}

    def register(self, method: Method[T], replace: bool = False) -> Method[T]:
        if method.name in self._methods and not replace:
            raise ValueError(f"a {self.role} named '{method.name}' is already registered")
        self._methods[method.name] = method
        return method

    def load_entry_points(self, group: str) -> list[str]:
        """Register the `Method`s installed packages declare under the entry-point `group`;
        returns one line per entry point that could not be used (the others still load)."""
        problems = []
        for point in entry_points(group=group):
            try:
                method = point.load()
            except Exception as error:  # a broken plug-in must not take the node down
                problems.append(f"{group} plug-in {point.name}: cannot load ({error})")
                continue
            if not isinstance(method, Method):
                problems.append(f"{group} plug-in {point.name}: {point.value} is not a Method")
            elif method.name in self._methods and self._methods[method.name] is not method:
                problems.append(f"{group} plug-in {point.name}: '{method.name}' is taken")
            else:
                self._methods[method.name] = method
        return problems

    def unregister(self, name: str) -> None:
        self._methods.pop(name, None)

    def get(self, name: str) -> Method[T]:
        try:
            return self._methods[name]
        except KeyError:
            raise ValueError(
                f"unknown {self.role} '{name}' (registered: {', '.join(self._methods)})"
            ) from None

    def names(self) -> tuple[str, ...]:
        return tuple(self._methods)

    def method_spec(self) -> ParamSpec:
        """The node parameter that picks one of the methods registered now (start-up only: a
        node builds its method once), each named with its description."""
        described = "; ".join(f"{m.name}: {m.description}" for m in self)
        return ParamSpec(
            "method",
            self.names()[0],
            f"the {self.role}: {described}",
            choices=self.names(),
            read_only=True,
        )

    def __contains__(self, name: object) -> bool:
        return name in self._methods

    def __iter__(self) -> Iterator[Method[T]]:
        return iter(self._methods.values())
