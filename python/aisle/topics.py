"""The topic table (generated from the Rust catalogue): `aisle.topics.ROBOT_STATE`, ...
User topics a graph declares (`[[topic]]` in graph.toml) are resolved by name through
`Group.topic()` with `USER_TOPIC_QOS`."""

from . import _generated as _g
from ._generated import (  # noqa: F401
    SERVICE_SETTINGS,
    TOPICS,
    USER_TOPIC_QOS,
    Qos,
    ServiceSettings,
    Topic,
)

globals().update({n: v for n, v in vars(_g).items() if isinstance(v, _g.Topic)})


def by_name(name: str) -> Topic | None:
    """The catalogue topic called `name`, or None."""
    return next((t for t in TOPICS if t.name == name), None)
