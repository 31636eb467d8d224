"""An ONVIF PTZ camera of the tests' own: device, media and PTZ services on localhost, built on
the WSDLs that onvif-zeep-async ships. zeep reads each request and writes each reply from those
service definitions (the same ones the client serializes with), so what passes is what a real
camera's SOAP carries; a WS-Security UsernameToken digest is checked when a password is set.

The head moves in ONVIF's generic spaces (pan x, tilt y in [-1, 1], velocities in [-1, 1] of
its top speed) with a speed limit: ContinuousMove (with or without a timeout), AbsoluteMove,
RelativeMove (generic translation; in the FOV space only with `fov_moves`), Stop, presets.
Quirks of real cameras on request: no FOV-relative moves (`fov_moves=False`), a MoveStatus that
never returns to IDLE (`never_idle=True`), a GetStatus without a position.
"""

from __future__ import annotations

import asyncio
import base64
import datetime as dt
import hashlib
import os
import re
import socket
import threading
import time
from dataclasses import dataclass, field
from typing import Any

from aiohttp import web
from lxml import etree

SOAP = "http://www.w3.org/2003/05/soap-envelope"
WSSE = "http://docs.oasis-open.org/wss/2004/01/oasis-200401-wss-wssecurity-secext-1.0.xsd"
WSU = "http://docs.oasis-open.org/wss/2004/01/oasis-200401-wss-wssecurity-utility-1.0.xsd"
GENERIC_POSITION = "http://www.onvif.org/ver10/tptz/PanTiltSpaces/PositionGenericSpace"
GENERIC_TRANSLATION = "http://www.onvif.org/ver10/tptz/PanTiltSpaces/TranslationGenericSpace"
FOV_TRANSLATION = "http://www.onvif.org/ver10/tptz/PanTiltSpaces/TranslationSpaceFov"
GENERIC_VELOCITY = "http://www.onvif.org/ver10/tptz/PanTiltSpaces/VelocityGenericSpace"
GENERIC_SPEED = "http://www.onvif.org/ver10/tptz/PanTiltSpaces/GenericSpeedSpace"
ZOOM_POSITION = "http://www.onvif.org/ver10/tptz/ZoomSpaces/PositionGenericSpace"
SERVICES = {  # path: (WSDL file, binding, namespace)
    "device": ("devicemgmt.wsdl", "{http://www.onvif.org/ver10/device/wsdl}DeviceBinding",
               "http://www.onvif.org/ver10/device/wsdl"),
    "media": ("media.wsdl", "{http://www.onvif.org/ver10/media/wsdl}MediaBinding",
              "http://www.onvif.org/ver10/media/wsdl"),
    "ptz": ("ptz.wsdl", "{http://www.onvif.org/ver20/ptz/wsdl}PTZBinding",
            "http://www.onvif.org/ver20/ptz/wsdl"),
}  # fmt: skip
PROFILE = "profile_1"


@dataclass
class Head:
    """The pan-tilt head in generic units: position in [-1, 1], rates in units/s."""

    top_speed: tuple[float, float] = (0.5, 0.5)  # generic units/s at velocity 1
    x: float = 0.0
    y: float = 0.0
    rate: tuple[float, float] = (0.0, 0.0)
    goal: tuple[float, float] | None = None  # a position move's goal
    goal_speed: tuple[float, float] = (1.0, 1.0)
    until: float = float("inf")  # a continuous move's timeout (monotonic)
    stamp: float = field(default_factory=time.monotonic)

    def advance(self, now: float | None = None) -> None:
        now = time.monotonic() if now is None else now
        end = min(now, self.until)
        dt_s = max(0.0, end - self.stamp)
        if self.goal is not None:
            for axis, goal in enumerate(self.goal):
                speed = self.top_speed[axis] * self.goal_speed[axis]
                here = self.x if axis == 0 else self.y
                step = max(-speed * dt_s, min(speed * dt_s, goal - here))
                if axis == 0:
                    self.x = here + step
                else:
                    self.y = here + step
            if (self.x, self.y) == self.goal:
                self.goal = None
        else:
            self.x = max(-1.0, min(1.0, self.x + self.rate[0] * self.top_speed[0] * dt_s))
            self.y = max(-1.0, min(1.0, self.y + self.rate[1] * self.top_speed[1] * dt_s))
        if now >= self.until:
            self.rate, self.until = (0.0, 0.0), float("inf")
        self.stamp = now

    @property
    def moving(self) -> bool:
        return self.goal is not None or self.rate != (0.0, 0.0)


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _duration_s(value: Any) -> float | None:
    if value is None:
        return None
    if isinstance(value, dt.timedelta):
        return value.total_seconds()
    return float(getattr(value, "total_seconds", lambda: value)())


def _arguments(operation: Any, envelope: Any) -> dict[str, Any]:
    """A request's parts by name (zeep gives a lone part's value bare)."""
    names = [name for name, _ in operation.input.body.type.elements]
    parsed = operation.input.deserialize(envelope)
    if len(names) == 1:
        return {names[0]: parsed}
    return {name: getattr(parsed, name, None) for name in names} if parsed is not None else {}


class OnvifCamera:
    """See the module docstring. `requests` lists (operation, arguments) in the order served."""

    def __init__(
        self,
        *,
        user: str | None = None,
        password: str | None = None,
        fov_moves: bool = True,
        never_idle: bool = False,
        status_position: bool = True,
        presets: dict[str, tuple[float, float]] | None = None,
        top_speed: tuple[float, float] = (0.5, 0.5),
    ) -> None:
        import onvif
        from zeep import Client

        wsdl = os.path.join(os.path.dirname(onvif.__file__), "wsdl")
        self.bindings = {
            path: Client(os.path.join(wsdl, file)).wsdl.bindings[binding]
            for path, (file, binding, _) in SERVICES.items()
        }
        self.user, self.password = user, password
        self.fov_moves, self.never_idle = fov_moves, never_idle
        self.status_position = status_position
        self.presets = dict(presets or {"home": (0.0, 0.0)})
        self.head = Head(top_speed=top_speed)
        self.lock = threading.Lock()
        self.requests: list[tuple[str, dict[str, Any]]] = []
        self.port = free_port()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._runner: web.AppRunner | None = None
        self._thread: threading.Thread | None = None

    # --- the server ---------------------------------------------------------------------------

    def __enter__(self) -> OnvifCamera:
        self.start()
        return self

    def __exit__(self, *_: object) -> None:
        self.stop()

    def start(self) -> None:
        ready = threading.Event()
        self._thread = threading.Thread(target=self._serve, args=(ready,), daemon=True)
        self._thread.start()
        assert ready.wait(10.0), "the ONVIF test camera did not start"

    def stop(self) -> None:
        if self._loop is not None and self._runner is not None:
            asyncio.run_coroutine_threadsafe(self._runner.cleanup(), self._loop).result(10.0)
            self._loop.call_soon_threadsafe(self._loop.stop)
        if self._thread is not None:
            self._thread.join(10.0)

    def _serve(self, ready: threading.Event) -> None:
        self._loop = asyncio.new_event_loop()
        app = web.Application()
        for path in SERVICES:
            app.router.add_post(f"/onvif/{path}_service", self._handler(path))
        self._runner = web.AppRunner(app, access_log=None)
        self._loop.run_until_complete(self._runner.setup())
        site = web.TCPSite(self._runner, "127.0.0.1", self.port)
        self._loop.run_until_complete(site.start())
        ready.set()
        self._loop.run_forever()

    def _handler(self, path: str):  # noqa: ANN202 - an aiohttp handler
        async def handle(request: web.Request) -> web.Response:
            envelope = etree.fromstring(await request.read())
            body = envelope.find(f"{{{SOAP}}}Body")
            element = body[0] if body is not None and len(body) else None
            binding = self.bindings[path]
            name = etree.QName(element).localname if element is not None else ""
            if name not in binding._operations:
                return self._fault("ter:ActionNotSupported", f"{name} is not served here")
            operation = binding._operations[name]
            if name != "GetSystemDateAndTime" and not self._authorized(envelope):
                return self._fault("ter:NotAuthorized", "Sender not Authorized", status=400)
            values = _arguments(operation, envelope)
            with self.lock:
                self.requests.append((name, values))
                self.head.advance()
                reply = getattr(self, "_" + re.sub(r"(?<!^)(?=[A-Z])", "_", name).lower(), None)
                if reply is None:
                    return self._fault("ter:ActionNotSupported", f"{name} is not supported")
                try:
                    result = reply(values)
                except ValueError as error:
                    return self._fault("ter:InvalidArgVal", str(error))
            message = operation.output.serialize(**result)
            return web.Response(
                body=etree.tostring(message.content), content_type="application/soap+xml"
            )

        return handle

    def _authorized(self, envelope: Any) -> bool:
        if self.password is None:
            return True
        token = envelope.find(f".//{{{WSSE}}}UsernameToken")
        if token is None:
            return False
        user = token.findtext(f"{{{WSSE}}}Username")
        digest = token.findtext(f"{{{WSSE}}}Password") or ""
        nonce = base64.b64decode(token.findtext(f"{{{WSSE}}}Nonce") or "")
        created = (token.findtext(f"{{{WSU}}}Created") or "").encode()
        expected = base64.b64encode(
            hashlib.sha1(nonce + created + self.password.encode()).digest()
        ).decode()
        return user == self.user and digest == expected

    @staticmethod
    def _fault(code: str, reason: str, status: int = 500) -> web.Response:
        xml = (
            f'<s:Envelope xmlns:s="{SOAP}" xmlns:ter="http://www.onvif.org/ver10/error">'
            "<s:Body><s:Fault><s:Code><s:Value>s:Sender</s:Value><s:Subcode>"
            f"<s:Value>{code}</s:Value></s:Subcode></s:Code>"
            f'<s:Reason><s:Text xml:lang="en">{reason}</s:Text></s:Reason>'
            "</s:Fault></s:Body></s:Envelope>"
        )
        return web.Response(status=status, body=xml.encode(), content_type="application/soap+xml")

    def url(self, path: str) -> str:
        return f"http://127.0.0.1:{self.port}/onvif/{path}_service"

    # --- device and media ---------------------------------------------------------------------

    def _get_system_date_and_time(self, _: dict[str, Any]) -> dict[str, Any]:
        now = dt.datetime.now(dt.UTC)
        moment = {
            "Date": {"Year": now.year, "Month": now.month, "Day": now.day},
            "Time": {"Hour": now.hour, "Minute": now.minute, "Second": now.second},
        }
        return {
            "SystemDateAndTime": {
                "DateTimeType": "Manual",
                "DaylightSavings": False,
                "UTCDateTime": moment,
            }
        }

    def _get_services(self, _: dict[str, Any]) -> dict[str, Any]:
        services = [
            {"Namespace": ns, "XAddr": self.url(path), "Version": {"Major": 2, "Minor": 60}}
            for path, (_file, _binding, ns) in SERVICES.items()
        ]
        return {"Service": services}

    def _get_capabilities(self, _: dict[str, Any]) -> dict[str, Any]:
        return {"Capabilities": {"PTZ": {"XAddr": self.url("ptz")}}}

    def _get_profiles(self, _: dict[str, Any]) -> dict[str, Any]:
        return {
            "Profiles": [
                {
                    "token": PROFILE,
                    "fixed": True,
                    "Name": "main",
                    "PTZConfiguration": self._config(),
                }
            ]
        }

    # --- PTZ ----------------------------------------------------------------------------------

    def _spaces(self) -> dict[str, Any]:
        unit = {"Min": -1.0, "Max": 1.0}
        translations = [{"URI": GENERIC_TRANSLATION, "XRange": unit, "YRange": unit}]
        if self.fov_moves:
            translations.append({"URI": FOV_TRANSLATION, "XRange": unit, "YRange": unit})
        return {
            "AbsolutePanTiltPositionSpace": [
                {"URI": GENERIC_POSITION, "XRange": unit, "YRange": unit}
            ],
            "RelativePanTiltTranslationSpace": translations,
            "ContinuousPanTiltVelocitySpace": [
                {"URI": GENERIC_VELOCITY, "XRange": unit, "YRange": unit}
            ],
            "PanTiltSpeedSpace": [{"URI": GENERIC_SPEED, "XRange": {"Min": 0.0, "Max": 1.0}}],
        }

    def _config(self) -> dict[str, Any]:
        return {
            "token": "ptz_config_1",
            "Name": "ptz",
            "UseCount": 1,
            "NodeToken": "ptz_node_1",
            "DefaultAbsolutePantTiltPositionSpace": GENERIC_POSITION,
            "DefaultContinuousPanTiltVelocitySpace": GENERIC_VELOCITY,
            "DefaultPTZTimeout": dt.timedelta(seconds=5),
        }

    def _get_configurations(self, _: dict[str, Any]) -> dict[str, Any]:
        return {"PTZConfiguration": [self._config()]}

    def _get_configuration_options(self, _: dict[str, Any]) -> dict[str, Any]:
        return {
            "PTZConfigurationOptions": {
                "Spaces": self._spaces(),
                "PTZTimeout": {"Min": dt.timedelta(seconds=1), "Max": dt.timedelta(seconds=60)},
            }
        }

    def _get_nodes(self, _: dict[str, Any]) -> dict[str, Any]:
        return {
            "PTZNode": [
                {
                    "token": "ptz_node_1",
                    "Name": "head",
                    "SupportedPTZSpaces": self._spaces(),
                    "MaximumNumberOfPresets": 16,
                    "HomeSupported": True,
                }
            ]
        }

    def _get_status(self, _: dict[str, Any]) -> dict[str, Any]:
        head = self.head
        moving = "MOVING" if (head.moving or self.never_idle) else "IDLE"
        status: dict[str, Any] = {
            "MoveStatus": {"PanTilt": moving, "Zoom": "IDLE"},
            "UtcTime": dt.datetime.now(dt.UTC),
        }
        if self.status_position:
            status["Position"] = {
                "PanTilt": {"x": head.x, "y": head.y, "space": GENERIC_POSITION},
                "Zoom": {"x": 0.0, "space": ZOOM_POSITION},
            }
        return {"PTZStatus": status}

    def _continuous_move(self, values: dict[str, Any]) -> dict[str, Any]:
        pan_tilt = values["Velocity"].PanTilt
        rate = (max(-1.0, min(1.0, pan_tilt.x)), max(-1.0, min(1.0, pan_tilt.y)))
        timeout = _duration_s(values.get("Timeout"))
        self.head.goal, self.head.rate = None, rate
        self.head.until = time.monotonic() + timeout if timeout else float("inf")
        return {}

    def _speed(self, values: dict[str, Any]) -> tuple[float, float]:
        speed = values.get("Speed")
        pan_tilt = getattr(speed, "PanTilt", None) if speed is not None else None
        return (pan_tilt.x, pan_tilt.y) if pan_tilt is not None else (1.0, 1.0)

    def _absolute_move(self, values: dict[str, Any]) -> dict[str, Any]:
        target = values["Position"].PanTilt
        self._move_to((target.x, target.y), self._speed(values))
        return {}

    def _relative_move(self, values: dict[str, Any]) -> dict[str, Any]:
        step = values["Translation"].PanTilt
        space = step.space or GENERIC_TRANSLATION
        if space == FOV_TRANSLATION and not self.fov_moves:
            raise ValueError(f"translation space {space} is not supported")
        scale = 0.1 if space == FOV_TRANSLATION else 1.0  # the view is 0.1 generic units wide
        goal = (self.head.x + scale * step.x, self.head.y + scale * step.y)
        self._move_to(goal, self._speed(values))
        return {}

    def _move_to(self, goal: tuple[float, float], speed: tuple[float, float]) -> None:
        clipped = (max(-1.0, min(1.0, goal[0])), max(-1.0, min(1.0, goal[1])))
        self.head.rate, self.head.until = (0.0, 0.0), float("inf")
        self.head.goal, self.head.goal_speed = clipped, speed

    def _stop(self, _: dict[str, Any]) -> dict[str, Any]:
        self.head.goal, self.head.rate, self.head.until = None, (0.0, 0.0), float("inf")
        return {}

    def _get_presets(self, _: dict[str, Any]) -> dict[str, Any]:
        presets = [
            {
                "token": token,
                "Name": token,
                "PTZPosition": {"PanTilt": {"x": x, "y": y, "space": GENERIC_POSITION}},
            }
            for token, (x, y) in self.presets.items()
        ]
        return {"Preset": presets}

    def _goto_preset(self, values: dict[str, Any]) -> dict[str, Any]:
        token = values["PresetToken"]
        if token not in self.presets:
            raise ValueError(f"no preset {token}")
        self._move_to(self.presets[token], self._speed(values))
        return {}

    # --- for the tests ------------------------------------------------------------------------

    def pose(self) -> tuple[float, float]:
        with self.lock:
            self.head.advance()
            return self.head.x, self.head.y

    def calls(self, name: str) -> list[dict[str, Any]]:
        with self.lock:
            return [values for op, values in self.requests if op == name]
