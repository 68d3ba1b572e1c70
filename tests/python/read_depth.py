#!/usr/bin/python3
"""Reads depth maps with the readers users have, for tests/pipeline/formats/depth_readers_test.cpp.

Usage: read_depth.py OUT_DIR EXR [PNG]

Reads EXR with OpenCV (cv2.imread(path, cv2.IMREAD_ANYDEPTH), as nerfstudio's
get_depth_image_from_path does) and with OpenImageIO's Python module, and PNG (when given) with
OpenCV as uint16. Writes what each returned, unchanged, as raw little-endian row-major arrays:
OUT_DIR/cv2_exr.f32, OUT_DIR/oiio_exr.f32, OUT_DIR/cv2_png.u16, and OUT_DIR/readers.json with
each reader's dtype, shape and (OpenImageIO) channel names and pixel format. The comparison
with the renderer's buffer is the C++ test's. A missing module is an error (exit 1), never a
skip: `scripts/setup --tests` installs python3-opencv and python3-openimageio.
"""

import json
import os
import sys

import cv2
import numpy as np
import OpenImageIO as oiio


def main():
    out, exr = sys.argv[1], sys.argv[2]
    png = sys.argv[3] if len(sys.argv) > 3 else None
    info = {"opencv_version": cv2.__version__, "oiio_version": oiio.__version__}

    img = cv2.imread(exr, cv2.IMREAD_ANYDEPTH)
    if img is None:
        info["cv2_exr"] = None
    else:
        info["cv2_exr"] = {"dtype": str(img.dtype), "shape": list(img.shape)}
        img.astype("<f4", copy=False).tofile(os.path.join(out, "cv2_exr.f32"))

    inp = oiio.ImageInput.open(exr)
    if inp is None:
        info["oiio_exr"] = None
    else:
        spec = inp.spec()
        data = inp.read_image("float")
        inp.close()
        info["oiio_exr"] = {"channelnames": list(spec.channelnames), "format": str(spec.format),
                            "shape": list(data.shape)}
        np.ascontiguousarray(data, dtype="<f4").tofile(os.path.join(out, "oiio_exr.f32"))

    if png is not None:
        units = cv2.imread(png, cv2.IMREAD_ANYDEPTH)
        if units is None:
            info["cv2_png"] = None
        else:
            info["cv2_png"] = {"dtype": str(units.dtype), "shape": list(units.shape)}
            units.astype("<u2", copy=False).tofile(os.path.join(out, "cv2_png.u16"))

    with open(os.path.join(out, "readers.json"), "w") as f:
        json.dump(info, f)


if __name__ == "__main__":
    main()
