"""aisle: the Python SDK of the aisle navigation stack.

- `aisle.connect()` joins a running group (discovery, schema check) -> `Group`, whose
  `subscribe(topic)` / `publisher(topic)` are typed ports (`aisle.topics.ROBOT_STATE`, ...).
- `aisle.messages`: every message structure (generated from the Rust catalogue).
- `aisle.numpy.points(msg)`: a point cloud as a NumPy array without copying.
- `@aisle.stage` / `aisle.run_node(fn)`: an external node of the lockstep graph.
"""

from . import messages, topics
from ._generated import SCHEMA_HASH, SCHEMA_HASH_HEX
from .bus import Group, Loan, Publisher, Stamp, Subscriber, View, connect, node_code
from .errors import AisleError, DiscoveryError, SchemaMismatch, Timeout, TopicError
from .stage import Inputs, Stage, run_node, stage

__all__ = [
    "AisleError", "DiscoveryError", "Group", "Inputs", "Loan", "Publisher", "SCHEMA_HASH",
    "SCHEMA_HASH_HEX", "SchemaMismatch", "Stage", "Stamp", "Subscriber", "Timeout",
    "TopicError", "View", "connect", "messages", "node_code", "run_node", "stage", "topics",
]
