#!/usr/bin/python3
"""Colour pictures of a `sylva build` as OpenCV, OpenImageIO and the sylva_dataset package read
them.

Builds tests/data/colour_dataset.toml (RGBA PNGs over a transparent background) and a JPEG
variant over the sky, then for every view:

- OpenCV (cv2.IMREAD_UNCHANGED) and OpenImageIO read the PNG as 8-bit RGBA of the camera's size,
  identical arrays, and the package's rgb() gives the same pixels;
- registration with the mask (views/NNN.png, mask_path): alpha 255 only on tree pixels, alpha
  > 0 on every tree pixel, partial alpha on the mask or next to it; depth > 0 exactly on the mask;
- transforms.json: file_path names the colour picture, mask_path the silhouette, and the frame
  records its sun (a unit vector above the horizon within the spec's elevations) and exposure;
- the tree is coloured as its species: silver birch's sunlit trunk (the brightest tenth of
  its label-1 pixels) is pale (its white bark) and lighter than hawthorn's; leaf pixels (label 255) are green (G > R, G > B);
- the JPEG build (metered over the sky): OpenCV reads 3-channel JPEGs of the same size, the
  exposure is the metering's, and a view from below the crown shows a blue sky along its top.

Usage: test_colour_views.py SYLVA_EXE SOURCE_DIR
A missing module (numpy, cv2, OpenImageIO) is a failure, not a skip.
"""

import json
import os
import shutil
import subprocess
import sys
import tempfile

import cv2
import numpy as np
import OpenImageIO as oiio

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what)


def build(exe, spec, out):
    subprocess.run([exe, "build", spec, "--out", out, "--threads", "2"], check=True,
                   stdout=subprocess.DEVNULL)
    with open(os.path.join(out, "manifest.jsonl")) as f:
        return [json.loads(line) for line in f if line.strip()]


def dilate(mask):
    return cv2.dilate(mask.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0


def main():
    exe, src = sys.argv[1], sys.argv[2]
    sys.path.insert(0, os.path.join(src, "python"))
    import sylva_dataset as sd

    tmp = tempfile.mkdtemp(prefix="sylva-colour-")
    try:
        out = os.path.join(tmp, "png")
        records = build(exe, os.path.join(src, "tests/data/colour_dataset.toml"), out)
        check(len(records) == 2, "two instances built")
        ds = {inst.species: inst for inst in sd.Dataset(out)}
        trunk_lightness = {}
        for rec in records:
            base = os.path.join(out, os.path.dirname(rec["files"]["transforms"]))
            with open(os.path.join(base, "transforms.json")) as f:
                tj = json.load(f)
            package = ds[rec["species"]].rgb()
            check(len(package) == len(tj["frames"]) == 3, "%s: three colour views" % rec["id"])
            trunk = []
            for k, fr in enumerate(tj["frames"]):
                what = "%s view %d" % (rec["id"], k)
                check(fr["file_path"] == "views/%03d_rgb.png" % k, what + ": file_path is colour")
                check(fr["mask_path"] == "views/%03d.png" % k, what + ": mask_path is the mask")
                sun = np.array(fr["sun_direction"], float)
                check(abs(np.linalg.norm(sun) - 1) < 1e-9 and 25 - 1e-9 <= fr["sun_elevation_deg"]
                      <= 65 + 1e-9, what + ": sun direction and elevation")
                check(abs(np.degrees(np.arcsin(sun[1])) - fr["sun_elevation_deg"]) < 1e-6,
                      what + ": elevation matches the direction")
                check(abs(fr["exposure_ev"] - 0.6) < 1e-9 and
                      abs(fr["exposure_scale"] - 2 ** 0.6) < 1e-9, what + ": the fixed exposure")
                path = os.path.join(base, fr["file_path"])
                cv = cv2.imread(path, cv2.IMREAD_UNCHANGED)
                check(cv is not None and cv.shape == (tj["h"], tj["w"], 4) and cv.dtype == np.uint8,
                      what + ": OpenCV reads 8-bit RGBA")
                rgba = cv[:, :, [2, 1, 0, 3]]  # OpenCV's BGRA
                # OpenImageIO premultiplies a PNG's alpha on reading unless told the file's
                # alpha is unassociated (straight), as sylva's is.
                config = oiio.ImageSpec()
                config.attribute("oiio:UnassociatedAlpha", 1)
                buf = oiio.ImageBuf(path, 0, 0, config)
                oi = buf.get_pixels(oiio.UINT8)
                check(buf.spec().nchannels == 4 and np.array_equal(oi, rgba),
                      what + ": OpenImageIO reads the same pixels")
                check(np.array_equal(package[k], rgba), what + ": sylva_dataset.rgb() the same")
                mask = cv2.imread(os.path.join(base, fr["mask_path"]), cv2.IMREAD_UNCHANGED) > 0
                alpha = rgba[:, :, 3]
                check(mask.sum() > 300, what + ": a tree in view")
                check(not np.any((alpha == 255) & ~mask), what + ": alpha 255 only on the mask")
                check(np.all(alpha[mask] > 0), what + ": every mask pixel has alpha > 0")
                partial = (alpha > 0) & (alpha < 255)
                check(partial.sum() > 20 and not np.any(partial & ~dilate(mask)),
                      what + ": partial alpha on the mask's edge")
                depth = cv2.imread(os.path.join(base, fr["depth_file_path"]), cv2.IMREAD_ANYDEPTH)
                check(np.array_equal(depth > 0, mask), what + ": depth on the mask")
                labels = cv2.imread(os.path.join(base, fr["label_file_path"]),
                                    cv2.IMREAD_UNCHANGED)
                full = alpha == 255
                leaf = full & (labels == 255)
                if leaf.sum() > 50:
                    g = rgba[leaf].astype(float).mean(axis=0)
                    check(g[1] > g[0] and g[1] > g[2], what + ": leaves are green %s" % g[:3])
                stem = full & (labels == 1)
                trunk.append(rgba[stem][:, :3].astype(float))
            pixels = np.concatenate(trunk)
            check(len(pixels) > 30, rec["id"] + ": trunk pixels in view")
            # The sunlit side: the brightest tenth of the trunk's pixels.
            trunk_lightness[rec["species"]] = np.percentile(pixels.mean(axis=1), 90)
        print("trunk value, 90th percentile (sRGB 0-255):", trunk_lightness)
        check(trunk_lightness.get("silver-birch", 0) > 140,
              "silver birch's trunk is pale: %s" % trunk_lightness)
        check(trunk_lightness.get("silver-birch", 0) > trunk_lightness.get("hawthorn", 255) + 30,
              "birch's bark lighter than hawthorn's: %s" % trunk_lightness)

        # JPEG over the sky.
        with open(os.path.join(src, "tests/data/colour_dataset.toml")) as f:
            spec = f.read().replace("colour = true", 'colour = true\ncolour_background = "sky"\n'
                                    'colour_format = "jpg"')
        spec = spec.replace("colour_auto_exposure = false", "colour_auto_exposure = true")
        jspec = os.path.join(tmp, "colour_jpg.toml")
        with open(jspec, "w") as f:
            f.write(spec.replace("../../species", os.path.join(os.path.abspath(src), "species")))
        jout = os.path.join(tmp, "jpg")
        for rec in build(exe, jspec, jout):
            base = os.path.join(jout, os.path.dirname(rec["files"]["transforms"]))
            with open(os.path.join(base, "transforms.json")) as f:
                tj = json.load(f)
            for k, fr in enumerate(tj["frames"]):
                what = "%s jpg view %d" % (rec["id"], k)
                check(fr["file_path"] == "views/%03d_rgb.jpg" % k, what + ": file_path")
                check(fr["exposure_scale"] > 0 and
                      abs(fr["exposure_scale"] - 2 ** fr["exposure_ev"]) > 1e-6,
                      what + ": metered (the scale is not the EV's alone)")
                img = cv2.imread(os.path.join(base, fr["file_path"]), cv2.IMREAD_UNCHANGED)
                check(img is not None and img.shape == (tj["h"], tj["w"], 3), what + ": RGB JPEG")
                if fr["elevation_deg"] < 0:  # looking up: sky along the top rows
                    top = img[:8].reshape(-1, 3).astype(float).mean(axis=0)  # BGR
                    check(top[0] > top[2] + 20, what + ": the sky above is blue %s" % top)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if failures:
        print("%d failure(s)" % len(failures))
        sys.exit(1)
    print("colour views: OK")


if __name__ == "__main__":
    main()
