"""The twin seen in Foxglove (boat_twin.view): ``follow --foxglove`` serves the Foxglove WebSocket protocol to a real
client (the ``websockets`` package speaking the protocol, ``foxglove.sdk.v1``: serverInfo, advertise, subscribe, binary
messageData decoded with the advertised schemas), records the same channels to MCAP, and the saved layout is the
one the view's topics give."""

from __future__ import annotations

import base64
import json
import os
import selectors
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from processes import popen_as_from_a_shell

from boat_twin.errors import InputError
from boat_twin.view.address import DEFAULT_HOST, DEFAULT_PORT, parse_address

foxglove = pytest.importorskip("foxglove", reason="the view extra (foxglove-sdk) is not installed")
websockets_sync = pytest.importorskip("websockets.sync.client")
descriptor_pb2 = pytest.importorskip("google.protobuf.descriptor_pb2")

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "bags" / "thrust_steps_sample"
BOAT_TWIN = Path(sys.executable).with_name("boat-twin")
SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]
"""The Foxglove WebSocket protocol by its two names: the SDK's server (0.30) accepts only the new one, identical to
the old ``foxglove.websocket.v1`` but for the name (an old client's handshake gets HTTP 400)."""
MESSAGE_DATA = 0x01
"""Opcode of a binary messageData frame: u8 opcode, u32 subscription id, u64 log time ns, payload (little endian)."""
WANTED = ("/boat/fix", "/twin/fix", "/twin/innovations/speed_mps", "/twin/model")
FOLLOW_DEADLINE_S = 600.0
"""The whole follow of the 930 s sample (~15 s idle, ~50 s at a load of 6 on two cores)."""


def test_addresses_default_to_loopback_and_bad_ones_are_one_line() -> None:
    assert parse_address("") == (DEFAULT_HOST, DEFAULT_PORT) == ("127.0.0.1", 8765)
    assert parse_address("127.0.0.1:0") == ("127.0.0.1", 0)
    assert parse_address(":9000") == ("127.0.0.1", 9000)
    assert parse_address("localhost") == ("localhost", DEFAULT_PORT)
    assert parse_address("[::1]:9001") == ("::1", 9001)
    for bad in ("127.0.0.1:70000", "127.0.0.1:port", "bags/thrust_steps_sample"):
        with pytest.raises(InputError, match="expected HOST:PORT"):
            parse_address(bad)


def test_the_saved_layout_is_the_one_the_views_topics_give() -> None:
    from boat_twin.view.layout import layout_json

    saved = (ROOT / "config" / "foxglove" / "twin_layout.json").read_text()
    assert json.loads(saved) == json.loads(layout_json()), \
        "regenerate: .venv/bin/python -m boat_twin.view.layout > config/foxglove/twin_layout.json"
    text = json.dumps(json.loads(saved))
    for path in ("/boat/fix", "/twin/fix", "/twin/innovations/speed_mps.band_high", "/twin/model.mass_low_kg",
                 "/twin/log", "/scene"):
        assert path in text


def test_without_the_sdk_foxglove_is_refused_in_one_line(tmp_path: Path) -> None:
    blocked = tmp_path / "blocked" / "foxglove"
    blocked.mkdir(parents=True)
    (blocked / "__init__.py").write_text("raise ImportError('foxglove-sdk hidden by the test')\n")
    env = {**os.environ, "PYTHONPATH": str(blocked.parent)}
    done = subprocess.run([str(BOAT_TWIN), "follow", str(SAMPLE), "--foxglove"], capture_output=True, text=True,
                          env=env, timeout=120)
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().splitlines() == [
        "boat-twin follow: error: --foxglove needs the foxglove-sdk package: pip install 'boat_twin[view]' (or pip "
        "install foxglove-sdk)"], done.stderr


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
    """The ``foxglove: live view on ws://...`` line of the process's stderr (bounded wait)."""
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


def collect(url: str, deadline: float, enough: int = 20) -> tuple[dict[str, Any], dict[str, list[dict[str, Any]]]]:
    """Connect as a Foxglove client, subscribe to :data:`WANTED` as they are advertised, decode messageData until
    ``enough`` of each (or the deadline)."""
    channels: dict[int, dict[str, Any]] = {}
    by_subscription: dict[int, tuple[str, Any]] = {}
    received: dict[str, list[dict[str, Any]]] = {topic: [] for topic in WANTED}
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
                        if channel["topic"] in WANTED:
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


def test_follow_serves_the_twin_to_a_foxglove_client_and_records_it(tmp_path: Path) -> None:
    deadline = time.monotonic() + FOLLOW_DEADLINE_S
    out = tmp_path / "out"
    process = popen_as_from_a_shell(
        [str(BOAT_TWIN), "follow", str(SAMPLE), "--json", "--out", str(out), "--foxglove", "127.0.0.1:0",
         "--foxglove-speed", "0"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        url = read_url(process, deadline)
        assert url.startswith("ws://127.0.0.1:") and not url.endswith(":0"), url
        info, received = collect(url, min(deadline, time.monotonic() + 120.0))
        stdout, stderr = process.communicate(timeout=max(1.0, deadline - time.monotonic()))
    finally:
        if process.poll() is None:
            process.send_signal(signal.SIGINT)
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
    assert process.returncode == 0, stderr.decode(errors="replace")[-2000:]
    assert info.get("op") == "serverInfo"
    for topic in WANTED:
        assert len(received[topic]) >= 20, {t: len(v) for t, v in received.items()}
    # the sample's waters (43.07 N, 131.90 E); measured and predicted fixes of one stamp within metres
    boat, twin = received["/boat/fix"], received["/twin/fix"]
    for fix in boat + twin:
        assert 42.9 < fix["latitude"] < 43.2 and 131.8 < fix["longitude"] < 132.0, fix
    assert {f["frame_id"] for f in boat} == {"boat"} and {f["frame_id"] for f in twin} == {"twin"}
    assert boat[-1]["position_covariance"][0] > 0.0 and boat[-1]["position_covariance_type"] == "DIAGONAL_KNOWN"
    predicted = {f["log_time_ns"]: f for f in twin}
    pairs = [(f, predicted[f["log_time_ns"]]) for f in boat if f["log_time_ns"] in predicted]
    assert len(pairs) >= 10
    for measured, twin_fix in pairs:  # 1e-4 deg: 11 m of latitude, 8 m of longitude there
        assert abs(measured["latitude"] - twin_fix["latitude"]) < 1e-4, (measured, twin_fix)
        assert abs(measured["longitude"] - twin_fix["longitude"]) < 1e-4, (measured, twin_fix)
    speed = received["/twin/innovations/speed_mps"]
    for item in speed:
        assert item["band_high"] == pytest.approx(2.0 * item["stdev"]) and item["stdev"] > 0.0
        assert item["innovation"] == pytest.approx(item["measured"] - item["predicted"])
    assert sum(abs(i["innovation"]) <= i["band_high"] for i in speed) >= 0.8 * len(speed)
    assert 1000.0 < received["/twin/model"][-1]["mass_kg"] < 2000.0
    json.loads(stdout)  # the --json report is intact beside the live view

    from mcap.reader import make_reader

    with (out / "view.mcap").open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        schemas = {ch.topic: (ch.message_encoding, summary.schemas[ch.schema_id].name,
                              summary.schemas[ch.schema_id].encoding) for ch in summary.channels.values()}
        counts = {summary.channels[i].topic: n for i, n in summary.statistics.channel_message_counts.items()}
        fixes = []
        for schema, channel, message in reader.iter_messages(topics=["/twin/fix"]):
            if not fixes:
                decode = decoder({"encoding": channel.message_encoding, "schemaEncoding": schema.encoding,
                                  "schemaName": schema.name, "schema": base64.b64encode(schema.data).decode()})
            fixes.append(decode(message.data))
    assert schemas["/boat/fix"] == schemas["/twin/fix"] == ("protobuf", "foxglove.LocationFix", "protobuf")
    assert schemas["/scene"] == ("protobuf", "foxglove.SceneUpdate", "protobuf")
    assert schemas["/tf"] == ("protobuf", "foxglove.FrameTransforms", "protobuf")
    assert schemas["/twin/log"] == ("protobuf", "foxglove.Log", "protobuf")
    assert schemas["/twin/model"] == ("json", "boat_twin.TwinModel", "jsonschema")
    for channel in ("speed_mps", "yaw_rate_radps", "east_m", "north_m", "heading_rad"):
        assert schemas[f"/twin/innovations/{channel}"] == ("json", "boat_twin.Innovation", "jsonschema")
    assert counts["/twin/fix"] > 5000 and counts["/twin/log"] >= 1  # 10 Hz over 930 s; the verdicts
    assert len(fixes) == counts["/twin/fix"] and 42.9 < fixes[-1]["latitude"] < 43.2
