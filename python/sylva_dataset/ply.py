"""Binary PLY reader (little- and big-endian): sylva's skeletons, meshes and point clouds."""

import numpy as np

from .source import read_source

__all__ = ["read_ply"]


_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


def _ply_header(data):
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise ValueError("not a PLY file")
    body = data.index(b"\n", end) + 1
    fmt, elements = None, []
    for line in data[:end].decode("ascii").splitlines():
        w = line.split()
        if not w or w[0] in ("ply", "comment", "obj_info"):
            continue
        if w[0] == "format":
            fmt = w[1]
        elif w[0] == "element":
            elements.append((w[1], int(w[2]), []))
        elif w[0] == "property":
            if w[1] == "list":
                elements[-1][2].append((w[4], ("list", _PLY_TYPES[w[2]], _PLY_TYPES[w[3]])))
            else:
                elements[-1][2].append((w[2], _PLY_TYPES[w[1]]))
    if fmt not in ("binary_little_endian", "binary_big_endian"):
        raise ValueError("PLY format %r: only binary PLY is supported" % fmt)
    return ("<" if fmt == "binary_little_endian" else ">"), elements, body


def read_ply(source, name=None):
    """Reads a binary PLY file into {element name: numpy structured array}. source: a path or
    the file's bytes; name: what error messages call it."""
    data, path = read_source(source, name)
    try:
        bo, elements, pos = _ply_header(data)
    except ValueError as e:
        raise ValueError("%s: %s" % (path, e)) from None
    out = {}
    for name, count, props in elements:
        lists = [p for p in props if isinstance(p[1], tuple)]
        if not lists:
            dt = np.dtype([(p, bo + t) for p, t in props])
            out[name] = np.frombuffer(data, dt, count, pos).copy()
            pos += dt.itemsize * count
            continue
        # Fast path: every row's lists have the count of the first row.
        first = {}
        off = pos
        fields = []
        for p, t in props:
            if isinstance(t, tuple):
                ct = np.dtype(bo + t[1])
                n = int(np.frombuffer(data, ct, 1, off)[0]) if count else 0
                first[p] = n
                fields += [(p + "__count", bo + t[1]), (p, bo + t[2], (n,))]
                off += ct.itemsize + n * np.dtype(t[2]).itemsize
            else:
                fields.append((p, bo + t))
                off += np.dtype(t).itemsize
        dt = np.dtype(fields)
        if count == 0 or pos + dt.itemsize * count <= len(data):
            arr = np.frombuffer(data, dt, count, pos) if count else np.zeros(0, dt)
            if all((arr[p + "__count"] == n).all() for p, n in first.items()):
                out[name] = arr.copy()
                pos += dt.itemsize * count
                continue
        # General path: row by row, lists as object arrays.
        rows = []
        for _ in range(count):
            row = []
            for p, t in props:
                if isinstance(t, tuple):
                    ct, it = np.dtype(bo + t[1]), np.dtype(bo + t[2])
                    n = int(np.frombuffer(data, ct, 1, pos)[0])
                    pos += ct.itemsize
                    row.append(np.frombuffer(data, it, n, pos).copy())
                    pos += n * it.itemsize
                else:
                    d = np.dtype(bo + t)
                    row.append(np.frombuffer(data, d, 1, pos)[0])
                    pos += d.itemsize
            rows.append(tuple(row))
        dt = np.dtype([(p, object if isinstance(t, tuple) else bo + t) for p, t in props])
        arr = np.empty(count, dt)
        for i, r in enumerate(rows):
            arr[i] = r
        out[name] = arr
    return out
