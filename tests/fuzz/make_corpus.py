#!/usr/bin/python3
"""Seed corpus and dictionary for the fuzz targets (tests/fuzz/, run by scripts/fuzz).

    make_corpus.py SOURCE_DIR OUT_DIR

OUT_DIR/spec/    every species and dataset file of the repository (species/**, datasets/,
                 bench/, tests/data/**), each relative file reference ("../../sketches/x.png",
                 "tiny.toml") rewritten as "../<path from the repository root>", the form that
                 resolves from the fuzz sandbox's in/spec.toml (spec_input.h)
OUT_DIR/image/   every PNG and SVG a spec can name (species/sketches/, tests/data/)
OUT_DIR/spec.dict   libFuzzer dictionary: every key, table name and word the specs use, and
                    TOML's syntax (numbers at the edges, dates, escapes, table headers)
OUT_DIR/image.dict  PNG's signature and chunk names, SVG's markup and path commands
"""
import os
import re
import sys

SPEC_DIRS = ["species", "datasets", "bench", "tests/data"]
MAX_SPECIES_ENTRIES = 10
STRING = re.compile(r'"((?:[^"\\\n]|\\.)*)"')
KEY = re.compile(r'^\s*\[*\s*([A-Za-z0-9_.\-"]+?)\s*\]*\s*(?:=|$)', re.M)
INLINE_KEY = re.compile(r'[{,]\s*([A-Za-z0-9_\-]+)\s*=')

TOML_TOKENS = [
    "=", "[", "]", "[[", "]]", "{", "}", ",", ".", "\n", "#", '"', "'", '"""', "'''", "\\",
    "\\n", "\\u0000", "\\U0010FFFF", "\\x", "true", "false", "inf", "-inf", "+inf", "nan",
    "-nan", "0", "-0", "-1", "1e308", "-1e308", "1e-308", "4.9e-324", "1.7976931348623157e308",
    "9223372036854775807", "-9223372036854775808", "9223372036854775808", "2147483648",
    "4294967296", "0x7fffffffffffffff", "0o777", "0b1", "1_000", "1979-05-27T07:32:00Z",
    "1979-05-27", "07:32:00", "{uniform = [", "{normal = [", "[0, 0, 0]", "[[0, 0], [1, 1]]",
    "/dev/zero", "/dev/null", "/proc/self/mem", "../", "..", "/",
]
# The image target: PNG signature and chunks, SVG markup and path commands.
IMAGE_TOKENS = [
    r"\x89PNG\x0D\x0A\x1A\x0A", "IHDR", "IDAT", "IEND", "PLTE", "tRNS", "gAMA", "iCCP", "sBIT",
    r"\x00\x00\x00\x0D", r"\xFF\xFF\xFF\xFF", r"\x7F\xFF\xFF\xFF", "<svg", "</svg>", "<path",
    "/>", r" d=\x22", r"\x22", "<g>", "</g>", "transform=", "M", "m", "L", "l", "H", "h", "V", "v",
    "C", "c", "S", "s", "Q", "q", "T", "t", "A", "a", "Z", "z", "1e308", "-1e308", "nan", "inf",
    ".5.5", "1e", "-", ",",
]


def spec_files(src):
    for d in SPEC_DIRS:
        for root, _, files in os.walk(os.path.join(src, d)):
            for f in sorted(files):
                if f.endswith(".toml"):
                    yield os.path.join(root, f)


def rewrite(src, path, text):
    here = os.path.dirname(path)

    def fix(m):
        s = m.group(1)
        if not s or s.startswith("/") or "\\" in s:
            return m.group(0)
        target = os.path.normpath(os.path.join(here, s))
        if not os.path.isfile(target):
            return m.group(0)
        rel = os.path.relpath(target, src)
        if rel.startswith(".."):
            return m.group(0)
        return '"../' + rel + '"'

    return STRING.sub(fix, text)


def main():
    src, out = sys.argv[1], sys.argv[2]
    for sub in ("spec", "image"):
        os.makedirs(os.path.join(out, sub), exist_ok=True)
    words = set()
    n = 0
    for path in spec_files(src):
        # Hostile fixtures hold invalid UTF-8 on purpose: their bytes go through unchanged.
        text = open(path, encoding="utf-8", errors="surrogateescape").read()
        # The gallery and the realism gates list every species: validating them all takes
        # longer than the fuzzer's 10 s limit under the sanitizers, and each species they
        # list is a seed of its own.
        if text.count("[[species]]") > MAX_SPECIES_ENTRIES:
            continue
        rel = os.path.relpath(path, src).replace("/", "__")
        with open(os.path.join(out, "spec", rel), "w", encoding="utf-8",
                  errors="surrogateescape") as f:
            f.write(rewrite(src, path, text))
        n += 1
        for m in KEY.finditer(text):
            for part in m.group(1).strip('"').split("."):
                if part:
                    words.add(part.strip('"'))
        for m in INLINE_KEY.finditer(text):
            words.add(m.group(1))
        for m in STRING.finditer(text):
            s = m.group(1)
            if 0 < len(s) <= 40 and "/" not in s and " " not in s:
                words.add(s)
    images = 0
    for d in ("species/sketches", "tests/data"):
        for root, _, files in os.walk(os.path.join(src, d)):
            for f in sorted(files):
                if f.endswith((".png", ".svg")):
                    data = open(os.path.join(root, f), "rb").read()
                    with open(os.path.join(out, "image", f), "wb") as g:
                        g.write(data)
                    images += 1
    with open(os.path.join(out, "spec.dict"), "w", encoding="utf-8") as f:
        for w in sorted(words) + TOML_TOKENS:
            # libFuzzer's dictionary: printable ASCII, everything else as \xNN.
            esc = "".join(
                chr(b) if 0x20 <= b < 0x7F and chr(b) not in '"\\' else "\\x%02X" % b
                for b in w.encode("utf-8", errors="surrogateescape"))
            f.write('"%s"\n' % esc)
    with open(os.path.join(out, "image.dict"), "w", encoding="utf-8") as f:
        for w in IMAGE_TOKENS:  # already in libFuzzer's escaped form
            f.write('"%s"\n' % w)
    print("corpus: %d spec files, %d images, %d dictionary words" % (n, images, len(words)))


if __name__ == "__main__":
    main()
