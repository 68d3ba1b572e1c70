"""LAS 1.4 reader (point formats 6, 7 and 8, with Extra Bytes): sylva's scans (docs/scanning.md).

Reads the header, the VLRs and the point records with numpy alone, and decodes every field the
Extra Bytes VLR (user id "LASF_Spec", record 4) declares, so a scan's ``treeID``,
``semantic_seg``, ``node_id``… come back as named arrays. Coordinates are the LAS frame (x east,
y north, z up), scaled and offset as the header says.
"""

import struct

import numpy as np

from .source import read_source

__all__ = ["read_las", "LasFile"]

# LAS 1.4 R15, Table 24: Extra Bytes data types 1–10 (0 = undocumented bytes, `options` long).
_EXTRA_TYPES = {1: "u1", 2: "i1", 3: "u2", 4: "i2", 5: "u4", 6: "i4", 7: "u8", 8: "i8",
                9: "f4", 10: "f8"}

# The base record of point formats 6–8 (LAS 1.4 R15, Tables 7–9).
_BASE_6 = [("X", "<i4"), ("Y", "<i4"), ("Z", "<i4"), ("intensity", "<u2"), ("returns", "u1"),
           ("flags", "u1"), ("classification", "u1"), ("user_data", "u1"),
           ("scan_angle", "<i2"), ("point_source_id", "<u2"), ("gps_time", "<f8")]
_BASE = {6: _BASE_6,
         7: _BASE_6 + [("red", "<u2"), ("green", "<u2"), ("blue", "<u2")],
         8: _BASE_6 + [("red", "<u2"), ("green", "<u2"), ("blue", "<u2"), ("nir", "<u2")]}


class LasFile:
    """A read LAS file.

    header     dict: version, point_format, record_length, point_count, points_by_return (15),
               scale (3), offset (3), min (3), max (3), global_encoding, system_identifier,
               generating_software, creation_day, creation_year, vlrs (list of (user id, record
               id, description, payload bytes))
    positions  (P, 3) float64, metres, LAS frame
    fields     dict of (P,) arrays: intensity, return_number, number_of_returns,
               classification_flags, scanner_channel, scan_direction, edge_of_flight_line,
               classification, user_data, scan_angle_deg, point_source_id, gps_time, [red, green,
               blue, nir], and every Extra Bytes field by its name (scaled when it has a scale)
    extra      the Extra Bytes descriptors: list of dicts (name, data_type, options, scale,
               offset, description)
    """

    def __init__(self, header, positions, fields, extra):
        self.header, self.positions, self.fields, self.extra = header, positions, fields, extra

    def __getitem__(self, name):
        return self.fields[name]


def _text(b):
    return b.split(b"\0", 1)[0].decode("ascii", "replace")


def _extra_descriptors(payload):
    out = []
    for k in range(len(payload) // 192):
        d = payload[192 * k:192 * (k + 1)]
        data_type, options = d[2], d[3]
        name = _text(d[4:36])
        scale = struct.unpack_from("<3d", d, 112)
        offset = struct.unpack_from("<3d", d, 136)
        out.append({"name": name, "data_type": data_type, "options": options,
                    "scale": scale[0] if options & 8 else None,
                    "offset": offset[0] if options & 16 else None,
                    "description": _text(d[160:192])})
    return out


def read_las(source, name=None):
    """Reads a LAS 1.4 file of point format 6, 7 or 8 (see LasFile). source: a path or the
    file's bytes; name: what error messages call it."""
    data, path = read_source(source, name)
    if len(data) < 375 or data[:4] != b"LASF":
        raise ValueError("%s: not a LAS file" % path)
    major, minor = data[24], data[25]
    if (major, minor) != (1, 4):
        raise ValueError("%s: LAS %d.%d, expected 1.4" % (path, major, minor))
    h = {"version": "%d.%d" % (major, minor)}
    h["global_encoding"] = struct.unpack_from("<H", data, 6)[0]
    h["system_identifier"] = _text(data[26:58])
    h["generating_software"] = _text(data[58:90])
    h["creation_day"], h["creation_year"], h["header_size"] = struct.unpack_from("<HHH", data, 90)
    offset_to_points, vlr_count = struct.unpack_from("<II", data, 96)
    h["point_format"] = data[104] & 0x3F  # bits 6–7: compression (LAZ), not read here
    h["record_length"] = struct.unpack_from("<H", data, 105)[0]
    h["scale"] = struct.unpack_from("<3d", data, 131)
    h["offset"] = struct.unpack_from("<3d", data, 155)
    mx = struct.unpack_from("<6d", data, 179)  # max x, min x, max y, min y, max z, min z
    h["max"], h["min"] = (mx[0], mx[2], mx[4]), (mx[1], mx[3], mx[5])
    h["point_count"] = struct.unpack_from("<Q", data, 247)[0]
    h["points_by_return"] = struct.unpack_from("<15Q", data, 255)
    if h["point_format"] not in _BASE:
        raise ValueError("%s: point format %d, expected 6, 7 or 8" % (path, h["point_format"]))

    vlrs, extra, pos = [], [], h["header_size"]
    for _ in range(vlr_count):
        user, record, length = _text(data[pos + 2:pos + 18]), *struct.unpack_from("<HH", data, pos + 18)
        payload = data[pos + 54:pos + 54 + length]
        vlrs.append((user, record, _text(data[pos + 22:pos + 54]), payload))
        if user == "LASF_Spec" and record == 4:
            extra = _extra_descriptors(payload)
        pos += 54 + length
    h["vlrs"] = vlrs

    dtype = list(_BASE[h["point_format"]])
    for k, d in enumerate(extra):
        if d["data_type"] == 0:
            dtype.append(("_undocumented%d" % k, "V%d" % d["options"]))
        elif d["data_type"] in _EXTRA_TYPES:
            dtype.append((d["name"], "<" + _EXTRA_TYPES[d["data_type"]]))
        else:
            raise ValueError("%s: extra bytes %r: data type %d (deprecated arrays) not read"
                             % (path, d["name"], d["data_type"]))
    dt = np.dtype(dtype)
    if dt.itemsize > h["record_length"]:
        raise ValueError("%s: records of %d bytes, the fields need %d"
                         % (path, h["record_length"], dt.itemsize))
    if dt.itemsize < h["record_length"]:  # undeclared trailing bytes
        dt = np.dtype({"names": dt.names, "formats": [dt.fields[n][0] for n in dt.names],
                       "offsets": [dt.fields[n][1] for n in dt.names],
                       "itemsize": h["record_length"]})
    n = h["point_count"]
    end = offset_to_points + n * h["record_length"]
    if end > len(data):
        raise ValueError("%s: %d points need %d bytes, the file has %d" % (path, n, end, len(data)))
    rec = np.frombuffer(data, dtype=dt, count=n, offset=offset_to_points)

    scale, off = np.array(h["scale"]), np.array(h["offset"])
    positions = np.stack([rec["X"], rec["Y"], rec["Z"]], axis=1).astype(np.float64) * scale + off
    r, fl = rec["returns"], rec["flags"]
    fields = {
        "intensity": rec["intensity"].astype(np.int64),
        "return_number": (r & 0x0F).astype(np.int64),
        "number_of_returns": (r >> 4).astype(np.int64),
        "classification_flags": (fl & 0x0F).astype(np.int64),
        "scanner_channel": ((fl >> 4) & 0x03).astype(np.int64),
        "scan_direction": ((fl >> 6) & 1).astype(np.int64),
        "edge_of_flight_line": ((fl >> 7) & 1).astype(np.int64),
        "classification": rec["classification"].astype(np.int64),
        "user_data": rec["user_data"].astype(np.int64),
        "scan_angle_deg": rec["scan_angle"].astype(np.float64) * 0.006,
        "point_source_id": rec["point_source_id"].astype(np.int64),
        "gps_time": rec["gps_time"].astype(np.float64),
    }
    for c in ("red", "green", "blue", "nir"):
        if c in rec.dtype.names:
            fields[c] = rec[c].astype(np.int64)
    for d in extra:
        if d["data_type"] == 0:
            continue
        v = np.ascontiguousarray(rec[d["name"]])
        if d["scale"] is not None or d["offset"] is not None:
            v = v.astype(np.float64) * (d["scale"] or 1.0) + (d["offset"] or 0.0)
        elif v.dtype.kind in "iu":
            v = v.astype(np.int64)
        fields[d["name"]] = v
    return LasFile(h, positions, fields, extra)
