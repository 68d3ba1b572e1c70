#!/usr/bin/env python3
"""Per-species allometry of the species library from the Biomass And Allometry Database (BAAD).

A recipe, not run in CI: it writes species/reference/baad-allometry.json (numbers only) and,
with --markdown, the tables of species/reference/README.md ("Allometry: BAAD").

BAAD (Falster, D. S. et al. 2015, BAAD: a Biomass And Allometry Database for woody plants,
Ecology 96:1445, doi:10.1890/14-1889.1; data CC0, code BSD 2-clause) is not in this repository.
Bring its source repository here (GitHub dfalster/baad, the version this file was made from is
commit e8bb28d6a17e2f311130df6963fd3f28221088cb of 2017-08-07), either as a clone or a bare git
directory, and give its path:

    git clone https://github.com/dfalster/baad.git BAAD     # or any copy of its git directory
    /usr/bin/python3 scripts/reference_from_baad.py BAAD \\
        --out species/reference/baad-allometry.json --markdown TABLES.md

Needs numpy only (Debian: python3-numpy). A git directory without a work tree is read with
`git archive HEAD data config` into a temporary directory; the commit recorded in the output is
`git rev-parse HEAD` (or --commit).

The repository holds no compiled table (the releases do, as baad_data.csv); it holds each
study's raw data (data/<study>/data.csv) and the R workflow (R/steps.R, R/post_process.R) that
compiles them. This script re-implements that workflow in Python, per study:
  1. read data.csv as dataImportOptions.csv says (skip, na.strings; fields stripped; a column
     is numeric when all its values parse as numbers, as R's read.csv);
  2. the study's dataManipulate.R, ported below (MANIPULATE) where it changes rows, species or
     the variables read here (heights, diameters, crown size, leaf area and what leaf area is
     derived from); manipulations of masses, nitrogen and grouping only are left out;
  3. dataMatchColumns.csv: rename var_in to var_out, convert units to those of
     config/variableDefinitions.csv with config/variableConversion.csv;
  4. dataNew.csv: set newVariable to newValue where lookupVariable == lookupValue (everywhere
     when lookupVariable is empty);
  5. numeric variables as numbers (non-numbers become missing), then R/post_process.R's derived
     variables: h.c = h.t - c.d and c.d = h.t - h.c where missing, d.bh / d.ba from the stem
     areas a.stbh / a.stba, d.cr from the crown area a.cp (d.cr = 2 sqrt(a.cp / pi)), a.lf =
     m.lf / ma.ilf; and the species name matched by config/taxon_updates.csv (speciesMatched).

BAAD's variables used (config/variableDefinitions.csv): h.t height (m), d.bh stem diameter at
breast height (m), d.ba at the base (m), d.cr crown width / diameter (m), a.cp projected crown
area (m2), c.d crown DEPTH (m; not the crown diameter), h.c height to crown base (m), a.lf leaf
area (m2), growingCondition (FW field wild, FE field experimental, PM / PU plantation managed /
unmanaged, CG common garden, GH glasshouse, GC growth chamber), location, studyName.

What it computes, per species of the library (LIBRARY below) that BAAD has, and for the genus
(every species of it in BAAD, pooled) where the species is absent: over individuals with
h.t >= MIN_HEIGHT m grown in the field, in plantations or common gardens (GH and GC dropped):
  n, studies (BAAD study names), locations;
  quantiles (p5, p25, p50, p75, p95, min, max; numpy's linear / R type 7) of
    height_m            h.t
    crown_diameter_ratio  d.cr / h.t
    crown_depth_ratio     c.d / h.t (crown length over height; c.d = h.t - h.c where missing)
    dbh_m               d.bh
    leaf_area_m2        a.lf
  each over the individuals that have it (its own n);
  crown_diameter_power_law: d.cr = a h.t^b by least squares of log d.cr on log h.t, with n,
    the residual sd (natural-log units, n - 2 degrees of freedom) and the height range, where
    >= MIN_FIT individuals have both.
Each individual weighs 1 (studies with many trees weigh more).
"""
import argparse
import csv
import json
import math
import os
import re
import subprocess
import sys
import tempfile

import numpy as np

MIN_HEIGHT = 2.0  # m: individuals shorter than this are left out
MIN_FIT = 10  # individuals with height and crown diameter needed for the power law
KEEP_CONDITIONS = ("FW", "FE", "PM", "PU", "CG")  # field, plantation, common garden
QUANTILES = (("p5", 0.05), ("p25", 0.25), ("p50", 0.5), ("p75", 0.75), ("p95", 0.95))

# The library (species/presets/*.toml, the Latin name in each file's first comment lines):
# preset -> (Latin binomial, other names BAAD might use).
LIBRARY = [
    ("apple", "Malus domestica", ["Malus pumila"]),
    ("areca-palm", "Areca catechu", []),
    ("ashoka", "Polyalthia longifolia", ["Monoon longifolium"]),
    ("aspen", "Populus tremuloides", []),
    ("bakul", "Mimusops elengi", []),
    ("bamboo", "Dendrocalamus strictus", []),
    ("banyan", "Ficus benghalensis", []),
    ("cedar-of-lebanon", "Cedrus libani", []),
    ("coconut-palm", "Cocos nucifera", []),
    ("douglas-fir", "Pseudotsuga menziesii", []),
    ("european-ash", "Fraxinus excelsior", []),
    ("european-beech", "Fagus sylvatica", []),
    ("european-larch", "Larix decidua", []),
    ("gulmohar", "Delonix regia", []),
    ("hawthorn", "Crataegus monogyna", []),
    ("horse-chestnut", "Aesculus hippocastanum", []),
    ("italian-cypress", "Cupressus sempervirens", []),
    ("kadamb", "Neolamarckia cadamba", ["Anthocephalus cadamba", "Anthocephalus chinensis"]),
    ("lemon", "Citrus limon", []),
    ("lombardy-poplar", "Populus nigra", []),
    ("mango", "Mangifera indica", []),
    ("neem", "Azadirachta indica", []),
    ("norway-maple", "Acer platanoides", []),
    ("norway-spruce", "Picea abies", []),
    ("olive", "Olea europaea", []),
    ("pedunculate-oak", "Quercus robur", []),
    ("peepal", "Ficus religiosa", []),
    ("sal", "Shorea robusta", []),
    ("scots-pine", "Pinus sylvestris", []),
    ("silver-birch", "Betula pendula", []),
    ("silver-fir", "Abies alba", []),
    ("small-leaved-lime", "Tilia cordata", []),
    ("stone-pine", "Pinus pinea", []),
    ("umbrella-thorn", "Vachellia tortilis", ["Acacia tortilis"]),
    ("weeping-willow", "Salix babylonica", []),
    ("wych-elm", "Ulmus glabra", []),
]

NUM_RE = re.compile(r"^[+-]?((\d+\.?\d*|\.\d+)([eE][+-]?\d+)?|Inf|NaN)$")


def is_num(x):
    return isinstance(x, float) or (isinstance(x, str) and bool(NUM_RE.match(x)))


def to_num(x):
    if x is None:
        return None
    if isinstance(x, float):
        return x
    return float(x) if NUM_RE.match(x) else None


def r_str(x):
    """A value as R's as.character would print it (numbers with 15 significant digits)."""
    if isinstance(x, float):
        return ("%.15g" % x) if math.isfinite(x) else ("NaN" if x != x else
                                                       ("Inf" if x > 0 else "-Inf"))
    return x


class Frame:
    """A data frame as ordered columns [name, values]; values are None (NA), float or str."""

    def __init__(self, cols, n):
        self.cols = cols
        self.n = n

    def names(self):
        return [c[0] for c in self.cols]

    def has(self, name):
        return any(c[0] == name for c in self.cols)

    def get(self, name):
        for c in self.cols:
            if c[0] == name:
                return c[1]
        return None

    def num(self, name):
        v = self.get(name)
        return [None] * self.n if v is None else [to_num(x) for x in v]

    def set(self, name, values):
        values = list(values)
        assert len(values) == self.n
        for c in self.cols:
            if c[0] == name:
                c[1] = values
                return
        self.cols.append([name, values])

    def drop(self, name):
        self.cols = [c for c in self.cols if c[0] != name]

    def rename(self, old, new):
        for c in self.cols:
            if c[0] == old:
                c[0] = new
                return

    def keep(self, mask):
        for c in self.cols:
            c[1] = [x for x, m in zip(c[1], mask) if m]
        self.n = sum(1 for m in mask if m)

    def set_where(self, name, mask, value):
        """x[mask] <- value; an NA in the mask selects nothing (R, for a single value)."""
        v = list(self.get(name))
        for i, m in enumerate(mask):
            if m:
                v[i] = value(i) if callable(value) else value
        self.set(name, v)


def read_csv_r(path, header=True, skip=0, na_strings=("NA",)):
    """R's read.csv(strip.white=TRUE, check.names=FALSE, stringsAsFactors=FALSE)."""
    with open(path, newline="", encoding="utf-8", errors="replace") as f:
        rows = list(csv.reader(f))
    rows = rows[skip:]
    rows = [r for r in rows if any(c.strip() for c in r)]  # blank lines are skipped
    if header:
        names, body = [c.strip() for c in rows[0]], rows[1:]
    else:
        body = rows
        names = ["V%d" % (j + 1) for j in range(max(len(r) for r in rows))]
    cols = []
    for j, name in enumerate(names):
        vals = [(r[j].strip() if j < len(r) else "") for r in body]
        vals = [None if v in na_strings else v for v in vals]
        if all(v is None or v == "" or is_num(v) for v in vals):
            vals = [None if (v is None or v == "") else float(v) for v in vals]
        cols.append([name, vals])
    return Frame(cols, len(body))


def mask_cmp(values, f):
    return [None if x is None else bool(f(x)) for x in values]


def arith(f, *cols):
    return [None if any(x is None for x in xs) else f(*xs) for xs in zip(*cols)]


# ---- dataManipulate.R, ported (only what changes rows, species or the variables used here) --

def m_paste_genus(genus, species):
    def f(raw):
        raw.set(species, [("%s %s" % (r_str(g) if g is not None else "NA",
                                      r_str(s) if s is not None else "NA"))
                          for g, s in zip(raw.get(genus), raw.get(species))])
    return f


def m_aiba2007(raw):
    m_paste_genus("genus", "species")(raw)
    ch, h = raw.num("crown height (cm)"), raw.num("height (cm)")
    raw.set_where("crown height (cm)", arith(lambda a, b: a > b, ch, h), None)


def m_albrektson1984(raw):
    raw.drop("a.cs")
    raw.set("h.c", arith(lambda t, c: t - c, raw.num("h.t"), raw.num("h.c")))


def m_bondlamberty2002(raw):
    raw.set_where("DBH", mask_cmp(raw.num("Height"), lambda h: h < 137), None)


def m_wrong_species_hc(raw):
    """Brown1978, Garber2005, Kantola2004, Maguire1998, Monserud1999: the code column
    'species' is set aside (the Latin name is in 'sp'); h_c is given as crown length."""
    raw.rename("species", "wrong.sp")
    raw.set("h_c", arith(lambda t, c: t - c, raw.num("h_t"), raw.num("h_c")))


def m_brown1978(raw):
    m_wrong_species_hc(raw)
    raw.set_where("dbh", mask_cmp(raw.num("dbh"), lambda x: x == 0), None)
    raw.set_where("a_st", mask_cmp(raw.num("a_st"), lambda x: x == 0), None)


def m_maguire1998(raw):
    m_wrong_species_hc(raw)
    raw.set("a_lf", arith(lambda a: a / (2 * 1.18), raw.num("a_lf")))


def m_claveau2002(raw):
    raw.set_where("c.d", mask_cmp(raw.num("c.d"), lambda x: x == 0), None)
    cd, ht = raw.num("c.d"), raw.num("h.t")
    ii = [c is not None and t is not None and c > t for c, t in zip(cd, ht)]
    raw.set_where("c.d", ii, lambda i: ht[i])
    raw.set_where("h.c", ii, 0.0)


def m_coll2008(raw):
    ilm = raw.get("individual.leaf.mass.g")
    sla = raw.num("specific.leaf.area.cm2/g")
    sp = raw.get("species")
    acc = {}
    for m, s, x in zip(ilm, sp, sla):
        if m is not None and x is not None:
            acc.setdefault(s, []).append(x)
    mean_sla = {s: sum(v) / len(v) for s, v in acc.items()}
    raw.keep([m is None and s in mean_sla for m, s in zip(ilm, sp)])
    raw.set("sla", [mean_sla[s] for s in raw.get("species")])
    raw.set("stem.biomass.g", arith(lambda a, b: a + b, raw.num("branch.biomass.g"),
                                    raw.num("trunk.biomass.g")))
    raw.set("ma.ilf", [1.0 / x for x in raw.get("sla")])


def m_delagrange0000a(raw):
    raw.set_where("a.lf", mask_cmp(raw.num("a.lf"), lambda x: x == 0), None)
    hc, ht = raw.num("h.c"), raw.num("h.t")
    raw.set_where("h.c", arith(lambda c, t: c >= t, hc, ht), None)


def m_delagrange0000b(raw):
    raw.set_where("a.lf", mask_cmp(raw.num("a.lf"), lambda x: x == 0), None)
    raw.set_where("diameter", mask_cmp(raw.num("diameter"), lambda x: x == 0), None)
    raw.set("h.c", arith(lambda t, c: t - c, raw.num("h.t"), raw.num("h.c")))
    hc, ht = raw.num("h.c"), raw.num("h.t")
    raw.set_where("h.c", arith(lambda c, t: c > t, hc, ht), None)
    raw.set_where("h.c", mask_cmp(raw.num("h.c"), lambda c: c < 0), None)


def m_delagrange2004(raw):
    hc, ht = raw.num("h.c"), raw.num("h.t")
    raw.set_where("h.c", arith(lambda c, t: c > t, hc, ht), None)


def m_drop_species(names):
    def f(raw):
        raw.keep([s not in names for s in raw.get("species")])
    return f


def m_ikushima1964(raw):
    raw.set_where("a.lf", mask_cmp(raw.num("a.lf"), lambda x: x == 0), None)
    raw.set_where("m.lf", mask_cmp(raw.num("m.lf"), lambda x: x == 0), None)


def m_kenzo2009(raw):
    raw.set_where("a.stbh.cm", mask_cmp(raw.num("h.t.m"), lambda h: h <= 1.3), None)


def m_lusk(raw):
    raw.set("h.c", arith(lambda t, c: t - c, raw.num("h.t"), raw.num("h.c")))
    raw.set_where("h.c", mask_cmp(raw.num("h.c"), lambda c: c < 0), 0.0)


def m_mcculloh2010(raw):
    raw.keep([s == "LowerTrunk" for s in raw.get("sample")])


def m_ohara1995(raw):
    raw.set("dbh", arith(lambda d: d * 2.54, raw.num("dbh")))


def m_osunkoya2007(raw):
    for c in raw.cols:
        c[1] = [None if x == "#NULL!" else x for x in c[1]]
    raw.set_where("crown_sil_area", [x in ("0", "", 0.0) for x in raw.get("crown_sil_area")],
                  None)


def m_petritan2009(raw):
    i = arith(lambda t, c: t - c == 0, raw.num("Total.height.of.plant..cm."),
              raw.num("Height.to.crown.base..cm."))
    raw.set_where("Height.to.crown.base..cm.", i, None)
    raw.set_where("Crown.lenght..cm.", i, None)


def m_reid2004(raw):
    for c in raw.cols:
        c[1] = [None if x == "#N/A" else x for x in c[1]]
    raw.set_where("growingCondition", [x == "?" for x in raw.get("growingCondition")], "FW")
    raw.drop("a.cs")
    raw.drop("a.cp")


def m_roberts2004(raw):
    raw.set("cw", arith(lambda a, b: (a + b) / 2, raw.num("CW1"), raw.num("CW2")))


def m_saldanaacosta2009(raw):
    raw.keep([x is not None and x > 0 for x in raw.num("Final height (cm)")])


def m_vanninen2005(raw):
    raw.set("hcb", arith(lambda t, c: t - c, raw.num("tree height CM"),
                         raw.num("crown length cm")))


def m_wang2011(raw):
    raw.keep([x is not None and x > 0.01 for x in raw.num("Total leaf dry mass (g)")])


def m_zero_na(name):
    def f(raw):
        raw.set_where(name, mask_cmp(raw.num(name), lambda x: x == 0), None)
    return f


def m_baltzer2007(raw):
    raw.set_where("lma (g cm-2)", mask_cmp(raw.num("lma (g cm-2)"), lambda x: x == 0.3498),
                  0.003498)


def m_portsmuth2006(raw):
    k = "Leaf mass per area :LMA*100 g cm-2"
    raw.set(k, arith(lambda x: x / 100, raw.num(k)))


def m_ximenes2004(raw, study_dir):
    raw2 = read_csv_r(os.path.join(study_dir, "data2.csv"))
    key = ("Tree No", "Site", "Species")
    index = {}
    for i in range(raw2.n):
        index.setdefault(tuple(r_str(raw2.get(k)[i]) for k in key), []).append(i)
    pairs = [(i, j) for i in range(raw.n)
             for j in index.get(tuple(r_str(raw.get(k)[i]) for k in key), [])]
    cols = [[name, [v[i] for i, _ in pairs]] for name, v in raw.cols]
    cols += [[name, [v[j] for _, j in pairs]] for name, v in raw2.cols if name not in key]
    raw.cols, raw.n = cols, len(pairs)
    ht = arith(lambda l, s: l + s / 100, raw.num("Tree length (m)"),
               raw.num("Stump height (cm)"))
    raw.set("h.t", [None if (h is None or h < 2) else h for h in ht])
    raw.keep([s not in ("DEAD", "NCO") for s in raw.get("Species")])


MANIPULATE = {
    "Aiba2005": m_paste_genus("Genus", "Species"),
    "Aiba2007": m_aiba2007,
    "Albrektson1984": m_albrektson1984,
    "Baltzer2007": m_baltzer2007,
    "BondLamberty2002": m_bondlamberty2002,
    "Brown1978": m_brown1978,
    "Claveau2002": m_claveau2002,
    "Coll2008": m_coll2008,
    "Delagrange0000a": m_delagrange0000a,
    "Delagrange0000b": m_delagrange0000b,
    "Delagrange2004": m_delagrange2004,
    "FLFU1965": m_drop_species({"Trachelospermum asiaticum", "Akebia trifoliata",
                                "Gardneria nutans", "Cocculus trilobus", "Wisteria floribunda",
                                "Vitis saccharifera", "Hedera rhombea", "Ficus nipponica"}),
    "Garber2005": m_wrong_species_hc,
    "Gargaglione2010": m_zero_na("DBH (cm)"),
    "Goto2003": m_drop_species({"Akebia trifoliata", "Cocculus trilobus", "Wisteria floribunda",
                                "Vitis saccharifera"}),
    "Ikushima1964": m_ikushima1964,
    "Kantola2004": m_wrong_species_hc,
    "Kenzo2009": m_kenzo2009,
    "Lusk2011": m_lusk,
    "Lusk2012": m_lusk,
    "Lusk2013": m_lusk,
    "Maguire1998": m_maguire1998,
    "McCulloh2010": m_mcculloh2010,
    # Monserud1999's a_lf corrections test raw$species after renaming it away: no effect.
    "Monserud1999": m_wrong_species_hc,
    "OHara1995": m_ohara1995,
    "Osunkoya2007": m_osunkoya2007,
    "Petritan2009": m_petritan2009,
    "Portsmuth2006": m_portsmuth2006,
    "Reid2004": m_reid2004,
    "Roberts2004": m_roberts2004,
    "SaldanaAcosta2009": m_saldanaacosta2009,
    "Vanninen2005": m_vanninen2005,
    "Wang2000": m_zero_na("D.B.H.(mm)"),
    "Wang2011": m_wang2011,
    "Ximenes2004": m_ximenes2004,
    "Yoda1978": m_drop_species({"Trachelospermum asiaticum", "Hedera rhombea",
                                "Ficus nipponica"}),
}


# ---- the rest of the workflow (R/steps.R, R/post_process.R) ----

def read_options(path):
    f = read_csv_r(path, header=False)
    opts = {"na.strings": ["NA"], "header": "TRUE", "skip": 0.0}
    keys, vals = f.cols[0][1], f.cols[1][1]
    for k, v in zip(keys, vals):
        if k == "na.strings":
            opts["na.strings"] = ["NA", r_str(v)]
        else:
            opts[k] = v
    return opts


def load_study(root, study, variables, conversions):
    d = os.path.join(root, "data", study)
    opts = read_options(os.path.join(d, "dataImportOptions.csv"))
    raw = read_csv_r(os.path.join(d, "data.csv"), header=str(opts["header"]).upper() == "TRUE",
                     skip=int(float(opts["skip"])), na_strings=tuple(opts["na.strings"]))
    if study == "Ximenes2004":
        m_ximenes2004(raw, d)
    elif study in MANIPULATE:
        MANIPULATE[study](raw)
    # dataMatchColumns.csv: rename, then convert units
    match = read_csv_r(os.path.join(d, "dataMatchColumns.csv"), na_strings=("NA", ""))
    var_in, var_out, unit_in = match.get("var_in"), match.get("var_out"), match.get("unit_in")
    rows = [(a, b, u) for a, b, u in zip(var_in, var_out, unit_in) if b is not None]
    for a, b, _ in rows:
        raw.rename(r_str(a), b)
    for b in dict.fromkeys(b for _, b, _ in rows):
        if not raw.has(b) or variables.get(b, {}).get("type") != "numeric":
            continue
        u_from = next(u for _, bb, u in rows if bb == b)
        u_to = variables[b]["units"]
        if u_from != u_to:
            f = conversions[(u_from, u_to)]
            raw.set(b, [None if x is None else f(x) for x in raw.num(b)])
    # keep BAAD's variables only
    data = Frame([[v, raw.get(v) if raw.has(v) else [None] * raw.n] for v in variables], raw.n)
    # dataNew.csv
    new = read_csv_r(os.path.join(d, "dataNew.csv"))
    if new.n:
        for lv, lval, nv, nval in zip(new.get("lookupVariable"), new.get("lookupValue"),
                                      new.get("newVariable"), new.get("newValue")):
            if lv in (None, ""):
                data.set(nv, [nval] * data.n)
            else:
                col = data.get(lv)
                if col is None:
                    continue
                if isinstance(lval, float) or all(x is None or isinstance(x, float)
                                                  for x in col):
                    target = to_num(r_str(lval)) if lval is not None else None
                    hit = [x is not None and target is not None and to_num(r_str(x)) == target
                           for x in col]
                    if target is None:
                        hit = [x is not None and r_str(x) == r_str(lval) for x in col]
                else:
                    hit = [x is not None and r_str(x) == r_str(lval) for x in col]
                data.set_where(nv, hit, nval)
    # fix types
    for v, info in variables.items():
        if info["type"] == "numeric":
            data.set(v, data.num(v))
        else:
            data.set(v, [None if x is None else r_str(x) for x in data.get(v)])
    fill_derived(data)
    data.set("studyName", [study] * data.n)
    return data


def fill_derived(data):
    g = data.get

    def fill(target, cond, value):
        t = list(g(target))
        for i in range(data.n):
            if cond(i):
                t[i] = value(i)
        data.set(target, t)

    na = lambda v, i: g(v)[i] is None
    ok = lambda v, i: g(v)[i] is not None
    fill("a.lf", lambda i: na("a.lf", i) and ok("m.lf", i) and ok("ma.ilf", i),
         lambda i: g("m.lf")[i] / g("ma.ilf")[i] if g("ma.ilf")[i] != 0 else None)
    fill("m.lf", lambda i: na("m.lf", i) and ok("a.lf", i) and ok("ma.ilf", i),
         lambda i: g("a.lf")[i] * g("ma.ilf")[i])
    fill("h.c", lambda i: na("h.c", i) and ok("c.d", i) and ok("h.t", i),
         lambda i: g("h.t")[i] - g("c.d")[i])
    fill("c.d", lambda i: na("c.d", i) and ok("h.t", i) and ok("h.c", i),
         lambda i: g("h.t")[i] - g("h.c")[i])
    fill("a.stbh", lambda i: na("a.stbh", i) and ok("d.bh", i),
         lambda i: math.pi / 4 * g("d.bh")[i] ** 2)
    fill("a.stba", lambda i: na("a.stba", i) and ok("d.ba", i),
         lambda i: math.pi / 4 * g("d.ba")[i] ** 2)
    fill("d.bh", lambda i: ok("a.stbh", i) and na("d.bh", i),
         lambda i: math.sqrt(g("a.stbh")[i] / (math.pi / 4)))
    fill("d.ba", lambda i: ok("a.stba", i) and na("d.ba", i),
         lambda i: math.sqrt(g("a.stba")[i] / (math.pi / 4)))
    fill("d.cr", lambda i: na("d.cr", i) and ok("a.cp", i),
         lambda i: math.sqrt(g("a.cp")[i] / (math.pi / 4)))
    fill("a.cp", lambda i: ok("d.cr", i) and na("a.cp", i),
         lambda i: math.pi / 4 * g("d.cr")[i] ** 2)


def read_conversions(root):
    f = read_csv_r(os.path.join(root, "config", "variableConversion.csv"))
    out = {}
    for a, b, expr in zip(f.get("unit_in"), f.get("unit_out"), f.get("conversion")):
        code = compile(expr.replace("^", "**"), "conversion", "eval")
        out[(a, b)] = (lambda c: (lambda x: r_eval(c, x)))(code)
    return out


def r_eval(code, x):
    """A conversion expression of x, with R's x/0 = Inf."""
    try:
        return eval(code, {"__builtins__": {}}, {"x": x})
    except ZeroDivisionError:
        return math.inf


def read_variables(root):
    f = read_csv_r(os.path.join(root, "config", "variableDefinitions.csv"))
    return {v: {"units": u, "type": t} for v, u, t in
            zip(f.get("variable"), f.get("units"), f.get("type"))}


def read_taxa(root):
    f = read_csv_r(os.path.join(root, "config", "taxon_updates.csv"))
    return dict(zip(f.get("species"), f.get("species_matched")))


def load_baad(root):
    variables = read_variables(root)
    conversions = read_conversions(root)
    taxa = read_taxa(root)
    studies = sorted(s for s in os.listdir(os.path.join(root, "data"))
                     if os.path.exists(os.path.join(root, "data", s, "data.csv")))
    recs = []
    for s in studies:
        d = load_study(root, s, variables, conversions)
        cols = {k: d.get(k) for k in ("studyName", "species", "growingCondition", "location",
                                      "h.t", "h.c", "c.d", "d.bh", "d.ba", "d.cr", "a.cp",
                                      "a.lf")}
        for i in range(d.n):
            r = {k: v[i] for k, v in cols.items()}
            sp = r["species"]
            m = taxa.get(sp, sp) if sp is not None else None
            if m is not None and re.search("un(known|identified)", sp, re.I):
                m = "Unknown"
            r["speciesMatched"] = m
            recs.append(r)
    return recs, studies


# ---- statistics ----

def quantiles(x):
    x = np.asarray(x, float)
    out = {k: float(np.quantile(x, p)) for k, p in QUANTILES}
    out["min"], out["max"] = float(x.min()), float(x.max())
    return out


def rounded(d, digits=4):
    if isinstance(d, dict):
        return {k: rounded(v, digits) for k, v in d.items()}
    if isinstance(d, float):
        return float("%.*g" % (digits, d))
    return d


def summarize(rs):
    studies = sorted(set(r["studyName"] for r in rs))
    out = {"n": len(rs), "n_studies": len(studies), "studies": studies,
           "locations": sorted(set(r["location"] for r in rs if r["location"])),
           "growing_conditions": {c: sum(1 for r in rs if r["growingCondition"] == c)
                                  for c in sorted(set(r["growingCondition"] for r in rs))}}
    series = {
        "height_m": [r["h.t"] for r in rs],
        "crown_diameter_ratio": [r["d.cr"] / r["h.t"] for r in rs if r["d.cr"] is not None],
        "crown_depth_ratio": [r["c.d"] / r["h.t"] for r in rs if r["c.d"] is not None],
        "dbh_m": [r["d.bh"] for r in rs if r["d.bh"] is not None],
        "leaf_area_m2": [r["a.lf"] for r in rs if r["a.lf"] is not None],
    }
    for k, v in series.items():
        if v:
            out[k] = {"n": len(v), **rounded(quantiles(v))}
    both = [(r["h.t"], r["d.cr"]) for r in rs if r["d.cr"] is not None and r["d.cr"] > 0]
    if len(both) >= MIN_FIT:
        lh = np.log([h for h, _ in both])
        lc = np.log([c for _, c in both])
        b, loga = np.polyfit(lh, lc, 1)
        res = lc - (loga + b * lh)
        out["crown_diameter_power_law"] = rounded({
            "a": float(math.exp(loga)), "b": float(b), "n": len(both),
            "residual_sd_log": float(math.sqrt(np.sum(res ** 2) / (len(both) - 2))),
            "height_min_m": float(min(h for h, _ in both)),
            "height_max_m": float(max(h for h, _ in both))})
        out["crown_diameter_power_law"]["n"] = len(both)
    return out


def git_commit(path):
    try:
        return subprocess.run(["git", "-C", path, "rev-parse", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()
    except (subprocess.CalledProcessError, FileNotFoundError):
        return None


def compact_json(x, indent=""):
    """JSON with one key per line, lists of numbers or short strings on one line."""
    inner = indent + "  "
    if isinstance(x, dict):
        if all(not isinstance(v, (dict, list)) for v in x.values()) and len(x) <= 9:
            return json.dumps(x, ensure_ascii=False)
        items = ["%s%s: %s" % (inner, json.dumps(k), compact_json(v, inner))
                 for k, v in x.items()]
        return "{\n" + ",\n".join(items) + "\n" + indent + "}"
    if isinstance(x, list) and any(isinstance(v, (dict, list)) for v in x):
        return "[\n" + ",\n".join(inner + compact_json(v, inner) for v in x) + "\n" + indent + "]"
    return json.dumps(x, ensure_ascii=False)


def fmt_range(s, key, digits):
    if key not in s:
        return "–"
    q = s[key]
    return "%.*f–%.*f (%d)" % (digits, q["p5"], digits, q["p95"], q["n"])


def markdown(result):
    out = []
    head = ("| library species | BAAD taxon | n | studies | height p5–p95 m (n) | crown diameter / "
            "height p5–p95 (n) | crown depth / height p5–p95 (n) | d.cr = a·h^b (n, sd) |\n"
            "|---|---|---:|---|---|---|---|---|\n")
    out.append(head)
    for name, e in result["species"].items():
        for level in ("species", "genus"):
            s = e.get(level)
            if not s:
                continue
            taxon = "*%s*" % (e["latin"] if level == "species" else e["genus_name"] + " spp.")
            if level == "genus":
                taxon += " (%s)" % ", ".join("*%s* %d" % (k, v) for k, v in s["taxa"].items())
            pl = s.get("crown_diameter_power_law")
            pls = ("%.2f·h^%.2f (%d, %.2f)" % (pl["a"], pl["b"], pl["n"], pl["residual_sd_log"])
                   if pl else "–")
            out.append("| %s | %s | %d | %s | %s | %s | %s | %s |\n" % (
                name, taxon, s["n"], ", ".join(s["studies"]), fmt_range(s, "height_m", 1),
                fmt_range(s, "crown_diameter_ratio", 2), fmt_range(s, "crown_depth_ratio", 2),
                pls))
    return "".join(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("baad", help="the baad repository: a clone or a bare git directory")
    ap.add_argument("--out", help="write the JSON here")
    ap.add_argument("--markdown", help="write the README tables here")
    ap.add_argument("--commit", help="commit hash to record (default: git rev-parse HEAD)")
    args = ap.parse_args()

    commit = args.commit or git_commit(args.baad)
    tmp = None
    root = args.baad
    if not os.path.isdir(os.path.join(root, "data")):
        tmp = tempfile.TemporaryDirectory()
        archive = subprocess.run(["git", "--git-dir", args.baad, "archive", "HEAD", "data",
                                  "config"], capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", tmp.name], input=archive, check=True)
        root = tmp.name
    recs, studies = load_baad(root)
    print("BAAD: %d studies, %d individuals" % (len(studies), len(recs)))
    use = [r for r in recs if r["h.t"] is not None and r["h.t"] >= MIN_HEIGHT
           and r["growingCondition"] in KEEP_CONDITIONS]
    print("kept (h.t >= %g m, growingCondition in %s): %d" % (MIN_HEIGHT,
                                                               "/".join(KEEP_CONDITIONS), len(use)))
    dropped = {}
    for r in recs:
        if r["h.t"] is not None and r["h.t"] >= MIN_HEIGHT and \
                r["growingCondition"] not in KEEP_CONDITIONS:
            dropped[r["growingCondition"]] = dropped.get(r["growingCondition"], 0) + 1
    print("dropped by growingCondition (h.t >= %g m): %s" % (MIN_HEIGHT, dropped))

    result = {"species": {}}
    missing, genus_only = [], []
    for preset, latin, synonyms in LIBRARY:
        names = {latin, *synonyms}
        genera = {latin.split()[0]}
        e = {"latin": latin}
        sp = [r for r in use if r["speciesMatched"] in names]
        if sp:
            e["species"] = summarize(sp)
        else:
            gen = [r for r in use if r["speciesMatched"] and
                   r["speciesMatched"].split()[0] in genera]
            e["genus_name"] = "/".join(sorted(genera))
            if gen:
                g = summarize(gen)
                taxa = {}
                for r in gen:
                    taxa[r["speciesMatched"]] = taxa.get(r["speciesMatched"], 0) + 1
                g["taxa"] = dict(sorted(taxa.items(), key=lambda kv: (-kv[1], kv[0])))
                e["genus"] = g
                genus_only.append(preset)
            else:
                missing.append(preset)
        result["species"][preset] = e
        s = e.get("species") or e.get("genus")
        print("%-18s %-24s %s" % (preset, latin, ("%s n=%d studies=%d" % (
            "species" if "species" in e else "genus " + e["genus_name"], s["n"],
            len(s["studies"]))) if s else "none"))

    doc = {
        "name": "baad-allometry",
        "description": "Per-species height, crown and stem allometry of the species library "
                       "from the Biomass And Allometry Database; see README.md",
        "derivation": "scripts/reference_from_baad.py",
        "source": {
            "database": "BAAD: a Biomass And Allometry Database for woody plants",
            "repository": "https://github.com/dfalster/baad",
            "commit": commit,
            "licence": "data: Creative Commons Zero (CC0 1.0) public domain dedication; "
                       "code: BSD 2-clause (LICENCE.md)",
            "citation": "Falster, D. S., Duursma, R. A., Ishihara, M. I. et al. 2015. BAAD: a "
                        "Biomass And Allometry Database for woody plants. Ecology 96:1445",
            "doi": "10.1890/14-1889.1",
            "studies": len(studies),
            "individuals": len(recs),
        },
        "selection": {
            "min_height_m": MIN_HEIGHT,
            "growing_conditions": list(KEEP_CONDITIONS),
            "note": "GH (glasshouse) and GC (growth chamber) dropped; individuals weigh 1 "
                    "each; species by BAAD's speciesMatched; where a library species is "
                    "absent, its genus pooled over every species of it in BAAD ('genus')",
        },
        "definitions": {
            "height_m": "h.t, total height (m)",
            "crown_diameter_ratio": "d.cr / h.t; d.cr crown width or diameter (m), from the "
                                    "projected crown area a.cp as 2 sqrt(a.cp / pi) where "
                                    "only the area was measured",
            "crown_depth_ratio": "c.d / h.t; c.d crown depth (m), h.t - h.c where only the "
                                 "height to crown base h.c was measured",
            "dbh_m": "d.bh, stem diameter at breast height (m)",
            "leaf_area_m2": "a.lf, leaf area of the whole plant (m2)",
            "quantiles": "p5 ... p95 linear between order statistics (R type 7), min, max, "
                         "over the individuals with the variable (n)",
            "crown_diameter_power_law": "d.cr = a h.t^b, least squares of ln d.cr on ln h.t; "
                                        "residual_sd_log in natural-log units (n - 2 df); "
                                        "only with >= %d individuals" % MIN_FIT,
        },
        "no_data": missing,
        "genus_only": genus_only,
        "species": result["species"],
    }
    print("no data: %s" % ", ".join(missing))
    print("genus only: %s" % ", ".join(genus_only))
    if args.out:
        with open(args.out, "w") as f:
            f.write(compact_json(doc) + "\n")
    if args.markdown:
        with open(args.markdown, "w") as f:
            f.write(markdown(doc))
    if tmp:
        tmp.cleanup()


if __name__ == "__main__":
    sys.exit(main())
