"""Instance discovery: which running aisle instance (iceoryx2 prefix and root) to join.

The rules are the Rust side's (`aisle_bus::discovery`, `run_dir`, `owner`), kept in step:
`AISLE_PREFIX` and `AISLE_ROOT` name one instance and win; otherwise the run directory
(`AISLE_RUN_DIR`, else `<tmp>/aisle-<euid>`, or `/tmp/aisle-<euid>` when that path is
longer than 24 bytes) is scanned for direct subdirectories holding `aisle-instance.toml`
whose `aisle-owner` record (`pid=N start=T`) names a running process; the newest (by the
owner's start time) wins. Knows files, the environment and /proc; not iceoryx2.
"""

from __future__ import annotations

import os
import stat
import tomllib
from dataclasses import dataclass
from pathlib import Path

from .errors import DiscoveryError

INSTANCE_FILE = "aisle-instance.toml"
OWNER_FILE = "aisle-owner"
RUN_DIR_VAR = "AISLE_RUN_DIR"
PREFIX_VAR = "AISLE_PREFIX"
ROOT_VAR = "AISLE_ROOT"
MAX_DEFAULT_LEN = 24
MAX_ROOT_AND_PREFIX = 68
_KEYS = {"prefix", "root", "pid", "mode", "seed", "schema_hash", "config_dir", "by"}
_REQUIRED = _KEYS - {"config_dir"}


@dataclass(frozen=True)
class InstanceRecord:
    """The contents of `aisle-instance.toml`."""

    prefix: str
    root: Path
    pid: int
    mode: str
    seed: int
    schema_hash: int
    by: str
    config_dir: Path | None = None


@dataclass(frozen=True)
class Found:
    """An instance to join; `record` is None when it was named without a discovery file."""

    prefix: str
    root: Path
    record: InstanceRecord | None = None
    owner_start: int = 0


def default_run_dir() -> Path:
    name = f"aisle-{os.geteuid()}"
    tmp = os.environ.get("TMPDIR") or "/tmp"
    t = Path(tmp) / name
    if t.is_absolute() and len(os.fsencode(str(t))) <= MAX_DEFAULT_LEN:
        return t
    return Path("/tmp") / name


def run_dir(environ=os.environ) -> Path:
    """The run directory `AISLE_RUN_DIR` names, else the per-user default."""
    value = environ.get(RUN_DIR_VAR)
    if value is None:
        return default_run_dir()
    if value == "":
        raise DiscoveryError(
            f"{RUN_DIR_VAR} is set but empty; set it to an absolute directory or unset it "
            f"(default {default_run_dir()})"
        )
    if not os.path.isabs(value):
        raise DiscoveryError(
            f"{RUN_DIR_VAR}={value!r} is not an absolute path; set it to an absolute "
            f"directory or unset it (default {default_run_dir()})"
        )
    return Path(value)


def parse_owner(text: str) -> tuple[int, int] | None:
    """(pid, start) of an owner record `pid=N start=T`, or None."""
    fields = dict(f.split("=", 1) for f in text.split() if "=" in f)
    try:
        return int(fields["pid"]), int(fields["start"])
    except (KeyError, ValueError):
        return None


def start_time(pid: int) -> int | None:
    """Field 22 of /proc/<pid>/stat (start time in clock ticks), None for a dead or zombie."""
    try:
        with open(f"/proc/{pid}/stat", encoding="utf-8", errors="replace") as f:
            text = f.read()
    except OSError:
        return None
    rest = text.rsplit(")", 1)[-1].split()
    if not rest or rest[0] in ("Z", "X") or len(rest) < 20:
        return None
    try:
        return int(rest[19])
    except ValueError:
        return None


def live_owner(root: Path) -> int | None:
    """The owner's start time when the process that created `root` still runs."""
    try:
        owner = parse_owner((root / OWNER_FILE).read_text())
    except OSError:
        return None
    if owner is None:
        return None
    pid, start = owner
    return start if start_time(pid) == start else None


def parse_record(text: str, path: Path) -> InstanceRecord:
    """Parses a discovery file; errors name the file and the key."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise DiscoveryError(f"{path}: {e}") from None
    unknown = sorted(set(data) - _KEYS)
    if unknown:
        raise DiscoveryError(f"{path}: unknown key `{unknown[0]}`")
    missing = sorted(_REQUIRED - set(data))
    if missing:
        raise DiscoveryError(f"{path}: missing key `{missing[0]}`")
    for key, kind in (("prefix", str), ("root", str), ("mode", str), ("by", str),
                      ("schema_hash", str), ("pid", int), ("seed", int)):
        if not isinstance(data[key], kind):
            raise DiscoveryError(f"{path}: `{key}` must be a {kind.__name__}")
    h = data["schema_hash"]
    if len(h) != 16 or any(c not in "0123456789abcdefABCDEF" for c in h):
        raise DiscoveryError(f"{path}: `schema_hash` = {h!r} is not 16 hex digits")
    if data["mode"] not in ("lockstep", "realtime"):
        raise DiscoveryError(f"{path}: `mode` = {data['mode']!r} is not lockstep or realtime")
    cd = data.get("config_dir")
    return InstanceRecord(
        prefix=data["prefix"],
        root=Path(data["root"]),
        pid=data["pid"],
        mode=data["mode"],
        seed=data["seed"],
        schema_hash=int(h, 16),
        by=data["by"],
        config_dir=Path(cd) if isinstance(cd, str) else None,
    )


def read_record(root: Path) -> InstanceRecord:
    """The discovery file of the instance rooted at `root`; it must describe that root."""
    path = root / INSTANCE_FILE
    try:
        text = path.read_text()
    except OSError as e:
        raise DiscoveryError(f"{path}: {e.strerror}") from None
    record = parse_record(text, path)
    if record.root != root or root.name != record.prefix:
        raise DiscoveryError(
            f"{path}: describes prefix `{record.prefix}` at {record.root}, not its own directory"
        )
    return record


def list_live(directory: Path) -> tuple[list[Found], list[str]]:
    """Live instances of a run directory, newest first, and unreadable files in words."""
    live, unreadable = [], []
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return live, unreadable
    for e in entries:
        if not e.is_dir(follow_symlinks=False):
            continue
        root = Path(e.path)
        start = live_owner(root)
        if start is None or not (root / INSTANCE_FILE).exists():
            continue
        try:
            r = read_record(root)
        except DiscoveryError as err:
            unreadable.append(str(err))
            continue
        live.append(Found(r.prefix, r.root, r, start))
    live.sort(key=lambda f: (-f.owner_start, f.prefix))
    return live, sorted(unreadable)


def check_instance(prefix: str, root: Path) -> None:
    """The same checks as Rust's `Instance::new` and `check_joinable` on the root."""
    if not (1 <= len(prefix) <= 48) or not all(c.isascii() and (c.isalnum() or c == "_") for c in prefix):
        raise DiscoveryError(f"prefix {prefix!r}: must be 1-48 characters of [A-Za-z0-9_]")
    if not root.is_absolute():
        raise DiscoveryError(f"root {root}: must be an absolute path")
    if len(os.fsencode(str(root))) + len(prefix) > MAX_ROOT_AND_PREFIX:
        raise DiscoveryError(
            f"root {root}: root and prefix together may have {MAX_ROOT_AND_PREFIX} bytes"
        )
    try:
        st = os.lstat(root)
    except OSError as e:
        raise DiscoveryError(f"instance `{prefix}`: {root}: {e.strerror}; is the group running?") from None
    if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.geteuid() or st.st_mode & 0o077:
        raise DiscoveryError(
            f"instance root {root} (owner uid {st.st_uid}, mode {st.st_mode & 0o7777:04o}) "
            "is not a private directory of this user: refused"
        )


def find(prefix: str | None = None, root: str | Path | None = None, environ=os.environ) -> Found:
    """The instance to join: explicit arguments, else `AISLE_PREFIX`/`AISLE_ROOT`, else
    the newest live instance of the run directory (the live one called `prefix`)."""
    if prefix is not None and root is not None:
        found = Found(prefix, Path(root))
    else:
        p, r = environ.get(PREFIX_VAR) or None, environ.get(ROOT_VAR) or None
        if p and r:
            found = Found(p, Path(r))
        elif p or r:
            s, u = (PREFIX_VAR, ROOT_VAR) if p else (ROOT_VAR, PREFIX_VAR)
            raise DiscoveryError(f"{s} is set but {u} is not: set both to name an instance, or neither")
        elif root is not None:
            raise DiscoveryError("root given without prefix: give both, or neither")
        else:
            return _newest(run_dir(environ), prefix)
    check_instance(found.prefix, found.root)
    try:
        record = read_record(found.root)
    except DiscoveryError:
        record = None  # named explicitly: the discovery file is optional
    return Found(found.prefix, found.root, record, found.owner_start)


def _newest(directory: Path, prefix: str | None) -> Found:
    live, unreadable = list_live(directory)
    chosen = live if prefix is None else [f for f in live if f.prefix == prefix]
    if chosen:
        return chosen[0]
    if prefix is not None and live:
        names = ", ".join(f.prefix for f in live)
        raise DiscoveryError(f"no live instance `{prefix}` in {directory}; live: {names}")
    extra = "; unreadable: " + "; ".join(unreadable) if unreadable else ""
    raise DiscoveryError(
        f"no live aisle instance in {directory}: start a group (`aisle run`) or a replay "
        f"(`aisle replay FILE`), or name one with {PREFIX_VAR} and {ROOT_VAR}{extra}"
    )
