"""Typed ports on a running instance: `connect()` joins it (discovery and the schema check),
`Group.subscribe(topic)` and `Group.publisher(topic)` open exactly the services the Rust
ports open (same QoS, same service settings, same paired event service for wake-up).

Received messages are copies by default (`receive()`, iteration): plain ctypes structures
owned by Python, valid forever. `receive_view()` hands a `View` instead: the structure in
shared memory, without a copy, valid until `release()` (or the end of its `with` block);
a subscriber may hold at most `SERVICE_SETTINGS.subscriber_max_borrowed_samples` views.
"""

from __future__ import annotations

import ctypes
import os
import time
import tomllib
from pathlib import Path
from typing import Callable, Iterator, NamedTuple

import iceoryx2 as iox2

from . import _generated as g
from .discovery import Found, find
from .errors import AisleError, SchemaMismatch, Timeout, TopicError

WAIT_SLICE = 0.025  # longest single sleep, so Ctrl-C and deadlines are served promptly


def monotonic_ns() -> int:
    return time.clock_gettime_ns(time.CLOCK_MONOTONIC)


def node_code(name: str) -> int:
    """The node code of an external node: bit 31 set over FNV-1a 32 of its UTF-8 name;
    a built-in name gives its built-in code."""
    if name in g.BUILTIN_NODES:
        return g.BUILTIN_NODES[name]
    h = 0x811C9DC5
    for b in name.encode("utf-8"):
        h = ((h ^ b) * 0x01000193) & 0xFFFFFFFF
    return 0x8000_0000 | (h & 0x7FFF_FFFF)


class Stamp(NamedTuple):
    """The causal stamps a message carries (Rust's `aisle_bus::Stamp`)."""

    stamp_ns: int = 0
    tick: int = 0
    tick_wall_ns: int = 0

    @staticmethod
    def of(header) -> "Stamp":
        return Stamp(header.stamp_ns, header.tick, header.tick_wall_ns)


def graph_topics(config_dir: Path | None) -> dict[str, g.Topic]:
    """The `[[topic]]` entries of `config_dir/graph.toml` (user topics of a catalogue type)."""
    if config_dir is None:
        return {}
    path = Path(config_dir) / "graph.toml"
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        return {}
    except (OSError, tomllib.TOMLDecodeError) as e:
        raise TopicError(f"{path}: {e}") from None
    out = {}
    for i, t in enumerate(data.get("topic", [])):
        name, tn = t.get("name"), t.get("type")
        if not isinstance(name, str) or not isinstance(tn, str):
            raise TopicError(f"{path}: [[topic]] #{i + 1} needs `name` and `type` strings")
        if tn not in g.MESSAGES:
            raise TopicError(f"{path}: [[topic]] `{name}`: unknown type `{tn}` (known: catalogue TYPE_NAMEs)")
        out[name] = g.Topic(name, g.MESSAGES[tn], g.USER_TOPIC_QOS)
    return out


class View:
    """A received message in shared memory (no copy): `msg` is valid until `release()`."""

    def __init__(self, sample, cls):
        self._sample = sample
        self.msg = sample.payload().contents
        self.cls = cls

    @property
    def address(self) -> int:
        return ctypes.addressof(self.msg)

    def copy(self):
        return self.cls.from_buffer_copy(self.msg)

    def release(self) -> None:
        if self._sample is not None:
            self.msg = None
            self._sample.delete()
            self._sample = None

    def __enter__(self) -> "View":
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def _pubsub(node, topic: g.Topic):
    s, q = g.SERVICE_SETTINGS, topic.qos
    return (
        node.service_builder(iox2.ServiceName.new(topic.name))
        .publish_subscribe(topic.message)
        .max_publishers(q.max_publishers)
        .max_subscribers(q.max_subscribers)
        .history_size(q.history)
        .subscriber_max_buffer_size(q.buffer)
        .subscriber_max_borrowed_samples(s.subscriber_max_borrowed_samples)
        .enable_safe_overflow(s.enable_safe_overflow)
        .max_nodes(s.max_nodes)
        .open_or_create()
    )


def _event(node, topic: g.Topic):
    s = g.SERVICE_SETTINGS
    return (
        node.service_builder(iox2.ServiceName.new(topic.name))
        .event()
        .max_notifiers(s.event_max_notifiers)
        .max_listeners(s.event_max_listeners)
        .max_nodes(s.max_nodes)
        .open_or_create()
    )


class Subscriber:
    """Receives `topic.message` samples; waits sleep on the topic's event service."""

    def __init__(self, node, topic: g.Topic):
        self.topic = topic
        try:
            b = _pubsub(node, topic).subscriber_builder().buffer_size(topic.qos.buffer)
            if topic.qos.history > 0:
                b = b.history_request(topic.qos.history)
            self._port = b.create()
            self._listener = _event(node, topic).listener_builder().create()
        except Exception as e:  # iceoryx2 raises its own exception types
            raise TopicError(f"cannot subscribe to {topic.name} ({topic.message.TYPE_NAME}): {e!r}") from None

    def _take(self):
        return self._port.receive()

    def receive_view(self, timeout: float | None = 0.0) -> View | None:
        """The next sample in place (see `View`), waiting up to `timeout` s (None: forever)."""
        s = self._wait(timeout)
        return None if s is None else View(s, self.topic.message)

    def receive(self, timeout: float | None = 0.0):
        """A copy of the next sample, waiting up to `timeout` s (None: forever); None on timeout."""
        s = self._wait(timeout)
        if s is None:
            return None
        try:
            return self.topic.message.from_buffer_copy(s.payload().contents)
        finally:
            s.delete()

    def latest(self):
        """A copy of the newest waiting sample (older ones are dropped), or None."""
        last = None
        while (s := self._take()) is not None:
            if last is not None:
                last.delete()
            last = s
        if last is None:
            return None
        try:
            return self.topic.message.from_buffer_copy(last.payload().contents)
        finally:
            last.delete()

    def _wait(self, timeout: float | None):
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            s = self._take()
            if s is not None:
                return s
            left = WAIT_SLICE if deadline is None else min(WAIT_SLICE, deadline - time.monotonic())
            if left <= 0:
                return None
            try:
                self._listener.timed_wait(iox2.Duration.from_secs_f64(left))
            except iox2.ListenerWaitError:
                pass  # a signal interrupted the sleep: Python runs its handler next

    def __iter__(self) -> Iterator:
        """Copies of every sample, forever (Ctrl-C ends it)."""
        while True:
            yield self.receive(timeout=None)


class Loan:
    """A sample loaned in shared memory, zero-filled: write `msg` in place, then `send()`."""

    def __init__(self, publisher: "Publisher", stamp: Stamp):
        self._pub, self._stamp = publisher, stamp
        self._sample = publisher._port.loan_uninit()
        size = ctypes.sizeof(publisher.topic.message)
        ctypes.memset(self._sample.payload_ptr, 0, size)
        self.msg = self._sample.payload().contents

    def send(self) -> int:
        """Stamps the header (as Rust's `Publisher::publish` does), sends, wakes the subscribers."""
        if self._sample is None:
            raise AisleError("this loan was already sent")
        p = self._pub
        p.seq += 1
        h = self.msg.header
        h.seq, h.stamp_ns, h.tick, h.tick_wall_ns = p.seq, *self._stamp
        h.publish_wall_ns = monotonic_ns()
        h.source = p.source
        self.msg = None
        self._sample.assume_init().send()
        self._sample = None
        p._notifier.notify()
        return p.seq

    def __enter__(self) -> "Loan":
        return self

    def __exit__(self, exc_type, *exc) -> None:
        if exc_type is None and self._sample is not None:
            self.send()
        self._sample = None  # dropped unsent: iceoryx2 returns it on release


class Publisher:
    """Publishes `topic.message` samples written in place, stamped like the Rust side's."""

    def __init__(self, node, topic: g.Topic, source: int):
        self.topic, self.source, self.seq = topic, source, 0
        try:
            self._port = (
                _pubsub(node, topic)
                .publisher_builder()
                .max_loaned_samples(g.SERVICE_SETTINGS.publisher_max_loaned_samples)
                .create()
            )
            self._notifier = _event(node, topic).notifier_builder().create()
        except Exception as e:
            raise TopicError(f"cannot publish on {topic.name} ({topic.message.TYPE_NAME}): {e!r}") from None

    def loan(self, stamp: Stamp = Stamp()) -> Loan:
        """A zero-filled sample in shared memory; `with pub.loan(stamp) as l: l.msg.x = 1` sends it."""
        return Loan(self, stamp)

    def publish(self, fill: Callable | None = None, *, stamp: Stamp = Stamp(), message=None) -> int:
        """Publishes one sample: a copy of `message` (a structure of the topic's type), then
        `fill(msg)` writing in place; the header is stamped last. Returns the sequence number."""
        loan = self.loan(stamp)
        if message is not None:
            if type(message) is not self.topic.message:
                raise TopicError(
                    f"{self.topic.name} carries {self.topic.message.__name__}, not {type(message).__name__}"
                )
            ctypes.memmove(ctypes.addressof(loan.msg), ctypes.addressof(message), ctypes.sizeof(message))
        if fill is not None:
            fill(loan.msg)
        return loan.send()

    def update_connections(self) -> None:
        """Hands the history to subscribers that joined since the last send."""
        self._port.update_connections()


class Group:
    """A joined instance: its iceoryx2 node and the ports opened on it."""

    def __init__(self, found: Found, name: str, config_dir: Path | None, timeout: float):
        self.prefix, self.root, self.record = found.prefix, found.root, found.record
        self.name, self.code = name, node_code(name)
        if found.record is not None and found.record.schema_hash != g.SCHEMA_HASH:
            raise _mismatch(self.prefix, found.record.schema_hash)
        cfg = iox2.config.default()
        cfg.global_cfg.prefix = iox2.FileName.new(self.prefix)
        cfg.global_cfg.root_path = iox2.Path.new(str(self.root).rstrip("/") + "/")
        self.node = (
            iox2.NodeBuilder.new()
            .name(iox2.NodeName.new(name))
            .config(cfg)
            .signal_handling_mode(iox2.SignalHandlingMode.Disabled)
            .create(iox2.ServiceType.Ipc)
        )
        if config_dir is None and found.record is not None:
            config_dir = found.record.config_dir
        self.config_dir = config_dir
        self._user_topics = graph_topics(config_dir)
        info = Subscriber(self.node, g.INSTANCE).receive(timeout=timeout)
        if info is None:
            raise Timeout(
                f"instance `{self.prefix}` at {self.root}: no InstanceInfo on {g.INSTANCE.name} "
                f"within {timeout} s (is its supervisor running?)"
            )
        if info.schema_hash != g.SCHEMA_HASH:
            raise _mismatch(self.prefix, info.schema_hash)
        self.info = info

    def topic(self, topic: g.Topic | str) -> g.Topic:
        """A topic by constant or name: the catalogue's table, else the graph's `[[topic]]`s."""
        if isinstance(topic, g.Topic):
            return topic
        for t in g.TOPICS:
            if t.name == topic:
                return t
        if topic in self._user_topics:
            return self._user_topics[topic]
        where = f" nor in {self.config_dir}/graph.toml" if self.config_dir else " (no graph.toml known)"
        raise TopicError(f"unknown topic `{topic}`: not in the catalogue's table{where}")

    def subscribe(self, topic: g.Topic | str) -> Subscriber:
        return Subscriber(self.node, self.topic(topic))

    def publisher(self, topic: g.Topic | str) -> Publisher:
        return Publisher(self.node, self.topic(topic), self.code)


def _mismatch(prefix: str, theirs: int) -> SchemaMismatch:
    return SchemaMismatch(
        f"instance `{prefix}` runs message schema {theirs:016x}, this SDK was generated for "
        f"{g.SCHEMA_HASH:016x}: run `aisle gen python` with the group's build and reinstall "
        "the SDK (`pip install ./python`), or run the group built from this checkout"
    )


def connect(
    prefix: str | None = None,
    root: str | Path | None = None,
    *,
    name: str = "python",
    config_dir: str | Path | None = None,
    timeout: float = 10.0,
) -> Group:
    """Joins a running instance (see `aisle.discovery` for which) and checks its schema."""
    found = find(prefix, root)
    cd = Path(config_dir) if config_dir is not None else None
    if cd is None and os.environ.get("AISLE_CONFIG_DIR"):
        cd = Path(os.environ["AISLE_CONFIG_DIR"])
    return Group(found, name, cd, timeout)
