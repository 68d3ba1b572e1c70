"""A reader's input: a file path, or the bytes of a file (a tar shard's member, docs/outputs.md,
"Packed datasets: tar shards"), so every reader works on either without a temporary file."""

import os

__all__ = ["read_source"]


def read_source(source, name=None):
    """(data, name): the bytes of `source` — a path (str or os.PathLike) or a bytes-like
    object — and the name error messages give it (`name`, else the path, else "<bytes>")."""
    if isinstance(source, (bytes, bytearray, memoryview)):
        return bytes(source), name or "<bytes>"
    with open(source, "rb") as f:
        return f.read(), name or os.fspath(source)
