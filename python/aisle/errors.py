"""The errors of the aisle SDK: each names the file, variable, topic or value at fault."""


class AisleError(Exception):
    """Base of every error the SDK raises on purpose."""


class DiscoveryError(AisleError):
    """No instance was found, or the one named cannot be used."""


class SchemaMismatch(AisleError):
    """The running instance was built from another message catalogue."""


class TopicError(AisleError):
    """A topic name that neither the catalogue nor the graph declares, or a port refused."""


class Timeout(AisleError):
    """A wait ended without what it waited for."""
