#include "experiments/study.h"

#include <algorithm>
#include <cctype>
#include <tuple>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include "core/safe_file.h"
#include "experiments/runner.h"
#include "experiments/slurm.h"
#include "scene/loader.h"

namespace hrad::experiments {

namespace fs = std::filesystem;

namespace {

SourceLocation loc(const std::string& file, const toml::source_region& r) {
    return SourceLocation{file, int(r.begin.line), int(r.begin.column)};
}

/// A TOML scalar as a Params value; arrays, tables and dates are errors.
Params::Value toValue(const toml::node& n, const std::string& key, const std::string& file) {
    if (auto v = n.as_boolean()) return v->get();
    if (auto v = n.as_integer()) return int64_t(v->get());
    if (auto v = n.as_floating_point()) return v->get();
    if (auto v = n.as_string()) return v->get();
    throwInputError(loc(file, n.source()),
                    "'{}' must be a boolean, number or string (a list belongs in [sweep])", key);
}

/// Table entries in file order (toml++ tables are sorted maps).
std::vector<std::pair<std::string, const toml::node*>> ordered(const toml::table& t) {
    std::vector<std::pair<std::string, const toml::node*>> out;
    for (auto&& [k, v] : t) out.emplace_back(std::string(k.str()), &v);
    std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
        const auto& ra = a.second->source().begin;
        const auto& rb = b.second->source().begin;
        return ra.line != rb.line ? ra.line < rb.line : ra.column < rb.column;
    });
    return out;
}

/// Flattens nested tables into dotted keys: [solver.oracle] eps -> "oracle.eps".
void flatten(const toml::table& t, const std::string& prefix,
             std::vector<std::pair<std::string, const toml::node*>>& out) {
    for (const auto& [k, n] : ordered(t)) {
        std::string key = prefix.empty() ? k : prefix + "." + k;
        if (const toml::table* sub = n->as_table())
            flatten(*sub, key, out);
        else
            out.emplace_back(key, n);
    }
}

}  // namespace

struct Axis {
    /// Keys varied together (one for a [sweep] axis, several for a zip group).
    std::vector<std::string> keys;
    /// values[i][k]: value of keys[k] at step i, with its location.
    std::vector<std::vector<std::pair<Params::Value, SourceLocation>>> values;
};

/// A study's points, one at a time: scenes x axis_1 x ... x axis_n (the last
/// axis varying fastest), never materialised as a whole.
struct StudyExpansion {
    struct Scene {
        std::string spec, label;
        /// Per-scene overrides, already converted to values.
        std::vector<std::tuple<std::string, Params::Value, SourceLocation>> solver, reference;
    };
    std::vector<Scene> scenes;
    Params base, baseRef;
    OutputOptions outputs;
    std::vector<Axis> axes;
    uint64_t combos = 1;  ///< product of the axis lengths, saturated at UINT64_MAX
    uint64_t count = 0;   ///< scenes x combos, saturated
};

namespace {

Axis axisFromList(const std::string& key, const toml::node& n, const std::string& file,
                  const char* where) {
    const toml::array* arr = n.as_array();
    if (!arr)
        throwInputError(loc(file, n.source()),
                        "{} '{}' must be a list of values (constants belong in [solver])", where,
                        key);
    if (arr->empty()) throwInputError(loc(file, n.source()), "{} '{}' is an empty list", where, key);
    Axis a;
    a.keys.push_back(key);
    for (const toml::node& e : *arr)
        a.values.push_back({{toValue(e, key, file), loc(file, e.source())}});
    return a;
}

bool getBoolNode(const toml::node& n, const std::string& key, const std::string& file) {
    if (auto v = n.as_boolean()) return v->get();
    throwInputError(loc(file, n.source()), "'{}' must be true or false", key);
}

uint64_t fnv1a(const std::string& s, uint64_t h = 1469598103934665603ull) {
    for (unsigned char c : s) {
        h ^= c;
        h *= 1099511628211ull;
    }
    return h;
}

/// Deepest key a study may use (dotted parts of a key or table header) and
/// deepest nesting of arrays and inline tables. toml++ parses table headers
/// and dotted keys recursively without a bound (a `[solver.a.a...]` header of
/// 100,000 parts overflowed its stack), and flatten() above recurses once per
/// level: both are safe below these bounds, which no real study approaches.
constexpr int kMaxTomlDepth = 64;

/// Refuses, with the line, TOML text whose keys or nesting are deeper than
/// kMaxTomlDepth, before toml++ sees it. A lexical scan (TOML 1.0): strings
/// (basic, literal, multi-line) are skipped; dots count where a key is being
/// read (line start, after `[`, `{` or `,` in an inline table, up to `=`/`]`).
void checkTomlDepth(const std::string& text, const std::string& file) {
    int line = 1, nesting = 0, dots = 0;
    bool inKey = true;       // reading a key (or a header)
    std::vector<char> open;  // '[' (array or header) or '{'
    auto fail = [&](const char* what) {
        throwInputError(SourceLocation{file, line, 0}, "{} deeper than {} levels", what, kMaxTomlDepth);
    };
    for (size_t i = 0; i < text.size(); ++i) {
        char c = text[i];
        if (c == '\n') {
            ++line;
            // A new line starts a key unless an array value continues.
            inKey = open.empty() || open.back() == '{';
            dots = 0;
            continue;
        }
        if (c == '#') {
            while (i + 1 < text.size() && text[i + 1] != '\n') ++i;
            continue;
        }
        if (c == '"' || c == '\'') {
            bool multi = text.compare(i, 3, std::string(3, c)) == 0;
            size_t j = i + (multi ? 3 : 1);
            for (; j < text.size(); ++j) {
                if (text[j] == '\n') {
                    if (!multi) break;  // toml++ reports the unterminated string
                    ++line;
                }
                if (c == '"' && text[j] == '\\') {
                    if (j + 1 < text.size() && text[j + 1] == '\n') ++line;
                    ++j;
                    continue;
                }
                if (text[j] == c && (!multi || text.compare(j, 3, std::string(3, c)) == 0)) {
                    if (multi) j += 2;
                    break;
                }
            }
            i = std::min(j, text.size() - 1);
            if (j < text.size() && text[j] == '\n') --i;  // let the newline be counted
            continue;
        }
        if (inKey && c == '.' && ++dots >= kMaxTomlDepth) fail("key or table header");
        if (c == '=') {
            inKey = false;
            dots = 0;
        } else if (c == '[' || c == '{') {
            bool header = inKey && c == '[' && open.empty();
            if (!header && ++nesting > kMaxTomlDepth) fail("arrays and inline tables nest");
            open.push_back(header ? 'h' : c);
            inKey = header || c == '{';
            dots = 0;
        } else if (c == ']' || c == '}') {
            if (!open.empty()) {
                if (open.back() != 'h') --nesting;
                open.pop_back();
            }
            inKey = false;
        } else if (c == ',' && !open.empty() && open.back() == '{') {
            inKey = true;
            dots = 0;
        }
    }
}

}  // namespace

Study loadStudy(const fs::path& path) {
    requireRegularFile(path, "study file");
    std::ifstream in(path, std::ios::binary);
    if (!in) throwInputError(SourceLocation{path.string(), 0, 0}, "cannot read study file");
    std::stringstream ss;
    ss << in.rdbuf();
    Study s = parseStudy(ss.str(), path.string(), path.parent_path());
    s.path = path;
    return s;
}

Study parseStudy(const std::string& text, const std::string& file, const fs::path& baseDir) {
    checkTomlDepth(text, file);
    toml::table root;
    try {
        root = toml::parse(text, file);
    } catch (const toml::parse_error& e) {
        throwInputError(loc(file, e.source()), "TOML syntax error: {}", e.description());
    }

    Study study;
    study.text = text;
    study.name = fs::path(file).stem().string();

    static const std::set<std::string> topKeys = {"name",   "description", "scenes", "solver",
                                                  "reference", "outputs", "limits",  "sweep",
                                                  "zip", "slurm"};
    for (const auto& [k, n] : ordered(root))
        if (!topKeys.count(k))
            throwInputError(loc(file, n->source()),
                            "unknown top-level key '{}' (expected one of: name, description, "
                            "scenes, solver, reference, outputs, limits, sweep, zip, slurm)",
                            k);

    auto stringOf = [&](const toml::node& n, const std::string& key) {
        if (auto v = n.as_string()) return std::string(v->get());
        throwInputError(loc(file, n.source()), "'{}' must be a string", key);
    };
    if (auto* n = root.get("name")) study.name = stringOf(*n, "name");
    if (auto* n = root.get("description")) study.description = stringOf(*n, "description");
    if (study.name.empty()) throwInputError(SourceLocation{file, 1, 1}, "study name is empty");
    // The name becomes a folder (runs/<name>) and a file (results/<name>.sqlite):
    // one plain path component, so nothing is written outside the folders the
    // user named ("../../escaped" was).
    {
        SourceLocation w = root.get("name") ? loc(file, root.get("name")->source()) : SourceLocation{file, 1, 1};
        bool plain = study.name != "." && study.name != ".." && study.name.size() <= 200;
        for (unsigned char c : study.name) plain &= std::isalnum(c) || c == '_' || c == '-' || c == '.';
        if (!plain)
            throwInputError(w, "study name '{}' must be a plain file name (letters, digits, '_', '-', "
                               "'.'; not '.' or '..'; at most 200 characters): it names the study's "
                               "artefact folder and results store",
                            study.name);
    }

    // ---- scenes ------------------------------------------------------------------
    struct SceneEntry {
        std::string spec, label;
        /// Per-scene overrides ({ scene = "...", solver = {...}, reference = {...} }).
        std::vector<std::pair<std::string, const toml::node*>> solver, reference;
    };
    std::vector<SceneEntry> scenes;
    const toml::node* scenesNode = root.get("scenes");
    if (!scenesNode) throwInputError(SourceLocation{file, 1, 1}, "missing 'scenes' (a list of scene names or files)");
    std::vector<const toml::node*> sceneNodes;
    if (const toml::array* arr = scenesNode->as_array()) {
        for (const toml::node& e : *arr) sceneNodes.push_back(&e);
    } else {
        sceneNodes.push_back(scenesNode);
    }
    if (sceneNodes.empty()) throwInputError(loc(file, scenesNode->source()), "'scenes' is empty");
    for (const toml::node* e : sceneNodes) {
        SceneEntry se;
        std::string label;
        if (const toml::table* t = e->as_table()) {
            // { scene = "cornell", solver = { ... }, reference = { ... } }
            for (const auto& [k, n] : ordered(*t)) {
                if (k == "scene") {
                    label = stringOf(*n, "scene");
                } else if ((k == "solver" || k == "reference") && n->as_table()) {
                    flatten(*n->as_table(), "", k == "solver" ? se.solver : se.reference);
                } else {
                    throwInputError(loc(file, n->source()),
                                    "unknown key '{}' in a scene entry (expected scene, solver, "
                                    "reference tables)",
                                    k);
                }
            }
            if (label.empty())
                throwInputError(loc(file, e->source()), "scene entry without 'scene = \"...\"'");
        } else {
            label = stringOf(*e, "scenes");
        }
        se.spec = se.label = label;
        if (!scene::isBuiltinName(label)) {
            fs::path p(label);
            if (p.is_relative()) p = baseDir / p;
            p = p.lexically_normal();
            std::error_code ec;  // (a name the system refuses is "not found", not an exception)
            if (!fs::is_regular_file(p, ec))
                throwInputError(loc(file, e->source()),
                                "scene file '{}' not found (resolved to '{}'; paths are relative to "
                                "the study file's folder)",
                                label, p.string());
            se.spec = p.string();
        }
        scenes.push_back(se);
    }

    // ---- base settings -------------------------------------------------------------
    Params base, baseRef;
    auto requireTable = [&](const char* key) -> const toml::table* {
        const toml::node* n = root.get(key);
        if (!n) return nullptr;
        if (const toml::table* t = n->as_table()) return t;
        throwInputError(loc(file, n->source()), "'{}' must be a table ([{}])", key, key);
    };
    std::map<std::string, SourceLocation> setAt;  // key -> where first set (solver/sweep/zip)
    auto claim = [&](const std::string& key, const SourceLocation& where) {
        auto [it, fresh] = setAt.emplace(key, where);
        if (!fresh)
            throwInputError(where, "setting '{}' is set twice (also at {})", key, it->second.str());
    };
    if (const toml::table* t = requireTable("solver")) {
        std::vector<std::pair<std::string, const toml::node*>> flat;
        flatten(*t, "", flat);
        for (const auto& [k, n] : flat) {
            SourceLocation w = loc(file, n->source());
            claim(k, w);
            base.set(k, toValue(*n, k, file), w);
        }
    }
    if (const toml::table* t = requireTable("reference")) {
        std::vector<std::pair<std::string, const toml::node*>> flat;
        flatten(*t, "", flat);
        for (const auto& [k, n] : flat) {
            SourceLocation w = loc(file, n->source());
            claim("reference." + k, w);
            baseRef.set(k, toValue(*n, k, file), w);
        }
    }
    OutputOptions outputs;
    if (const toml::table* t = requireTable("outputs")) {
        for (const auto& [k, n] : ordered(*t)) {
            if (k == "exr")
                outputs.exr = getBoolNode(*n, k, file);
            else if (k == "ply")
                outputs.ply = getBoolNode(*n, k, file);
            else if (k == "glb")
                outputs.glb = getBoolNode(*n, k, file);
            else if (k == "solution")
                outputs.solution = getBoolNode(*n, k, file);
            else if (k == "history_error")
                outputs.historyError = getBoolNode(*n, k, file);
            else if (k == "regions") {
                outputs.regions = getBoolNode(*n, k, file);
                outputs.regionsWhere = loc(file, n->source());
            } else if (k == "error_map") {
                outputs.errorMap = getBoolNode(*n, k, file);
                outputs.errorMapWhere = loc(file, n->source());
            } else if (k == "dir") {
                outputs.dir = stringOf(*n, k);
                // Relative to the results store's folder, and inside it.
                fs::path d = fs::path(outputs.dir).lexically_normal();
                bool inside = !outputs.dir.empty() && d.is_relative() && !d.has_root_name() && *d.begin() != "..";
                if (!inside)
                    throwInputError(loc(file, n->source()),
                                    "'outputs.dir' = '{}' must be a relative folder inside the results "
                                    "store's folder (no absolute path, no '..' leading out)",
                                    outputs.dir);
            } else
                throwInputError(loc(file, n->source()),
                                "unknown key 'outputs.{}' (expected exr, ply, glb, solution, "
                                "history_error, error_map, regions, dir)",
                                k);
        }
    }
    if (const toml::table* t = requireTable("limits")) {
        for (const auto& [k, n] : ordered(*t)) {
            if (k == "max_seconds") {
                auto v = n->value<double>();
                if (!v || !(*v >= 0))
                    throwInputError(loc(file, n->source()), "'limits.max_seconds' must be a number >= 0");
                study.limits.maxSeconds = *v;
            } else if (k == "max_memory_mb") {
                auto v = n->value<int64_t>();
                if (!v || *v < 0)
                    throwInputError(loc(file, n->source()), "'limits.max_memory_mb' must be an integer >= 0");
                if (*v > (int64_t(1) << 43))
                    throwInputError(loc(file, n->source()), "'limits.max_memory_mb' is out of range");
                study.limits.maxMemoryBytes = uint64_t(*v) << 20;
            } else if (k == "max_points") {
                auto v = n->value<int64_t>();
                if (!v || *v < 1)
                    throwInputError(loc(file, n->source()), "'limits.max_points' must be an integer >= 1");
                study.limits.maxPoints = uint64_t(*v);
                study.limits.maxPointsWhere = loc(file, n->source());
            } else {
                throwInputError(loc(file, n->source()),
                                "unknown key 'limits.{}' (expected max_seconds, max_memory_mb, max_points)", k);
            }
        }
    }

    // ---- [slurm]: how `hrad sweep --slurm` submits (experiments/slurm.h) ---------------
    // Scalars become Params with their file:line; the list `sbatch` (extra
    // #SBATCH lines) is kept as one string, one line per entry. The keys,
    // types and ranges are checked here by slurmSettingsFromParams, so a typo
    // is reported by every hrad sweep, not only on the cluster.
    if (const toml::table* t = requireTable("slurm")) {
        for (const auto& [k, n] : ordered(*t)) {
            SourceLocation w = loc(file, n->source());
            if (const toml::array* a = n->as_array()) {
                std::string lines;
                for (const toml::node& e : *a) {
                    auto v = e.as_string();
                    if (!v) throwInputError(loc(file, e.source()), "'slurm.{}' must be a list of strings", k);
                    if (!lines.empty()) lines += '\n';
                    lines += v->get();
                }
                study.slurm.set(k, lines, w);
            } else {
                study.slurm.set(k, toValue(*n, "slurm." + k, file), w);
            }
        }
        (void)slurmSettingsFromParams(study.slurm);
    }

    // ---- axes ------------------------------------------------------------------------
    std::vector<Axis> axes;
    if (const toml::table* t = requireTable("sweep")) {
        std::vector<std::pair<std::string, const toml::node*>> flat;
        flatten(*t, "", flat);
        for (const auto& [k, n] : flat) {
            claim(k, loc(file, n->source()));
            axes.push_back(axisFromList(k, *n, file, "sweep axis"));
        }
    }
    if (const toml::node* z = root.get("zip")) {
        std::vector<const toml::table*> groups;
        if (const toml::array* arr = z->as_array()) {
            for (const toml::node& g : *arr) {
                if (!g.as_table())
                    throwInputError(loc(file, g.source()), "each [[zip]] entry must be a table");
                groups.push_back(g.as_table());
            }
        } else if (const toml::table* t = z->as_table()) {
            groups.push_back(t);  // a single [zip] table
        } else {
            throwInputError(loc(file, z->source()), "'zip' must be a table or [[zip]] tables");
        }
        for (const toml::table* g : groups) {
            std::vector<std::pair<std::string, const toml::node*>> flat;
            flatten(*g, "", flat);
            if (flat.empty()) throwInputError(loc(file, g->source()), "empty [[zip]] group");
            Axis group;
            size_t len = 0;
            std::string firstKey;
            for (const auto& [k, n] : flat) {
                claim(k, loc(file, n->source()));
                Axis a = axisFromList(k, *n, file, "zip key");
                if (group.keys.empty()) {
                    len = a.values.size();
                    firstKey = k;
                    group.values.resize(len);
                } else if (a.values.size() != len) {
                    throwInputError(loc(file, n->source()),
                                    "zip key '{}' has {} values but '{}' in the same group has {} "
                                    "(zipped lists must have equal lengths)",
                                    k, a.values.size(), firstKey, len);
                }
                group.keys.push_back(k);
                for (size_t i = 0; i < len; ++i) group.values[i].push_back(a.values[i][0]);
            }
            axes.push_back(std::move(group));
        }
    }
    for (const SceneEntry& se : scenes) {
        auto check = [&](const std::string& key, const toml::node* n) {
            for (const Axis& a : axes)
                for (const auto& k : a.keys)
                    if (k == key)
                        throwInputError(loc(file, n->source()),
                                        "setting '{}' of scene '{}' is also a sweep axis", key,
                                        se.label);
        };
        for (const auto& [k, n] : se.solver) check(k, n);
        for (const auto& [k, n] : se.reference) check("reference." + k, n);
    }
    for (const Axis& a : axes)
        for (const auto& k : a.keys)
            if (k == "scene" || k == "scenes")
                throwInputError(a.values[0][0].second, "vary scenes with the top-level 'scenes' list");

    // ---- expansion: recorded, not performed (Study::point builds one point) -------
    auto ex = std::make_shared<StudyExpansion>();
    for (const SceneEntry& se : scenes) {
        StudyExpansion::Scene sc{se.spec, se.label, {}, {}};
        for (const auto& [k, n] : se.solver) sc.solver.emplace_back(k, toValue(*n, k, file), loc(file, n->source()));
        for (const auto& [k, n] : se.reference) sc.reference.emplace_back(k, toValue(*n, k, file), loc(file, n->source()));
        ex->scenes.push_back(std::move(sc));
    }
    ex->base = base;
    ex->baseRef = baseRef;
    ex->outputs = outputs;
    ex->axes = std::move(axes);
    auto mulSat = [](uint64_t a, uint64_t b) {
        uint64_t r;
        return __builtin_mul_overflow(a, b, &r) ? UINT64_MAX : r;
    };
    for (const Axis& a : ex->axes) ex->combos = mulSat(ex->combos, a.values.size());
    ex->count = mulSat(ex->scenes.size(), ex->combos);
    study.where = loc(file, scenesNode->source());
    study.expansion = std::move(ex);
    return study;
}

uint64_t Study::pointCount() const { return expansion ? expansion->count : 0; }

PointSpec Study::point(uint64_t index) const {
    HRAD_CHECK(expansion && index < expansion->count && expansion->count < UINT64_MAX);
    const StudyExpansion& ex = *expansion;
    const StudyExpansion::Scene& se = ex.scenes[size_t(index / ex.combos)];
    PointSpec p;
    p.index = size_t(index);
    p.scene = se.spec;
    p.sceneLabel = se.label;
    p.settings = ex.base;
    p.reference = ex.baseRef;
    for (const auto& [k, v, w] : se.solver) p.settings.set(k, v, w);
    for (const auto& [k, v, w] : se.reference) p.reference.set(k, v, w);
    p.outputs = ex.outputs;
    // Mixed-radix digits of the combination, last axis least significant.
    uint64_t rest = index % ex.combos;
    std::vector<size_t> digit(ex.axes.size());
    for (size_t a = ex.axes.size(); a-- > 0;) {
        digit[a] = size_t(rest % ex.axes[a].values.size());
        rest /= ex.axes[a].values.size();
    }
    for (size_t a = 0; a < ex.axes.size(); ++a) {
        const Axis& ax = ex.axes[a];
        for (size_t k = 0; k < ax.keys.size(); ++k) {
            const auto& [value, where] = ax.values[digit[a]][k];
            const std::string& key = ax.keys[k];
            if (key.rfind("reference.", 0) == 0)
                p.reference.set(key.substr(10), value, where);
            else
                p.settings.set(key, value, where);
            p.varying.emplace_back(key, Params::valueToString(value));
        }
    }
    return p;
}

std::vector<PointSpec> Study::points() const {
    checkPointCount(*this);
    std::vector<PointSpec> out;
    out.reserve(size_t(pointCount()));
    for (uint64_t i = 0; i < pointCount(); ++i) out.push_back(point(i));
    return out;
}

std::string Study::countDescription() const {
    if (!expansion) return "0";
    std::string out = fmt::format("{} scene(s)", expansion->scenes.size());
    for (const Axis& a : expansion->axes) out += fmt::format(" x {}", a.values.size());
    return out;
}

void checkPointCount(const Study& study) {
    uint64_t n = study.pointCount();
    if (n <= study.limits.maxPoints) return;
    std::string count = n == UINT64_MAX ? std::string("more than 1.8e19") : fmt::format("{}", n);
    std::string set = study.limits.maxPointsWhere.known()
                          ? fmt::format(" (set at {})", study.limits.maxPointsWhere.str())
                          : std::string(" (the default)");
    throwInputError(study.where,
                    "study '{}' expands to {} points ({}), more than sweep.max_points = {}{}; raise "
                    "it with [limits] max_points in the study or hrad sweep --max-points, or "
                    "shorten the sweep",
                    study.name, count, study.countDescription(), study.limits.maxPoints, set);
}

void validateStudyPoint(const Study& study, const PointSpec& p) {
    try {
        validatePoint(p);
    } catch (const InputError& e) {
        throw InputError(e.where(), fmt::format("{} (point {} of study '{}', scene {})", e.message(),
                                                p.index, study.name, p.sceneLabel));
    }
}

void validateStudy(const Study& study) {
    checkPointCount(study);
    for (uint64_t i = 0; i < study.pointCount(); ++i) validateStudyPoint(study, study.point(i));
}

std::string paramsToJsonText(const Params& params) {
    nlohmann::json j = nlohmann::json::object();
    for (const auto& entry : params.entries())  // no structured binding: clang 14 cannot capture one
        std::visit([&](const auto& v) { j[entry.first] = v; }, entry.second.value);
    return j.dump();
}

std::string pointKey(const PointSpec& point) {
    std::string content = "scene=" + point.sceneLabel + "\n";
    if (!scene::isBuiltinName(point.scene)) {
        // The scene file's bytes (not its absolute path) so that shards on
        // other machines agree; included files (MGF 'i') are not hashed.
        std::ifstream in(point.scene, std::ios::binary);
        std::stringstream ss;
        ss << in.rdbuf();
        content += fmt::format("scene_hash={:016x}\n", fnv1a(ss.str()));
    }
    content += "settings=" + paramsToJsonText(point.settings) + "\n";
    content += "reference=" + paramsToJsonText(point.reference) + "\n";
    // Two independent 64-bit FNV-1a hashes: 128 bits, collisions negligible.
    return fmt::format("{:016x}{:016x}", fnv1a(content), fnv1a(content, 0x84222325cbf29ce4ull));
}

std::string describePoint(const PointSpec& p) {
    std::string vary;
    for (const auto& [k, v] : p.varying) vary += fmt::format(" {}={}", k, v);
    return fmt::format("  #{:<4} {}  scene={}{}\n", p.index, pointKey(p).substr(0, 12), p.sceneLabel, vary);
}

std::string describePoints(const Study& study) {
    checkPointCount(study);
    std::string out = fmt::format("study '{}': {} point(s)\n", study.name, study.pointCount());
    for (uint64_t i = 0; i < study.pointCount(); ++i) out += describePoint(study.point(i));
    return out;
}

}  // namespace hrad::experiments
