"""The exceptions of meshrad. Every one carries the CLI's message (`str(e)`), and where the
error names them, `path` (the input file), `line` and `key` (the scene, solver or edit key).
"""


class Error(ValueError):
    """Bad input: a malformed scene, an impossible parameter or edit, bad points."""

    path = None
    line = None
    key = None


class FileError(Error, OSError):
    """A file could not be read or written (missing, unreadable, not a regular file)."""


class ResourceError(Error, MemoryError):
    """A run would need more memory than it may plan for (`max_memory`)."""


class DeviceError(Error, RuntimeError):
    """The Vulkan device failed or is missing (backend="gpu")."""
