"""The tar shards of a packed dataset (``[outputs] pack = "tar"``; docs/outputs.md, "Packed
datasets: tar shards"): WebDataset-style tars in shards/, one sample per instance, its files as
members ``ID.<path in the instance directory with "/" as ".">`` plus ``ID.json`` (its manifest
record without timing), a sample's members contiguous.

Random access (Dataset, Instance): a member's bytes by one seek and one read at the offset the
sidecar ``NNNNNN.index.json`` gives; a sidecar that is missing, or that describes a tar of
another size, is ignored and the tar's own headers are read instead (Python's tarfile).
Streaming (pytorch.ShardDataset): each tar read front to back (tarfile's stream mode), one
sample at a time.
"""

import collections
import glob
import json
import os
import re
import tarfile
import threading

__all__ = ["TarShards", "iter_shard", "member_name", "shard_list", "split_member", "tar_members"]

INDEX_FORMAT = "sylva-tar-index-1"
WIDS_KIND = "wids-shard-index-v1"

# WebDataset's split of a member name into sample key and field: the key is everything before the
# first dot of the file name (ids have no dots), the field the rest ("skeleton.ply").
_MEMBER = re.compile(r"^((?:.*/|)[^./]+)\.([^/]*)$")


def member_name(key, rel_path):
    """The member of an instance's file: "ID" and "views/000.png" → "ID.views.000.png"; its
    record, record.json while the build runs, is "ID.json"."""
    if rel_path == "record.json":
        return key + ".json"
    return key + "." + rel_path.replace(os.sep, "/").replace("/", ".")


def split_member(name):
    """(sample key, field) of a member name: "tiny-p000-00003.views.000.png" → ("tiny-p000-00003",
    "views.000.png"); (None, None) for a name without a dot."""
    m = _MEMBER.match(name)
    return (m.group(1), m.group(2)) if m else (None, None)


def sidecar_path(tar_path):
    """shards/000003.tar → shards/000003.index.json."""
    base = tar_path[:-4] if tar_path.endswith(".tar") else tar_path
    return base + ".index.json"


def tar_members(tar_path):
    """{member name: (data offset, size in bytes)} of a tar shard: from its sidecar index when
    that names this tar and its size, else from the tar's headers."""
    size = os.path.getsize(tar_path)
    try:
        with open(sidecar_path(tar_path)) as f:
            index = json.load(f)
        if (index.get("format") == INDEX_FORMAT and index.get("bytes") == size
                and index.get("tar") == os.path.basename(tar_path)):
            return {name: (offset, length) for sample in index["samples"]
                    for name, offset, length in sample["members"]}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        pass  # missing or unreadable: a cache, so read the headers instead
    with tarfile.open(tar_path, "r:") as tar:
        return {m.name: (m.offset_data, m.size) for m in tar if m.isfile()}


def iter_shard(tar_path):
    """The samples of a tar shard in file order, reading it front to back once (tarfile's stream
    mode): (key, {member name: bytes}) per sample. A key whose members are not contiguous is an
    error (a sylva shard never has one)."""
    key, members, done = None, {}, set()
    with open(tar_path, "rb") as f, tarfile.open(fileobj=f, mode="r|") as tar:
        for m in tar:
            if not m.isfile():
                continue
            k, _ = split_member(m.name)
            if k is None:
                raise ValueError("%s: member %r has no sample key (no dot in its name)"
                                 % (tar_path, m.name))
            if k != key:
                if members:
                    yield key, members
                    done.add(key)
                if k in done:
                    raise ValueError("%s: the members of sample %r are not contiguous (%r)"
                                     % (tar_path, k, m.name))
                key, members = k, {}
            members[m.name] = tar.extractfile(m).read()
    if members:
        yield key, members


def _wids_shards(index_path):
    with open(index_path) as f:
        index = json.load(f)
    if index.get("__kind__") != WIDS_KIND:
        raise ValueError("%s: __kind__ %r, expected %r"
                         % (index_path, index.get("__kind__"), WIDS_KIND))
    base = os.path.dirname(index_path)
    return [(os.path.join(base, s["url"]), s.get("nsamples")) for s in index["shardlist"]]


def shard_list(root):
    """The tar shards of a packed dataset directory: [(path, number of samples or None)], from
    shards/index.json (wids-shard-index-v1); else from a sharded build's
    shards/index.shard-I-of-N.json files, in I order; else every shards/*.tar, by name."""
    shards = os.path.join(root, "shards")
    whole = os.path.join(shards, "index.json")
    if os.path.exists(whole):
        return _wids_shards(whole)
    parts = []
    for path in glob.glob(os.path.join(shards, "index.shard-*-of-*.json")):
        m = re.fullmatch(r"index\.shard-(\d+)-of-(\d+)\.json", os.path.basename(path))
        if m:
            parts.append((int(m.group(1)), path))
    if parts:
        return [s for _, path in sorted(parts) for s in _wids_shards(path)]
    return [(path, None) for path in sorted(glob.glob(os.path.join(shards, "*.tar")))]


class TarShards:
    """Random access to the members of a dataset's tar shards, by (tar path relative to the
    dataset directory, member name). Keeps the member index and an open file of the `max_open`
    tars used last; a tar replaced since (a rerun merged an instance into it) is indexed and
    opened again. A process that did not open a file does not use it: after a fork (a
    DataLoader worker) the child opens its own, as the two would share the file offset; pickled
    (a spawned worker), it carries the indexes and no file. Safe across threads."""

    def __init__(self, root, max_open=64):
        self.root = root
        self.max_open = max_open
        self._pid = os.getpid()
        self._lock = threading.Lock()
        # tar → [members, file or None, (inode, size) indexed], the last used last
        self._open = collections.OrderedDict()

    def _check_process(self):
        """In a forked child: a lock of its own, and no file of the parent's (closing the
        child's descriptors leaves the parent's open)."""
        if self._pid != os.getpid():
            self._pid = os.getpid()
            self._lock = threading.Lock()
            for entry in self._open.values():
                if entry[1] is not None:
                    entry[1].close()
                    entry[1] = None

    def __getstate__(self):
        return {"root": self.root, "max_open": self.max_open,
                "indexes": {tar: (entry[0], entry[2]) for tar, entry in self._open.items()}}

    def __setstate__(self, state):
        self.__init__(state["root"], state["max_open"])
        for tar, (members, stat) in state["indexes"].items():
            self._open[tar] = [members, None, stat]

    def path(self, tar):
        return os.path.join(self.root, tar)

    def _entry(self, tar, name=None):
        """The tar's [members, file, stat]; indexed again when `name` is not a member and the tar
        on disk is another file than the one indexed."""
        entry = self._open.get(tar)
        if entry is not None and name is not None and name not in entry[0]:
            st = os.stat(self.path(tar))
            if (st.st_ino, st.st_size) != entry[2]:
                self._drop(tar)
                entry = None
        if entry is None:
            st = os.stat(self.path(tar))  # FileNotFoundError: not written yet
            entry = self._open[tar] = [tar_members(self.path(tar)), None, (st.st_ino, st.st_size)]
            while len(self._open) > self.max_open:
                self._drop(next(iter(self._open)))
        self._open.move_to_end(tar)
        return entry

    def _drop(self, tar):
        f = self._open.pop(tar)[1]
        if f is not None:
            f.close()

    def members(self, tar):
        """{member name: (data offset, size)} of the tar."""
        self._check_process()
        with self._lock:
            return self._entry(tar)[0]

    def read(self, tar, name):
        """The bytes of member `name` of the tar (KeyError when it has none of that name)."""
        self._check_process()
        with self._lock:
            entry = self._entry(tar, name)
            if name not in entry[0]:
                raise KeyError("%s: no member %r" % (self.path(tar), name))
            offset, size = entry[0][name]
            if entry[1] is None:
                entry[1] = open(self.path(tar), "rb")
            entry[1].seek(offset)
            data = entry[1].read(size)
        if len(data) != size:
            raise ValueError("%s: member %r ends past the end of the file (%d of %d bytes)"
                             % (self.path(tar), name, len(data), size))
        return data

    def close(self):
        """Closes the open tars (a later read reopens them)."""
        self._check_process()
        with self._lock:
            for entry in self._open.values():
                if entry[1] is not None:
                    entry[1].close()
                    entry[1] = None
