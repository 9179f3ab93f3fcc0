"""The lockstep stage API: an external node of the graph, run by the supervisor.

The supervisor starts a node declared with `command = [...]` in graph.toml with
`AISLE_PREFIX`, `AISLE_ROOT`, `AISLE_CONFIG_DIR`, `AISLE_NODE`, `AISLE_NODE_ID` and
`AISLE_RESTARTED` set. `run_node(fn)` joins (schema check, up to 10 s), beats on
`aisle/heartbeat` every 50 ms from a thread (Starting, then Ready: also while `fn`
computes), opens exactly the topics the node's graph entry declares, and per tick k
(`aisle/tick`): waits for the `TickDone(k)` of the nodes in `after`, hands `fn` the newest
sample with `header.tick <= k` of each subscribed topic, publishes what `fn` returns stamped
with tick k, and acknowledges with `TickDone(k)` when `acknowledges` covers the tick. A
repeated tick is acknowledged again, not recomputed. SIGTERM/SIGINT stop it cleanly (exit 0).

`fn(tick, inputs)` gets the `Tick` (a copy) and an `Inputs` (topic or name -> message copy
or None) and returns None or a dict topic (or name) -> a structure of the topic's type (sent
as a copy) or a function filling the loaned sample in place.
"""

from __future__ import annotations

import logging
import os
import signal
import sys
import threading
import time
import tomllib
from pathlib import Path
from typing import Callable

from . import _generated as g
from .bus import Group, Publisher, Stamp, connect, monotonic_ns, node_code
from .errors import AisleError

log = logging.getLogger("aisle.stage")

HEARTBEAT_PERIOD = 0.05
JOIN_TIMEOUT = 10.0
PROTOCOL_TOPICS = {g.TICK.name, g.TICK_DONE.name, g.HEARTBEAT.name}
ACKS = ("every_tick", "controller_ticks", "none")


class Inputs(dict):
    """Tick k's inputs: topic name -> newest copy with `header.tick <= k` (None: none yet).
    Indexable by topic constant or by name."""

    def __getitem__(self, key):
        return super().__getitem__(key.name if isinstance(key, g.Topic) else key)

    def get(self, key, default=None):
        return super().get(key.name if isinstance(key, g.Topic) else key, default)


class Entry:
    """A node's entry of graph.toml: what it may use and which ticks it acknowledges."""

    def __init__(self, config_dir: Path, name: str):
        path = config_dir / "graph.toml"
        try:
            data = tomllib.loads(path.read_text())
        except (OSError, tomllib.TOMLDecodeError) as e:
            raise AisleError(f"{path}: {e}") from None
        nodes = [n for n in data.get("node", []) if n.get("name") == name]
        if not nodes:
            raise AisleError(f"{path}: no [[node]] named `{name}` (AISLE_NODE)")
        n = nodes[0]
        self.publishes = list(n.get("publishes", []))
        self.subscribes = list(n.get("subscribes", []))
        self.acknowledges = n.get("acknowledges", "none")
        if self.acknowledges not in ACKS:
            raise AisleError(f"{path}: node `{name}`: acknowledges = {self.acknowledges!r} is not one of {ACKS}")
        self.after = [node_code(a) for a in n.get("after", [])]

    def acks(self, tick) -> bool:
        if self.acknowledges == "every_tick":
            return True
        return self.acknowledges == "controller_ticks" and bool(tick.stages & g.STAGE_CONTROLLER)


class Stage:
    """A stage function with `run()`; made by `@aisle.stage`."""

    def __init__(self, fn: Callable):
        self.fn = fn
        self.__doc__ = fn.__doc__

    def __call__(self, tick, inputs):
        return self.fn(tick, inputs)

    def run(self) -> int:
        return run_node(self.fn)


def stage(fn: Callable) -> Stage:
    """Decorator: `@aisle.stage def step(tick, inputs): ...`, then `step.run()`."""
    return Stage(fn)


def _env(name: str) -> str:
    v = os.environ.get(name)
    if not v:
        raise AisleError(f"{name} is not set: run this node from the graph (`command = [...]`) or set it by hand")
    return v


class _Heartbeat(threading.Thread):
    def __init__(self, pub: Publisher, code: int):
        super().__init__(name="aisle-heartbeat", daemon=True)
        self.pub, self.code, self.state = pub, code, g.NodeState.Starting
        self.stop = threading.Event()
        self.failed: Exception | None = None

    def beat(self):
        code, state = self.code, int(self.state)

        def fill(m):
            m.node, m.state, m.pid, m.schema_hash = code, state, os.getpid(), g.SCHEMA_HASH

        self.pub.publish(fill)

    def run(self):
        while not self.stop.is_set():
            try:
                self.beat()
            except Exception as e:  # the main loop sees it and ends the node
                self.failed = e
                return
            self.stop.wait(HEARTBEAT_PERIOD)


class _Runner:
    def __init__(self, fn: Callable, group: Group, entry: Entry, stop: threading.Event):
        self.fn, self.g, self.entry, self.stop = fn, group, entry, stop
        topics = [group.topic(t) for t in entry.subscribes if t not in PROTOCOL_TOPICS and t != "*"]
        self.ticks = group.subscribe(g.TICK)
        self.subs = {t.name: group.subscribe(t) for t in topics}
        self.pubs = {name: group.publisher(name) for name in entry.publishes if name not in PROTOCOL_TOPICS}
        self.dones = group.subscribe(g.TICK_DONE) if entry.after else None
        self.done_pub = group.publisher(g.TICK_DONE)
        self.seen_dones: set[tuple[int, int]] = set()
        self.held: dict[str, list] = {name: [] for name in self.subs}
        self.last_tick: int | None = None

    def next_tick(self):
        while not self.stop.is_set():
            t = self.ticks.receive(timeout=0.1)
            if t is not None:
                newer = self.ticks.latest()  # realtime: act on the newest tick
                return newer if newer is not None else t
        return None

    def wait_after(self, k: int) -> bool:
        need = set(self.entry.after)
        while not self.stop.is_set():
            need -= {n for (tk, n) in self.seen_dones if tk == k}
            if not need:
                self.seen_dones = {(tk, n) for (tk, n) in self.seen_dones if tk > k}
                return True
            d = self.dones.receive(timeout=0.1)
            if d is not None:
                self.seen_dones.add((d.header.tick, d.node))
        return False

    def inputs(self, k: int) -> Inputs:
        out = Inputs()
        for name, sub in self.subs.items():
            held = self.held[name]
            while (m := sub.receive()) is not None:
                held.append(m)
            past = [m for m in held if m.header.tick <= k]
            self.held[name] = ([past[-1]] if past else []) + [m for m in held if m.header.tick > k]
            out[name] = past[-1] if past else None
        return out

    def publish(self, outputs, stamp: Stamp):
        for key, value in (outputs or {}).items():
            name = key.name if isinstance(key, g.Topic) else key
            pub = self.pubs.get(name)
            if pub is None:
                raise AisleError(
                    f"node `{self.g.name}` publishes `{name}`, which its graph entry does not declare "
                    f"(publishes = {self.entry.publishes})"
                )
            if callable(value):
                pub.publish(value, stamp=stamp)
            else:
                pub.publish(stamp=stamp, message=value)

    def acknowledge(self, tick, status: int, compute_ns: int, cpu_ns: int):
        code = self.g.code

        def fill(m):
            m.node, m.status, m.compute_ns, m.cpu_ns = code, status, compute_ns, cpu_ns

        self.done_pub.publish(fill, stamp=Stamp.of(tick.header))

    def step(self, tick) -> None:
        k = tick.header.tick
        if self.entry.after and not self.wait_after(k):
            return
        if k == self.last_tick:  # a repeated tick: acknowledged again, not recomputed
            if self.entry.acks(tick):
                self.acknowledge(tick, g.StageStatus.Done, 0, 0)
            return
        wall0, cpu0 = monotonic_ns(), time.thread_time_ns()
        status = g.StageStatus.Done
        try:
            outputs = self.fn(tick, self.inputs(k))
            self.publish(outputs, Stamp.of(tick.header))
        except Exception:
            status = g.StageStatus.Failed
            raise
        finally:
            self.last_tick = k
            if self.entry.acks(tick):
                self.acknowledge(tick, status, monotonic_ns() - wall0, time.thread_time_ns() - cpu0)


def run_node(fn: Callable) -> int:
    """Runs `fn` as the external node the environment names; returns the exit code (0 on
    SIGTERM/SIGINT, 2 when it cannot run). `fn` raising ends the node (exit 1) after a
    `Failed` acknowledgement, so the supervisor restarts it."""
    logging.basicConfig(level=os.environ.get("AISLE_PY_LOG", "WARNING"), stream=sys.stderr)
    stop = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.set())
    hb = None
    try:
        name = _env("AISLE_NODE")
        try:
            code = int(_env("AISLE_NODE_ID"))
        except ValueError:
            raise AisleError(f"AISLE_NODE_ID={os.environ['AISLE_NODE_ID']!r} is not a decimal node code") from None
        if code != node_code(name):
            raise AisleError(f"AISLE_NODE_ID={code} is not the code of `{name}` ({node_code(name)})")
        config_dir = Path(_env("AISLE_CONFIG_DIR"))
        entry = Entry(config_dir, name)
        group = connect(_env("AISLE_PREFIX"), _env("AISLE_ROOT"), name=name,
                        config_dir=config_dir, timeout=JOIN_TIMEOUT)
        hb = _Heartbeat(group.publisher(g.HEARTBEAT), group.code)
        hb.start()
        runner = _Runner(fn, group, entry, stop)
        hb.state = g.NodeState.Ready
        log.info("%s (node code %#x) ready; restarted=%s", name, code, os.environ.get("AISLE_RESTARTED", "0"))
        while not stop.is_set():
            if hb.failed is not None:
                raise AisleError(f"heartbeat: {hb.failed!r}")
            tick = runner.next_tick()
            if tick is not None:
                runner.step(tick)
        return 0
    except AisleError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    finally:
        if hb is not None:
            hb.stop.set()
