// `sylva fit`: the CMA-ES wrapper on a quadratic with a known minimum, a real fit that recovers a
// planted pipe exponent, byte-identical outputs (same seed, 1 or 2 threads, a resumed log), the
// in-place rewrite of the species file and the [fit] reader's checks.
#include "pipeline/analysis/fit.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "pipeline/analysis/dataset_stats.h"
#include "species/model/reference_metrics.h"
#include "species/model/tree_stats.h"
#include "species/spec/species.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using namespace sylva;
using sylva::test::slurp;
using sylva::test::TempDir;

const fs::path kFitData = fs::path(SYLVA_SOURCE_DIR) / "tests" / "data" / "fit";
const fs::path kTinyPipe = kFitData / "tiny-pipe.toml";

void spit(const fs::path& p, const std::string& bytes) {
    std::ofstream out(p, std::ios::binary);
    out << bytes;
}

TEST(FitCmaes, PopulationFollowsHansensRule) {
    EXPECT_EQ(cmaesPopulation(1), 5);  // 4 + 0, raised to pagmo's minimum of 5
    EXPECT_EQ(cmaesPopulation(2), 6);  // 4 + ⌊3 ln 2⌋ = 4 + 2
    EXPECT_EQ(cmaesPopulation(4), 8);  // 4 + ⌊4.16⌋
    EXPECT_EQ(cmaesPopulation(10), 10);
}

// A shifted, scaled quadratic in 2-D: minimum 0.25 at (0.7, −1.3) inside [−2, 2]².
TEST(FitCmaes, FindsTheMinimumOfAShiftedQuadratic) {
    int calls = 0;
    std::function<double(const std::vector<double>&)> f = [&](const std::vector<double>& x) {
        ++calls;
        return 0.25 + (x[0] - 0.7) * (x[0] - 0.7) + 4 * (x[1] + 1.3) * (x[1] + 1.3);
    };
    CmaesOptions o;
    o.evaluations = 300;
    o.seed = 7;
    o.x0 = {-1.5, 1.5};  // far from the minimum
    std::vector<int> generations;
    const CmaesResult r = minimiseCmaes(f, {-2, -2}, {2, 2}, o, [&](const CmaesGeneration& g) {
        generations.push_back(g.generation);
    });
    EXPECT_NEAR(r.bestX[0], 0.7, 1e-3);
    EXPECT_NEAR(r.bestX[1], -1.3, 1e-3);
    EXPECT_NEAR(r.best, 0.25, 1e-6);
    // The budget is kept: the initial population and whole generations of 6.
    EXPECT_EQ(calls, r.evaluations);
    EXPECT_LE(r.evaluations, 300);
    EXPECT_EQ(r.evaluations % 6, 0);
    ASSERT_FALSE(generations.empty());
    EXPECT_EQ(generations.front(), 0);
    EXPECT_EQ(static_cast<int64_t>(generations.size()), r.evaluations / 6);
    // The best so far never gets worse.
    for (size_t i = 1; i < r.generations.size(); ++i) {
        EXPECT_LE(r.generations[i].best, r.generations[i - 1].best);
    }
}

TEST(FitCmaes, SameSeedSameSearchAndTheBoxIsKept) {
    std::vector<std::vector<double>> seen[2];
    for (int run = 0; run < 2; ++run) {
        std::function<double(const std::vector<double>&)> f = [&](const std::vector<double>& x) {
            seen[run].push_back(x);
            return std::fabs(x[0] - 3.0);  // minimum on the upper bound
        };
        CmaesOptions o;
        o.evaluations = 40;
        o.seed = 11;
        minimiseCmaes(f, {0.0}, {3.0}, o);
    }
    EXPECT_EQ(seen[0], seen[1]);
    for (const auto& x : seen[0]) {
        EXPECT_GE(x[0], 0.0);
        EXPECT_LE(x[0], 3.0);
    }
}

TEST(FitCmaes, ABudgetBelowTwoPopulationsIsRefused) {
    std::function<double(const std::vector<double>&)> f = [](const std::vector<double>&) {
        return 0.0;
    };
    CmaesOptions o;
    o.evaluations = 9;  // population 5 in 1-D
    EXPECT_THROW(minimiseCmaes(f, {0.0}, {1.0}, o), std::invalid_argument);
    o.evaluations = 10;
    EXPECT_NO_THROW(minimiseCmaes(f, {0.0}, {1.0}, o));
    EXPECT_THROW(minimiseCmaes(f, {1.0}, {1.0}, o), std::invalid_argument);
}

// --- the species file -----------------------------------------------------------------------

TEST(FitSpec, ReadsEveryKeyOfTheFixture) {
    const FitSpec s = readFitSpec(kTinyPipe.string());
    EXPECT_EQ(s.speciesName, "tiny-pipe");
    EXPECT_EQ(s.trees, 8);
    EXPECT_EQ(s.evaluations, 40);
    EXPECT_EQ(s.seed, 3u);
    EXPECT_EQ(s.distributions, (std::vector<std::string>{"radius_ratio", "tip_path_ratio"}));
    EXPECT_EQ(s.weights, (std::vector<double>{1, 0}));
    ASSERT_EQ(s.parameters.size(), 1u);
    const FitParameter& p = s.parameters[0];
    EXPECT_EQ(p.path, "form.pipe_exponent");
    EXPECT_EQ(p.lo, 1.8);
    EXPECT_EQ(p.hi, 3.4);
    EXPECT_EQ(p.initial, 2.2);
    EXPECT_FALSE(p.integer);
    EXPECT_EQ(p.value.line, 35);
    EXPECT_EQ(p.value.column, 17);
    EXPECT_TRUE(fs::is_regular_file(s.reference));
}

// `nodes = 300` is an integer key (the species refuses 300.0); `alpha_deg = 54` is a real key
// written without a decimal point. Only the first is rounded.
TEST(FitSpec, IntegerKeysAreToldFromWholeNumbers) {
    TempDir t;
    std::string text = slurp(kTinyPipe);
    text.replace(text.find("[[fit.parameter]]"), std::string::npos,
                 "[[fit.parameter]]\npath = \"levels[0].nodes\"\nbounds = [200, 400]\n\n"
                 "[[fit.parameter]]\npath = \"levels[1].alpha_deg\"\nbounds = [40, 60]\n");
    spit(t / "s.toml", text);
    const FitSpec s =
        readFitSpec((t / "s.toml").string(), nullptr,
                    fs::path(SYLVA_SOURCE_DIR) / "species/reference/treeqsm-broadleaf.json");
    ASSERT_EQ(s.parameters.size(), 2u);
    EXPECT_TRUE(s.parameters[0].integer);
    EXPECT_EQ(s.parameters[0].initial, 300);
    EXPECT_FALSE(s.parameters[1].integer);
    EXPECT_EQ(s.parameters[1].initial, 54);
    const std::string out = replaceFittedValues(text, s.parameters, {312.4, 47.5});
    EXPECT_NE(out.find("nodes = 312\n"), std::string::npos);
    EXPECT_NE(out.find("alpha_deg = 47.5\n"), std::string::npos);
    EXPECT_EQ(out.find("nodes = 300"), std::string::npos);
}

TEST(FitSpec, TheSpeciesReaderIgnoresTheFitTable) {
    const SpeciesFile s = loadSpecies(kTinyPipe.string());
    EXPECT_NO_THROW(validateSpecies(s, nullptr));
    EXPECT_NO_THROW(growSpecies(s, 1, nullptr, false));
}

TEST(FitSpec, ValuesAreReplacedInPlaceKeepingEverythingElse) {
    const std::string text =
        "# top\nname = \"x\"  # the name\n[form]\npipe_exponent = 2.2  # fitted\n"
        "n = 7\nscale = { normal = [1.0, 0.08] }\n\"é\" = { uniform = [-3e-1, 2] }\n";
    std::vector<FitParameter> ps(4);
    ps[0].value = {"x.toml", 4, 17};  // 2.2
    ps[1].value = {"x.toml", 5, 5};   // 7
    ps[1].integer = true;
    ps[2].value = {"x.toml", 6, 26};  // 0.08
    ps[3].value = {"x.toml", 7, 20};  // -3e-1: columns count code points, not bytes
    const std::string out = replaceFittedValues(text, ps, {2.6, 8.4, 0.1, 1.0 / 3.0});
    EXPECT_EQ(out,
              "# top\nname = \"x\"  # the name\n[form]\npipe_exponent = 2.6  # fitted\n"
              "n = 8\nscale = { normal = [1.0, 0.1] }\n"
              "\"é\" = { uniform = [0.3333333333333333, 2] }\n");
    // And the positions are toml++'s.
    const toml::table t = toml::parse(text);
    EXPECT_EQ(t.at_path("form.pipe_exponent").node()->source().begin.column, 17u);
    EXPECT_EQ(t.at_path("form.scale.normal[1]").node()->source().begin.column, 26u);
    EXPECT_EQ(t.at_path("form.é.uniform[0]").node()->source().begin.column, 20u);
}

TEST(FitSpec, NumbersRoundTrip) {
    for (double v : {2.6, 0.1, 1.0 / 3.0, 1e-300, 123456789.0, -2.0, 3.0000000000000004}) {
        const std::string s = roundTripNumber(v);
        EXPECT_EQ(std::strtod(s.c_str(), nullptr), v) << s;
        EXPECT_NE(s.find_first_of(".e"), std::string::npos) << s;  // a TOML float
    }
    EXPECT_EQ(roundTripNumber(2.6), "2.6");
    EXPECT_EQ(roundTripNumber(3.0), "3.0");
    EXPECT_EQ(roundTripNumber(20.0), "20.0");  // not 2e+01
    EXPECT_EQ(roundTripNumber(0.00028902096502518847), "0.00028902096502518847");
    EXPECT_EQ(roundTripNumber(1e-300), "1e-300");
}

// --- a real fit -------------------------------------------------------------------------------

// A reference file whose radius_ratio and tip_path_ratio tables are the pooled values of the fit's
// own trees (fitTreeSeeds) grown with form.pipe_exponent = 2.6: at 2.6 the fit's trees reproduce
// the reference exactly (D = 0), and since a lateral's pipe-model ratio (about (tips_lateral /
// tips_parent)^(1/n), spread by the fixture's pipe_taper) moves every ratio the same way with n,
// D > 0 elsewhere: 2.6 is the unique minimum. (The radius exponent would not do: under the pipe
// model every fork has exactly n, a point mass whose D is 1 at any other n.)
fs::path plantedReference(const fs::path& dir, const FitSpec& spec) {
    const SpeciesFile species = loadSpecies(spec.speciesPath);
    Overrides ov;
    ov["form.pipe_exponent"].holder.insert_or_assign("v", 2.6);
    ReferenceValues pool;
    for (uint64_t seed : fitTreeSeeds(spec.seed, spec.trees)) {
        poolReferenceValues(pool,
                            skeletonReferenceValues(growSpecies(species, seed, &ov, false).tree));
    }
    nlohmann::json j;
    j["name"] = "planted";
    j["trees"] = spec.trees;
    for (int k : {kRadiusRatio, kTipPathRatio}) {
        std::vector<double> v = pool[k];
        std::sort(v.begin(), v.end());
        const QuantileTable t = sampleTable(v);
        j["distributions"][kReferenceDistributionNames[k]] = {
            {"p", t.p}, {"q", t.q}, {"n", v.size()}};
    }
    const fs::path file = dir / "planted.json";
    spit(file, j.dump());
    return file;
}

FitOptions quietOptions(const fs::path& out, const fs::path& reference) {
    FitOptions o;
    o.out = out;
    o.reference = reference;
    o.progress = false;
    return o;
}

// 20 evaluations (the initial population and 3 generations), enough for the byte comparisons.
FitOptions shortOptions(const fs::path& out, const fs::path& reference) {
    FitOptions o = quietOptions(out, reference);
    o.evaluations = 20;
    return o;
}

TEST(FitRun, RecoversAPlantedPipeExponent) {
    TempDir t;
    const FitSpec spec = readFitSpec(kTinyPipe.string());
    const fs::path ref = plantedReference(t.path(), spec);
    const FitResult r = runFit(kTinyPipe.string(), quietOptions(t / "tiny-pipe.toml", ref));
    ASSERT_EQ(r.after.x.size(), 1u);
    // 40 evaluations: the initial population and 7 generations of 5 in 1-D. D is exactly 0 at
    // 2.6 (the reference is these trees) and, measured on these 8 trees, 0.073 at 2.58 and 2.62
    // (forks of equal tip counts give equal ratios: a step), 0.085 / 0.087 at 2.55 / 2.65, 0.10
    // at 2.5 / 2.7, 0.25 at 2.2: a V around 2.6. A best objective below 0.085 therefore puts the
    // exponent within 0.05 of 2.6; CMA-ES need not hit the exact point inside the step.
    EXPECT_LT(r.after.objective, 0.085);
    EXPECT_NEAR(r.after.x[0], 2.6, 0.05);
    EXPECT_LT(r.after.objective, r.before.objective);
    EXPECT_LT(*r.after.d[0], *r.before.d[0]);
    EXPECT_EQ(r.before.x[0], 2.2);
    EXPECT_EQ(r.evaluations, 40);
    EXPECT_EQ(r.reused, 0);
    // The fitted file is the fixture with the value replaced, below a provenance block.
    const std::string fitted = slurp(r.out);
    const std::string original = slurp(kTinyPipe);
    const size_t end = fitted.find("# --- end of sylva fit ---\n");
    ASSERT_NE(end, std::string::npos);
    EXPECT_EQ(fitted.rfind("# --- sylva fit ---", 0), 0u);
    std::string body = fitted.substr(end + 27);
    std::string expected = original;
    expected.replace(expected.find("pipe_exponent = 2.2"), 19,
                     "pipe_exponent = " + roundTripNumber(r.after.x[0]));
    EXPECT_EQ(body, expected);
    EXPECT_NE(fitted.find("planted.json (\"planted\", 8 measured trees)"), std::string::npos)
        << fitted;
    // The fitted file is a valid species whose exponent reads back exactly.
    const FitSpec again = readFitSpec(r.out.string(), nullptr, ref);
    EXPECT_EQ(again.parameters[0].initial, r.after.x[0]);
    // The log: a header and one line per evaluation; the report and its plot.
    std::ifstream log(r.log);
    std::vector<std::string> lines;
    for (std::string l; std::getline(log, l);) lines.push_back(l);
    ASSERT_EQ(lines.size(), 41u);
    const nlohmann::json first = nlohmann::json::parse(lines[1]);
    EXPECT_EQ(first["evaluation"], 0);
    EXPECT_EQ(first["x"]["form.pipe_exponent"], 2.2);
    EXPECT_EQ(first["objective"].get<double>(), r.before.objective);
    EXPECT_NE(slurp(r.report).find("| D radius_ratio |"), std::string::npos);
    EXPECT_EQ(slurp(r.plot).rfind("<svg", 0), 0u);
}

// Every output of a fit, by file name.
std::map<std::string, std::string> outputs(const fs::path& dir) {
    std::map<std::string, std::string> files;
    for (const auto& e : fs::directory_iterator(dir)) {
        if (e.path().extension() != ".json") {
            files[e.path().filename().string()] = slurp(e.path());
        }
    }
    return files;
}

TEST(FitRun, SameSeedSameBytesWithOneOrTwoThreadsAndAfterAResume) {
    TempDir t;
    const FitSpec spec = readFitSpec(kTinyPipe.string());
    const fs::path ref = plantedReference(t.path(), spec);
    std::map<std::string, std::string> want;
    for (const char* run : {"a", "b", "c"}) {
        fs::create_directories(t / run);
        std::unique_ptr<tbb::global_control> limit;
        if (std::string(run) == "b") {
            limit = std::make_unique<tbb::global_control>(
                tbb::global_control::max_allowed_parallelism, 1);
        }
        if (std::string(run) == "c") {
            limit = std::make_unique<tbb::global_control>(
                tbb::global_control::max_allowed_parallelism, 2);
        }
        runFit(kTinyPipe.string(), shortOptions(t / run / "x.toml", ref));
        const auto got = outputs(t / run);
        EXPECT_EQ(got.size(), 4u);
        if (want.empty()) {
            want = got;
        } else {
            EXPECT_EQ(got, want) << run;
        }
    }
    // A killed fit: its log cut in the middle of a line. The rerun takes the complete lines'
    // evaluations from the log and ends with the same bytes.
    std::string log = slurp(t / "a" / "x.toml.fit.jsonl");
    size_t cut = 0;
    for (int i = 0; i < 18; ++i) cut = log.find('\n', cut) + 1;
    spit(t / "a" / "x.toml.fit.jsonl", log.substr(0, cut + 25));
    fs::remove(t / "a" / "x.toml");
    const FitResult r = runFit(kTinyPipe.string(), shortOptions(t / "a" / "x.toml", ref));
    EXPECT_EQ(r.reused, 17);  // the header and 17 evaluations were complete
    EXPECT_EQ(outputs(t / "a"), want);
    // A log of another seed is not reused.
    FitOptions other = shortOptions(t / "a" / "x.toml", ref);
    other.seed = 4;
    const FitResult r4 = runFit(kTinyPipe.string(), other);
    EXPECT_EQ(r4.reused, 0);
    EXPECT_NE(slurp(t / "a" / "x.toml.fit.jsonl"), want["x.toml.fit.jsonl"]);
}

// A candidate whose trees fail (here: the species' node budget) scores 1, the worst.
TEST(FitRun, AFailingTreeMakesTheObjectiveOne) {
    TempDir t;
    std::string text = slurp(kTinyPipe);
    text += "\n[budget]\nmax_skeleton_nodes = 50\n";  // the tree has over 300
    spit(t / "s.toml", text);
    FitSpec spec = readFitSpec(kTinyPipe.string());
    spec.speciesPath = (t / "s.toml").string();
    spec.reference = plantedReference(t.path(), readFitSpec(kTinyPipe.string()));
    try {
        const FitObjective objective(spec);
        const FitEvaluation e = objective.evaluate({2.6});
        EXPECT_EQ(e.objective, 1.0);
        EXPECT_FALSE(e.error.empty());
        for (const auto& d : e.d) EXPECT_FALSE(d.has_value());
    } catch (const SpecError& e) {
        ADD_FAILURE() << e.what();
    }
}

// Elements of an array of numbers (a grammar's `tilt_deg = [40, 55]`) are fitted one by one:
// read with their place, written back in place, and the override reaches the grammar's reader —
// an evaluation with the interval's ends crossed is the reader's "lo ≤ hi" error, one with them
// apart grows other trees than the file's values.
TEST(FitSpec, ElementsOfAGrammarArrayAreFitted) {
    TempDir t;
    std::string text = slurp(fs::path(SYLVA_SOURCE_DIR) / "species/presets/neem.toml");
    text.erase(text.find("\n[fit]") + 1);
    text +=
        "[fit]\ntrees = 4\nevaluations = 20\ndistributions = [\"branch_angle_deg\"]\n\n"
        "[[fit.parameter]]\npath = \"geometry.a->m.tilt_deg[0]\"\nbounds = [30, 70]\n\n"
        "[[fit.parameter]]\npath = \"geometry.a->m.tilt_deg[1]\"\nbounds = [45, 80]\n";
    spit(t / "neem.toml", text);
    const fs::path reference =
        fs::path(SYLVA_SOURCE_DIR) / "species/reference/treeqsm-broadleaf-fit.json";
    const FitSpec spec = readFitSpec((t / "neem.toml").string(), nullptr, reference);
    ASSERT_EQ(spec.parameters.size(), 2u);
    for (int k = 0; k < 2; ++k) {
        const FitParameter& p = spec.parameters[k];
        EXPECT_TRUE(p.arrayElement);
        EXPECT_EQ(p.element, k);
        EXPECT_EQ(p.overrideKey, "geometry.a->m.tilt_deg");
        EXPECT_EQ(p.initial, k == 0 ? 40 : 55);
    }
    const std::string out = replaceFittedValues(text, spec.parameters, {42.5, 61.25});
    EXPECT_NE(out.find("tilt_deg = [42.5, 61.25]\n"), std::string::npos);
    EXPECT_EQ(out.size(), text.size() + 5);  // "40" → "42.5", "55" → "61.25": nothing else

    const FitObjective objective(spec);
    const FitEvaluation crossed = objective.evaluate({65, 50});
    EXPECT_EQ(crossed.objective, 1.0);
    EXPECT_NE(crossed.error.find("expected lo ≤ hi"), std::string::npos) << crossed.error;
    const FitEvaluation own = objective.evaluate({40, 55});
    const FitEvaluation wide = objective.evaluate({30, 80});
    ASSERT_TRUE(own.error.empty()) << own.error;
    ASSERT_TRUE(wide.error.empty()) << wide.error;
    ASSERT_TRUE(own.d[0] && wide.d[0]);
    EXPECT_NE(*own.d[0], *wide.d[0]);
    EXPECT_EQ(*objective.evaluate({40, 55}).d[0], *own.d[0]);

    // Not an array of numbers, or an element past its end: an error at the path.
    for (const char* bad : {"geometry.a->m.phyllotaxis[0]", "geometry.a->m.tilt_deg[2]"}) {
        std::string b = text;
        b.replace(b.find("geometry.a->m.tilt_deg[1]"), 25, bad);
        spit(t / "bad.toml", b);
        EXPECT_THROW(readFitSpec((t / "bad.toml").string(), nullptr, reference), SpecError) << bad;
    }
}

// The fixture's text with its reference file given by absolute path, for a copy of it written
// elsewhere.
void pointAtBroadleafReference(std::string& text) {
    text.replace(
        text.find("reference = \""), text.find("trees = 8") - text.find("reference = \""),
        "reference = \"" +
            (fs::path(SYLVA_SOURCE_DIR) / "species/reference/treeqsm-broadleaf.json").string() +
            "\"\n");
}

TEST(FitSpec, WithoutDistributionsTheSixBroadleafOnesAreCompared) {
    TempDir t;
    std::string text = slurp(kTinyPipe);
    for (const char* key : {"distributions = ", "weights = "}) {
        const size_t at = text.find(key);
        ASSERT_NE(at, std::string::npos) << key;
        text.erase(at, text.find('\n', at) + 1 - at);
    }
    pointAtBroadleafReference(text);
    spit(t / "s.toml", text);
    const FitSpec spec = readFitSpec((t / "s.toml").string());
    EXPECT_EQ(spec.distributions,
              (std::vector<std::string>{"radius_ratio", "radius_exponent", "branch_angle_deg",
                                        "tip_path_ratio", "branch_length_order1",
                                        "branch_length_order2"}));
}

// Crown depth ÷ height from an allometry file: the file's quantiles of the species make a
// piecewise-linear CDF (min, p5, p25, p50, p75, p95, max at 0 … 1) and D is the KS distance of
// the trees' values (one per tree, crownHeight / height) to it — here recomputed by hand at
// every knot of both CDFs; quantiles above every tree give D = 1; the key without `allometry`,
// and a species the file does not hold, are errors at their keys.
TEST(FitSpec, AllometryDistributionsComeFromTheAllometryFile) {
    TempDir t;
    auto allometry = [&](const std::string& species, const std::vector<double>& q) {
        nlohmann::json block;
        const char* keys[] = {"min", "p5", "p25", "p50", "p75", "p95", "max"};
        for (size_t k = 0; k < 7; ++k) block[keys[k]] = q[k];
        nlohmann::json j;
        j["species"][species]["species"]["crown_depth_ratio"] = block;
        spit(t / "allometry.json", j.dump());
    };
    std::string text = slurp(kTinyPipe);
    text.replace(text.find("distributions = "),
                 text.find("[[fit.parameter]]") - text.find("distributions = "),
                 "distributions = [\"radius_ratio\", \"crown_depth_ratio\"]\n"
                 "allometry = \"allometry.json\"\n\n");
    pointAtBroadleafReference(text);
    spit(t / "s.toml", text);
    const std::vector<double> q = {0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.95};
    allometry("tiny-pipe", q);
    const FitSpec spec = readFitSpec((t / "s.toml").string());
    EXPECT_EQ(spec.allometry, t / "allometry.json");
    ASSERT_EQ(spec.distributions.size(), 2u);

    // The trees the objective grows at the file's own value, measured here.
    const SpeciesFile species = loadSpecies((t / "s.toml").string());
    std::vector<double> v;
    for (uint64_t seed : fitTreeSeeds(spec.seed, spec.trees)) {
        const TreeStats st = computeStats(growSpecies(species, seed, nullptr, false).tree);
        v.push_back(st.crownHeight / st.height);
    }
    std::sort(v.begin(), v.end());
    const std::vector<double> p = {0, 0.05, 0.25, 0.5, 0.75, 0.95, 1};
    // Piecewise-linear CDFs through (xs[i], ps[i]), right-continuous at repeated xs.
    auto cdf = [](const std::vector<double>& xs, const std::vector<double>& ps, double x) {
        if (x < xs.front()) return 0.0;
        if (x >= xs.back()) return 1.0;
        size_t i = 0;
        while (i + 1 < xs.size() && xs[i + 1] <= x) ++i;
        return ps[i] + (ps[i + 1] - ps[i]) * (x - xs[i]) / (xs[i + 1] - xs[i]);
    };
    std::vector<double> pv;
    for (size_t i = 0; i < v.size(); ++i) pv.push_back(double(i) / double(v.size() - 1));
    double want = 0;
    std::vector<double> knots = v;
    knots.insert(knots.end(), q.begin(), q.end());
    for (double x : knots) {
        for (double y : {x, std::nextafter(x, -1.0)}) {
            want = std::max(want, std::abs(cdf(v, pv, y) - cdf(q, p, y)));
        }
    }
    const FitObjective objective(spec);
    const FitEvaluation e = objective.evaluate({spec.parameters[0].initial});
    ASSERT_TRUE(e.error.empty()) << e.error;
    ASSERT_TRUE(e.d[1].has_value());
    EXPECT_NEAR(*e.d[1], want, 1e-9);
    EXPECT_GT(want, 0.0);
    EXPECT_LT(want, 1.0);

    allometry("tiny-pipe", {5, 5, 5, 5, 5, 5, 5});  // above every tree: D = 1
    EXPECT_EQ(*FitObjective(readFitSpec((t / "s.toml").string())).evaluate({2.2}).d[1], 1.0);

    allometry("another", q);
    try {
        readFitSpec((t / "s.toml").string());
        ADD_FAILURE() << "a species the file does not hold";
    } catch (const SpecError& err) {
        EXPECT_NE(std::string(err.what()).find("fit.allometry"), std::string::npos) << err.what();
        EXPECT_NE(std::string(err.what()).find("no entry for species \"tiny-pipe\""),
                  std::string::npos)
            << err.what();
    }
    std::string without = text;
    without.erase(without.find("allometry = "), without.find("\n", without.find("allometry = ")) -
                                                    without.find("allometry = ") + 1);
    spit(t / "without.toml", without);
    try {
        readFitSpec((t / "without.toml").string());
        ADD_FAILURE() << "crown_depth_ratio without an allometry file";
    } catch (const SpecError& err) {
        EXPECT_NE(std::string(err.what()).find("set `allometry`"), std::string::npos) << err.what();
    }
}

}  // namespace
