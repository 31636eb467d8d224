"""A minimal Foxglove WebSocket client for tests: connect, subscribe to every advertised channel,
and collect the messages by topic (https://github.com/foxglove/ws-protocol)."""

from __future__ import annotations

import json
import struct
import time
from collections import defaultdict

from websockets.sync.client import connect

MESSAGE_DATA = 0x01  # binary opcode: subscription id (u32), log time (u64), payload


class FoxgloveClient:
    def __init__(self, port: int, host: str = "127.0.0.1") -> None:
        self._connection = connect(f"ws://{host}:{port}", subprotocols=["foxglove.sdk.v1"])
        self.socket = self._connection.__enter__()
        self.channels: dict[int, str] = {}  # channel id -> topic
        self.subscribed: dict[int, str] = {}  # subscription id -> topic
        self.messages: dict[str, list[bytes]] = defaultdict(list)

    def close(self) -> None:
        self._connection.__exit__(None, None, None)

    def wait_for_channels(self, topics: set[str], timeout: float = 10.0) -> None:
        deadline = time.monotonic() + timeout
        while not topics <= set(self.channels.values()):
            assert time.monotonic() < deadline, f"advertised only {sorted(self.channels.values())}"
            self._receive(deadline)
        self._subscribe()

    def wait_for_messages(self, topics: set[str], timeout: float = 10.0) -> None:
        deadline = time.monotonic() + timeout
        while not topics <= {t for t, m in self.messages.items() if m}:
            assert time.monotonic() < deadline, f"received only {sorted(self.messages)}"
            self._receive(deadline)

    def _subscribe(self) -> None:
        wanted = [(i, c) for i, c in enumerate(sorted(self.channels)) if i not in self.subscribed]
        self.subscribed |= {i: self.channels[c] for i, c in wanted}
        subscriptions = [{"id": i, "channelId": c} for i, c in wanted]
        self.socket.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))

    def _receive(self, deadline: float) -> None:
        try:
            message = self.socket.recv(timeout=max(0.01, deadline - time.monotonic()))
        except TimeoutError:
            return
        if isinstance(message, str):
            data = json.loads(message)
            if data.get("op") == "advertise":
                self.channels |= {c["id"]: c["topic"] for c in data["channels"]}
        elif message[0] == MESSAGE_DATA:
            (subscription,) = struct.unpack_from("<I", message, 1)
            self.messages[self.subscribed[subscription]].append(message[13:])
