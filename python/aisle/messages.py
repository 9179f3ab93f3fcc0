"""Every message structure, wire enum and capacity (generated from the Rust catalogue)."""

from ._generated import *  # noqa: F401,F403
from ._generated import LAYOUTS, MESSAGES, SCHEMA_HASH, SCHEMA_HASH_HEX  # noqa: F401
