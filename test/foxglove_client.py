"""A client of the Foxglove WebSocket protocol for the tests (the ``websockets`` package): connect with the
protocol's subprotocol, subscribe to topics as they are advertised, decode binary messageData frames with the
advertised schemas (protobuf through its FileDescriptorSet, or JSON)."""

from __future__ import annotations

import base64
import json
import os
import selectors
import struct
import subprocess
import time
from collections.abc import Iterable
from typing import Any

from google.protobuf import descriptor_pb2
from websockets.sync import client as websockets_sync

SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]
"""The Foxglove WebSocket protocol by its two names: the SDK's server (0.30) accepts only the new one, identical to
the old ``foxglove.websocket.v1`` but for the name (an old client's handshake gets HTTP 400)."""
MESSAGE_DATA = 0x01
"""Opcode of a binary messageData frame: u8 opcode, u32 subscription id, u64 log time ns, payload (little endian)."""


def decoder(channel: dict[str, Any]) -> Any:
    """A function bytes → dict for an advertised channel (protobuf with its FileDescriptorSet, or JSON)."""
    if channel["encoding"] == "json":
        return lambda data: json.loads(data)
    assert channel["encoding"] == "protobuf" and channel["schemaEncoding"] == "protobuf", channel
    from google.protobuf import descriptor_pool, json_format, message_factory

    files = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"])).file
    return _protobuf_decoder(files, channel["schemaName"], descriptor_pool, message_factory, json_format)


def _protobuf_decoder(files: Any, name: str, descriptor_pool: Any, message_factory: Any, json_format: Any) -> Any:
    pool = descriptor_pool.DescriptorPool()
    pending = list(files)
    while pending:  # dependencies first, whatever the set's order
        added = []
        for file in pending:
            try:
                pool.Add(file)
                added.append(file)
            except TypeError:
                continue
        assert added, f"unresolved protobuf dependencies of {name}"
        pending = [f for f in pending if f not in added]
    cls = message_factory.GetMessageClass(pool.FindMessageTypeByName(name))
    return lambda data: json_format.MessageToDict(cls.FromString(data), preserving_proto_field_name=True)


def read_url(process: subprocess.Popen, deadline: float) -> str:
    """The ``foxglove: live view on ws://...`` line of the process's stderr pipe (bounded wait)."""
    assert process.stderr is not None
    selector = selectors.DefaultSelector()
    selector.register(process.stderr, selectors.EVENT_READ)
    text = b""
    while time.monotonic() < deadline:
        if selector.select(timeout=max(0.0, min(1.0, deadline - time.monotonic()))):
            chunk = os.read(process.stderr.fileno(), 4096)
            if not chunk:
                break
            text += chunk
            for line in text.decode(errors="replace").splitlines():
                if line.startswith("foxglove: live view on ws://"):
                    return line.split()[4]
    raise AssertionError(f"no live-view line from follow: {text.decode(errors='replace')!r}")


def collect(url: str, wanted: Iterable[str], deadline: float, enough: int = 20
            ) -> tuple[dict[str, Any], dict[str, list[dict[str, Any]]]]:
    """Connect as a Foxglove client, subscribe to the ``wanted`` topics as they are advertised, decode messageData
    until ``enough`` of each (or the deadline)."""
    wanted = tuple(wanted)
    channels: dict[int, dict[str, Any]] = {}
    by_subscription: dict[int, tuple[str, Any]] = {}
    received: dict[str, list[dict[str, Any]]] = {topic: [] for topic in wanted}
    info: dict[str, Any] = {}
    while True:  # the server is up once it printed its address, but allow a slow accept
        try:
            ws = websockets_sync.connect(url, subprotocols=SUBPROTOCOLS, open_timeout=10)
            break
        except OSError:
            assert time.monotonic() < deadline, f"cannot connect to {url}"
            time.sleep(0.2)
    with ws:
        assert ws.subprotocol in SUBPROTOCOLS
        while time.monotonic() < deadline and min(len(v) for v in received.values()) < enough:
            try:
                frame = ws.recv(timeout=max(0.1, min(2.0, deadline - time.monotonic())))
            except TimeoutError:
                continue
            if isinstance(frame, str):
                message = json.loads(frame)
                if message["op"] == "serverInfo":
                    info = message
                elif message["op"] == "advertise":
                    subscribe = []
                    for channel in message["channels"]:
                        channels[channel["id"]] = channel
                        if channel["topic"] in wanted:
                            sub_id = len(by_subscription) + 1
                            by_subscription[sub_id] = (channel["topic"], decoder(channel))
                            subscribe.append({"id": sub_id, "channelId": channel["id"]})
                    if subscribe:
                        ws.send(json.dumps({"op": "subscribe", "subscriptions": subscribe}))
                continue
            if frame[0] != MESSAGE_DATA:
                continue
            sub_id, log_time_ns = struct.unpack_from("<IQ", frame, 1)
            topic, decode = by_subscription[sub_id]
            received[topic].append({"log_time_ns": log_time_ns, **decode(frame[13:])})
    return info, received


def url_in(text: str) -> str | None:
    """The address of a ``foxglove: live view on ws://...`` line in ``text`` (None without one)."""
    for line in text.splitlines():
        if "foxglove: live view on ws://" in line:
            return line.split("live view on ")[1].split()[0]
    return None
