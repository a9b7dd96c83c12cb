#include "experiments/store.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <unistd.h>

#include <sqlite3.h>

#include <fstream>

#include <fmt/format.h>

#include "core/error.h"
#include "core/safe_file.h"
#include "experiments/runner.h"
#include "hr/solver.h"

namespace hrad::experiments {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS studies (
  hash TEXT PRIMARY KEY, name TEXT, path TEXT, added TEXT, text TEXT);
CREATE TABLE IF NOT EXISTS runs (
  key TEXT PRIMARY KEY, study TEXT, point_index INTEGER, scene TEXT, solver TEXT,
  oracle TEXT, eps REAL, settings TEXT, reference TEXT,
  version TEXT, build_type TEXT, host TEXT, date TEXT, wall_s REAL,
  load_s REAL, visibility_s REAL, cluster_build_s REAL, linking_s REAL, refine_s REAL,
  gather_s REAL, push_pull_s REAL, solve_s REAL, reference_s REAL, error_s REAL, render_s REAL,
  peak_rss INTEGER, elements INTEGER, leaves INTEGER, links INTEGER, rays INTEGER,
  form_factors INTEGER, iterations INTEGER, converged INTEGER,
  links_ss INTEGER, links_sc INTEGER, links_cs INTEGER, links_cc INTEGER,
  l1_lum REAL, l2_lum REAL, linf_lum REAL, l1_rgb REAL, l2_rgb REAL, linf_rgb REAL,
  mc_stderr_l2_lum REAL, mc_stderr_l2_rgb REAL, regions INTEGER, reference_desc TEXT,
  bytes TEXT, summary TEXT,
  l1_reflected_lum REAL, l2_reflected_lum REAL, l1_nonemitter_lum REAL,
  l2_nonemitter_lum REAL, mean_ratio_nonemitter REAL, error_estimate REAL, residual REAL,
  slurm_job_id TEXT, slurm_array_task_id INTEGER, noise_estimate REAL,
  noise_l2_nonemitter REAL, error_estimate_leaves REAL, error_estimate_points REAL,
  resolved_settings TEXT, estimate_l2_nonemitter REAL, estimate_l1_reflected REAL,
  estimate_mean_ratio REAL, true_l2_nonemitter REAL, target_error REAL, target_met INTEGER);
CREATE TABLE IF NOT EXISTS iterations (
  run_key TEXT, iteration INTEGER, stage INTEGER, eps REAL, links INTEGER,
  elements INTEGER, leaves INTEGER, refined_links INTEGER, rays INTEGER,
  form_factors INTEGER, residual REAL, refine_s REAL, gather_s REAL, push_pull_s REAL,
  element_bytes INTEGER, link_bytes INTEGER, l2_lum REAL,
  PRIMARY KEY (run_key, iteration));
CREATE TABLE IF NOT EXISTS failures (
  key TEXT PRIMARY KEY, study TEXT, point_index INTEGER, scene TEXT, settings TEXT,
  kind TEXT, message TEXT, version TEXT, host TEXT, date TEXT, wall_s REAL, peak_rss INTEGER,
  slurm_job_id TEXT, slurm_array_task_id INTEGER);
)sql";

/// PRAGMA application_id of an hrad store ("HRAD" in ASCII) and the schema
/// version in PRAGMA user_version (both in the SQLite file header,
/// https://www.sqlite.org/fileformat.html section 1.3). Versions:
///   1  the first stores (no application id, user_version 0)
///   2  runs gain the reflected/non-emitter errors, error estimate, residual
///      (still user_version 0; told apart from 1 by its columns)
///   3  application id and user_version set; runs and failures gain
///      slurm_job_id and slurm_array_task_id (provenance)
///   4  runs gain noise_estimate and noise_l2_nonemitter (the solve's own
///      ray noise, hr/noise.h)
///   5  runs gain error_estimate_leaves and error_estimate_points (the
///      error of the leaves' averages and of the irradiance at the leaves'
///      points, hr/receiver_error.h leafAverageError)
///   6  runs gain resolved_settings: every key the run read, with the value
///      it used (defaults and resolved "auto"s included), as a JSON object
///      (core/params records; summary.resolved_settings)
///   7  runs gain the residual error estimate (estimate_l2_nonemitter,
///      estimate_l1_reflected, estimate_mean_ratio; reference/error_estimate.h),
///      the non-emitter L2 with a Monte Carlo reference's noise removed
///      (true_l2_nonemitter), and a target-error solve's target and outcome
/// Older versions are migrated when opened for writing (missing columns are
/// added, NULL in old rows) and read as they are when opened read-only.
constexpr int32_t kApplicationId = 0x48524144;
constexpr int kSchemaVersion = 7;

const char* kTables[] = {"studies", "runs", "iterations", "failures"};

/// Columns added to `runs` after the first stores were written (the error
/// of the reflected part and of non-emitting surfaces, reference/metrics.h;
/// the solver's error and noise estimates and final residual). Stores without them get
/// them on opening for writing (NULL in the old rows; the values are in each
/// row's `summary` too).
const std::pair<const char*, const char*> kAddedRunColumns[] = {{"l1_reflected_lum", "REAL"},
                                                                {"l2_reflected_lum", "REAL"},
                                                                {"l1_nonemitter_lum", "REAL"},
                                                                {"l2_nonemitter_lum", "REAL"},
                                                                {"mean_ratio_nonemitter", "REAL"},
                                                                {"error_estimate", "REAL"},
                                                                {"residual", "REAL"},
                                                                {"slurm_job_id", "TEXT"},
                                                                {"slurm_array_task_id", "INTEGER"},
                                                                {"noise_estimate", "REAL"},
                                                                {"noise_l2_nonemitter", "REAL"},
                                                                {"error_estimate_leaves", "REAL"},
                                                                {"error_estimate_points", "REAL"},
                                                                {"resolved_settings", "TEXT"},
                                                                {"estimate_l2_nonemitter", "REAL"},
                                                                {"estimate_l1_reflected", "REAL"},
                                                                {"estimate_mean_ratio", "REAL"},
                                                                {"true_l2_nonemitter", "REAL"},
                                                                {"target_error", "REAL"},
                                                                {"target_met", "INTEGER"}};
const std::pair<const char*, const char*> kAddedFailureColumns[] = {
    {"slurm_job_id", "TEXT"}, {"slurm_array_task_id", "INTEGER"}};

/// The Slurm job of this process ("" / -1 outside Slurm): the array job id
/// and task id for array tasks, else the job id.
std::pair<json, json> slurmProvenance() {
    const char* arrayJob = std::getenv("SLURM_ARRAY_JOB_ID");
    const char* job = std::getenv("SLURM_JOB_ID");
    const char* task = std::getenv("SLURM_ARRAY_TASK_ID");
    json j = arrayJob ? json(arrayJob) : job ? json(job) : json(nullptr);
    json t = nullptr;
    if (task) {
        char* end = nullptr;
        long long v = std::strtoll(task, &end, 10);
        if (end && *end == 0 && end != task) t = int64_t(v);
    }
    return {j, t};
}

/// Disk full, I/O errors, a read-only file: the machine's failure, reported as
/// IoError naming the database (exit 2; a sweep records kind "io").
bool isIoCode(int rc) {
    const int primary = rc & 0xff;
    return primary == SQLITE_FULL || primary == SQLITE_IOERR || primary == SQLITE_READONLY ||
           primary == SQLITE_CANTOPEN;
}

[[noreturn]] void throwSqlite(sqlite3* db, int rc, const std::string& what) {
    const char* file = db ? sqlite3_db_filename(db, "main") : nullptr;
    if (isIoCode(rc))
        throw IoError(file && *file ? file : "results store", fmt::format("{}: {}", what, sqlite3_errstr(rc)));
    throw Error("sqlite: " + what);
}

/// A prepared statement with positional binding of JSON values.
class Stmt {
  public:
    Stmt(sqlite3* db, const std::string& sql) : db_(db) {
        if (sqlite3_prepare_v2(db, sql.c_str(), -1, &st_, nullptr) != SQLITE_OK)
            throw Error(fmt::format("sqlite: {} in: {}", sqlite3_errmsg(db), sql));
    }
    ~Stmt() { sqlite3_finalize(st_); }
    Stmt& bind(int i, const json& v) {
        if (v.is_null())
            sqlite3_bind_null(st_, i);
        else if (v.is_boolean())
            sqlite3_bind_int64(st_, i, v.get<bool>() ? 1 : 0);
        else if (v.is_number_integer())
            sqlite3_bind_int64(st_, i, v.get<int64_t>());
        else if (v.is_number_unsigned())
            sqlite3_bind_int64(st_, i, int64_t(v.get<uint64_t>()));
        else if (v.is_number())
            sqlite3_bind_double(st_, i, v.get<double>());
        else if (v.is_string())
            sqlite3_bind_text(st_, i, v.get_ref<const std::string&>().c_str(), -1, SQLITE_TRANSIENT);
        else
            sqlite3_bind_text(st_, i, v.dump().c_str(), -1, SQLITE_TRANSIENT);
        return *this;
    }
    bool step() {
        int rc = sqlite3_step(st_);
        if (rc == SQLITE_ROW) return true;
        if (rc == SQLITE_DONE) return false;
        throwSqlite(db_, rc, sqlite3_errmsg(db_));
    }
    void reset() {
        sqlite3_reset(st_);
        sqlite3_clear_bindings(st_);
    }
    sqlite3_stmt* get() { return st_; }

  private:
    sqlite3* db_;
    sqlite3_stmt* st_ = nullptr;
};

json at(const json& j, const char* a, const char* b = nullptr) {
    auto it = j.find(a);
    if (it == j.end()) return nullptr;
    if (!b) return *it;
    auto jt = it->find(b);
    return jt == it->end() ? json(nullptr) : *jt;
}
json at(const json& j, const char* a, const char* b, const char* c) {
    json mid = at(j, a, b);
    return mid.is_object() ? at(mid, c) : json(nullptr);
}

std::string insertSql(const char* table, const std::vector<const char*>& cols,
                      const char* verb = "INSERT") {
    std::string names, marks;
    for (size_t i = 0; i < cols.size(); ++i) {
        names += (i ? ", " : "") + std::string(cols[i]);
        marks += i ? ", ?" : "?";
    }
    return fmt::format("{} INTO {} ({}) VALUES ({})", verb, table, names, marks);
}

std::string csvField(sqlite3_stmt* st, int c) {
    switch (sqlite3_column_type(st, c)) {
        case SQLITE_NULL: return "";
        case SQLITE_INTEGER: return std::to_string(sqlite3_column_int64(st, c));
        case SQLITE_FLOAT: return fmt::format("{}", sqlite3_column_double(st, c));
        default: {
            const char* t = reinterpret_cast<const char*>(sqlite3_column_text(st, c));
            std::string s = t ? t : "";
            if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
            std::string q = "\"";
            for (char ch : s) q += ch == '"' ? std::string("\"\"") : std::string(1, ch);
            return q + "\"";
        }
    }
}

uint64_t fnv1a(const std::string& s) {
    uint64_t h = 1469598103934665603ull;
    for (unsigned char c : s) {
        h ^= c;
        h *= 1099511628211ull;
    }
    return h;
}

}  // namespace

ResultStore::ResultStore(const fs::path& path, bool readOnly) : path_(path) {
    SourceLocation where{path.string(), 0, 0};
    // Not SQLite at all (or cut short inside its 100-byte header): say so
    // before SQLite answers with "file is not a database" to a statement.
    std::error_code ec;
    if (path.empty()) throwInputError({"command line (--store)", 0, 0}, "the store name is empty");
    if (fs::exists(path, ec) && !fs::is_regular_file(path, ec))
        throwInputError(where, "is not a results store: it is {}, expected an SQLite file",
                        fs::is_directory(path, ec) ? "a folder" : "not a regular file");
    if (fs::exists(path, ec) && fs::is_regular_file(path, ec)) {
        uintmax_t size = fs::file_size(path, ec);
        if (size == 0 && readOnly)
            throwInputError(where, "the results store is empty (0 bytes): not an hrad results "
                                   "store, or one cut short before its first write");
        if (size > 0) {
            char head[16] = {};
            std::ifstream in(path, std::ios::binary);
            in.read(head, sizeof head);
            if (in.gcount() < 16 || std::memcmp(head, "SQLite format 3", 16) != 0)
                throwInputError(where, "not an hrad results store: the file is not an SQLite "
                                       "database (its first bytes are not the SQLite header)");
            if (size < 100)
                throwInputError(where, "the results store is truncated ({} bytes, shorter than "
                                       "the 100-byte SQLite header)", size);
        }
    } else if (readOnly) {
        throwInputError(where, "no such results store");
    }
    int flags = readOnly ? SQLITE_OPEN_READONLY : (SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
    if (!readOnly) {
        // A folder that cannot be written: SQLite could not create its
        // journal and would call a sound store corrupt (issue 64).
        fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
        fs::create_directories(dir, ec);
        if (::access(dir.c_str(), W_OK | X_OK) != 0)
            throw IoError(dir, fmt::format("cannot write into the folder of the results store "
                                           "{} ({}); it is needed for the store's journal",
                                           path.string(), std::strerror(errno)));
    }
    if (sqlite3_open_v2(path.string().c_str(), &db_, flags, nullptr) != SQLITE_OK) {
        std::string msg = db_ ? sqlite3_errmsg(db_) : "out of memory";
        sqlite3_close(db_);
        db_ = nullptr;
        throw Error(fmt::format("cannot open results store {}: {}", path.string(), msg));
    }
    sqlite3_busy_timeout(db_, 30000);
    try {
        checkStore(readOnly);
    } catch (...) {
        sqlite3_close(db_);
        db_ = nullptr;
        throw;
    }
}

void ResultStore::checkStore(bool readOnly) {
    SourceLocation where{path_.string(), 0, 0};
    // A single value of a PRAGMA or query; any SQLite failure here means the
    // file is damaged (or not a database): one sentence, exit 2.
    auto scalar = [&](const std::string& sql) -> std::string {
        sqlite3_stmt* st = nullptr;
        int rc = sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr);
        std::string out;
        if (rc == SQLITE_OK) rc = sqlite3_step(st);
        if (rc == SQLITE_ROW) {
            const char* t = reinterpret_cast<const char*>(sqlite3_column_text(st, 0));
            out = t ? t : "";
        } else if (rc != SQLITE_DONE) {
            std::string msg = sqlite3_errmsg(db_);
            sqlite3_finalize(st);
            throwInputError(where, "the results store is corrupt or not an SQLite database "
                                   "(SQLite reports: {}); restore it from a copy or merge its "
                                   "shard stores again", msg);
        }
        sqlite3_finalize(st);
        return out;
    };
    std::string check = scalar("PRAGMA quick_check(1)");
    if (check != "ok")
        throwInputError(where, "the results store is corrupt (SQLite integrity check: {}); "
                               "restore it from a copy or merge its shard stores again", check);
    int64_t appId = std::stoll(scalar("PRAGMA application_id"));
    int64_t version = std::stoll(scalar("PRAGMA user_version"));
    if (appId != 0 && appId != kApplicationId)
        throwInputError(where, "not an hrad results store: it is an SQLite database of another "
                               "application (application_id 0x{:08x})", uint32_t(appId));
    if (version > kSchemaVersion)
        throwInputError(where, "the results store has schema version {}, written by a newer "
                               "hrad; this hrad reads versions up to {}", version, kSchemaVersion);

    // The tables and columns this hrad writes (kSchema in a scratch database).
    sqlite3* ref = nullptr;
    sqlite3_open(":memory:", &ref);
    sqlite3_exec(ref, kSchema, nullptr, nullptr, nullptr);
    auto columnsOf = [](sqlite3* db, const std::string& table) {
        std::vector<std::string> out;
        sqlite3_stmt* st = nullptr;
        sqlite3_prepare_v2(db, fmt::format("PRAGMA table_info({})", table).c_str(), -1, &st, nullptr);
        while (sqlite3_step(st) == SQLITE_ROW) {
            const char* n = reinterpret_cast<const char*>(sqlite3_column_text(st, 1));
            if (n) out.emplace_back(n);
        }
        sqlite3_finalize(st);
        return out;
    };
    std::vector<std::string> tables;
    {
        sqlite3_stmt* st = nullptr;
        sqlite3_prepare_v2(db_, "SELECT name FROM sqlite_master WHERE type = 'table' AND name NOT LIKE 'sqlite_%'",
                           -1, &st, nullptr);
        while (sqlite3_step(st) == SQLITE_ROW)
            tables.emplace_back(reinterpret_cast<const char*>(sqlite3_column_text(st, 0)));
        sqlite3_finalize(st);
    }
    std::string problem;
    if (!tables.empty()) {
        bool anyOurs = false;
        for (const char* t : kTables)
            if (std::find(tables.begin(), tables.end(), t) != tables.end()) anyOurs = true;
        if (!anyOurs) {
            std::string list;
            for (const auto& t : tables) list += (list.empty() ? "" : ", ") + t;
            problem = fmt::format("it has the tables {} and none of hrad's (studies, runs, "
                                  "iterations, failures)", list);
        }
        for (const char* t : kTables) {
            if (!problem.empty()) break;
            if (std::find(tables.begin(), tables.end(), t) == tables.end()) {
                problem = fmt::format("it has no table '{}'", t);
                break;
            }
            std::vector<std::string> mine = columnsOf(ref, t), theirs = columnsOf(db_, t);
            for (const auto& c : theirs)
                if (std::find(mine.begin(), mine.end(), c) == mine.end()) {
                    problem = fmt::format("its table '{}' has a column '{}' that hrad does not write", t, c);
                    break;
                }
            if (!problem.empty()) break;
            // Columns added in later versions may be missing (migrated below); others may not.
            auto added = [&](const std::string& c) {
                for (const auto& a : kAddedRunColumns)
                    if (std::string(t) == "runs" && c == a.first) return true;
                for (const auto& a : kAddedFailureColumns)
                    if (std::string(t) == "failures" && c == a.first) return true;
                return false;
            };
            for (const auto& c : mine)
                if (std::find(theirs.begin(), theirs.end(), c) == theirs.end() && !added(c)) {
                    problem = fmt::format("its table '{}' lacks the column '{}'", t, c);
                    break;
                }
        }
    }
    sqlite3_close(ref);
    if (!problem.empty()) throwInputError(where, "not an hrad results store: {}", problem);
    // Rows without a key cannot be skipped, merged or resumed.
    if (!tables.empty())
        for (auto [table, key] : {std::pair{"runs", "key"}, std::pair{"failures", "key"},
                                  std::pair{"studies", "hash"}, std::pair{"iterations", "run_key"}}) {
            std::string rowid = scalar(fmt::format("SELECT rowid FROM {} WHERE {} IS NULL LIMIT 1", table, key));
            if (!rowid.empty())
                throwInputError(where, "the results store was modified outside hrad: a row of "
                                       "table '{}' (rowid {}) has no {} (NULL)", table, rowid, key);
        }

    if (readOnly) return;
    exec("PRAGMA journal_mode=WAL");
    exec("PRAGMA synchronous=NORMAL");
    exec(kSchema);
    std::vector<std::string> have = columns("main", "runs");
    for (const auto& [name, type] : kAddedRunColumns)
        if (std::find(have.begin(), have.end(), name) == have.end())
            exec(fmt::format("ALTER TABLE runs ADD COLUMN {} {}", name, type));
    have = columns("main", "failures");
    for (const auto& [name, type] : kAddedFailureColumns)
        if (std::find(have.begin(), have.end(), name) == have.end())
            exec(fmt::format("ALTER TABLE failures ADD COLUMN {} {}", name, type));
    exec(fmt::format("PRAGMA application_id = {}", kApplicationId));
    exec(fmt::format("PRAGMA user_version = {}", kSchemaVersion));
}

int ResultStore::schemaVersion() const {
    Stmt st(db_, "PRAGMA user_version");
    st.step();
    return int(sqlite3_column_int64(st.get(), 0));
}

std::vector<std::string> ResultStore::columns(const std::string& schema,
                                              const std::string& table) const {
    std::vector<std::string> out;
    Stmt st(db_, fmt::format("PRAGMA {}.table_info({})", schema, table));
    while (sqlite3_step(st.get()) == SQLITE_ROW) {
        const char* n = reinterpret_cast<const char*>(sqlite3_column_text(st.get(), 1));
        if (n) out.emplace_back(n);
    }
    return out;
}

ResultStore::~ResultStore() {
    if (db_) sqlite3_close(db_);
}

void ResultStore::exec(const std::string& sql) const {
    char* err = nullptr;
    const int rc = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &err);
    if (rc != SQLITE_OK) {
        std::string msg = err ? err : "?";
        sqlite3_free(err);
        if (isIoCode(rc)) throw IoError(path_, fmt::format("cannot write the results store: {}", msg));
        throw Error(fmt::format("sqlite ({}): {}", path_.string(), msg));
    }
}

std::string ResultStore::addStudy(const std::string& name, const std::string& path,
                                  const std::string& text) {
    std::string hash = fmt::format("{:016x}", fnv1a(text));
    Stmt st(db_, insertSql("studies", {"hash", "name", "path", "added", "text"}, "INSERT OR IGNORE"));
    st.bind(1, hash).bind(2, name).bind(3, path).bind(4, isoDateUtc()).bind(5, text);
    st.step();
    return hash;
}

void ResultStore::addRun(const std::string& key, const std::string& study, int64_t pointIndex,
                         const json& s) {
    static const std::vector<const char*> cols = {"key",
                                                  "study",
                                                  "point_index",
                                                  "scene",
                                                  "solver",
                                                  "oracle",
                                                  "eps",
                                                  "settings",
                                                  "reference",
                                                  "version",
                                                  "build_type",
                                                  "host",
                                                  "date",
                                                  "wall_s",
                                                  "load_s",
                                                  "visibility_s",
                                                  "cluster_build_s",
                                                  "linking_s",
                                                  "refine_s",
                                                  "gather_s",
                                                  "push_pull_s",
                                                  "solve_s",
                                                  "reference_s",
                                                  "error_s",
                                                  "render_s",
                                                  "peak_rss",
                                                  "elements",
                                                  "leaves",
                                                  "links",
                                                  "rays",
                                                  "form_factors",
                                                  "iterations",
                                                  "converged",
                                                  "links_ss",
                                                  "links_sc",
                                                  "links_cs",
                                                  "links_cc",
                                                  "l1_lum",
                                                  "l2_lum",
                                                  "linf_lum",
                                                  "l1_rgb",
                                                  "l2_rgb",
                                                  "linf_rgb",
                                                  "mc_stderr_l2_lum",
                                                  "mc_stderr_l2_rgb",
                                                  "regions",
                                                  "reference_desc",
                                                  "bytes",
                                                  "summary",
                                                  "l1_reflected_lum",
                                                  "l2_reflected_lum",
                                                  "l1_nonemitter_lum",
                                                  "l2_nonemitter_lum",
                                                  "mean_ratio_nonemitter",
                                                  "error_estimate",
                                                  "residual",
                                                  "slurm_job_id",
                                                  "slurm_array_task_id",
                                                  "noise_estimate",
                                                  "noise_l2_nonemitter",
                                                  "error_estimate_leaves",
                                                  "error_estimate_points",
                                                  "resolved_settings",
                                                  "estimate_l2_nonemitter",
                                                  "estimate_l1_reflected",
                                                  "estimate_mean_ratio",
                                                  "true_l2_nonemitter",
                                                  "target_error",
                                                  "target_met"};
    auto [slurmJob, slurmTask] = slurmProvenance();
    json settings = at(s, "settings");
    json oracle = nullptr;
    if (at(s, "solver") == "hr")
        oracle = settings.contains("hr.oracle") ? settings["hr.oracle"] : json(hr::HrSettings{}.oracle);
    json eps = settings.is_object() && settings.contains("oracle.eps") ? settings["oracle.eps"] : json(nullptr);
    // What the run used, defaults included (summary.resolved_settings; older
    // summaries have none): the oracle's eps even when it was not set.
    json resolved = at(s, "resolved_settings");
    if (eps.is_null() && resolved.is_object() && resolved.contains("oracle.eps"))
        eps = resolved["oracle.eps"];
    std::vector<json> vals = {key,
                              study,
                              pointIndex,
                              at(s, "scene_label"),
                              at(s, "solver"),
                              oracle,
                              eps,
                              settings.dump(),
                              at(s, "reference_settings").dump(),
                              at(s, "hrad_version"),
                              at(s, "build_type"),
                              at(s, "host"),
                              at(s, "date"),
                              at(s, "wall_seconds"),
                              at(s, "timings", "load"),
                              at(s, "timings", "visibility_build"),
                              at(s, "timings", "cluster_build"),
                              at(s, "timings", "linking"),
                              at(s, "timings", "refine"),
                              at(s, "timings", "gather"),
                              at(s, "timings", "push_pull"),
                              at(s, "timings", "solve_total"),
                              at(s, "timings", "reference"),
                              at(s, "timings", "error"),
                              at(s, "timings", "render"),
                              at(s, "memory", "peak_rss"),
                              at(s, "counts", "elements"),
                              at(s, "counts", "leaves"),
                              at(s, "counts", "links"),
                              at(s, "counts", "rays"),
                              at(s, "counts", "form_factors"),
                              at(s, "counts", "iterations"),
                              at(s, "converged"),
                              at(s, "counts", "links_ss"),
                              at(s, "counts", "links_sc"),
                              at(s, "counts", "links_cs"),
                              at(s, "counts", "links_cc"),
                              at(s, "error", "l1_lum"),
                              at(s, "error", "l2_lum"),
                              at(s, "error", "linf_lum"),
                              at(s, "error", "l1_rgb"),
                              at(s, "error", "l2_rgb"),
                              at(s, "error", "linf_rgb"),
                              at(s, "error", "mc_stderr_l2_lum"),
                              at(s, "error", "mc_stderr_l2_rgb"),
                              at(s, "error", "regions"),
                              at(s, "error", "reference"),
                              at(s, "memory").dump(),
                              s.dump(),
                              at(s, "error", "l1_reflected_lum"),
                              at(s, "error", "l2_reflected_lum"),
                              at(s, "error", "l1_nonemitter_lum"),
                              at(s, "error", "l2_nonemitter_lum"),
                              at(s, "error", "mean_ratio_nonemitter"),
                              at(s, "error_estimate"),
                              at(s, "residual"),
                              slurmJob,
                              slurmTask,
                              at(s, "noise_estimate"),
                              at(s, "noise", "l2_nonemitter_direct"),
                              at(s, "error_estimate_leaves"),
                              at(s, "error_estimate_points"),
                              resolved.is_object() ? json(resolved.dump()) : json(nullptr),
                              at(s, "estimate", "l2_nonemitter"),
                              at(s, "estimate", "l1_reflected"),
                              at(s, "estimate", "mean_ratio_nonemitter"),
                              at(s, "error", "estimate", "true_l2_nonemitter"),
                              at(s, "target", "target"),
                              at(s, "target", "met")};
    exec("BEGIN IMMEDIATE");
    try {
        Stmt st(db_, insertSql("runs", cols, "INSERT OR REPLACE"));
        for (size_t i = 0; i < vals.size(); ++i) st.bind(int(i + 1), vals[i]);
        st.step();
        Stmt del(db_, "DELETE FROM iterations WHERE run_key = ?");
        del.bind(1, key).step();
        Stmt it(db_, insertSql("iterations",
                               {"run_key", "iteration", "stage", "eps", "links", "elements",
                                "leaves", "refined_links", "rays", "form_factors", "residual",
                                "refine_s", "gather_s", "push_pull_s", "element_bytes",
                                "link_bytes", "l2_lum"}));
        json hist = at(s, "history");
        if (hist.is_array()) {
            for (const json& h : hist) {
                it.reset();
                it.bind(1, key);
                int i = 2;
                for (const char* f : {"iteration", "stage", "eps", "links", "elements", "leaves",
                                      "refined_links", "rays", "form_factors", "residual",
                                      "refine_s", "gather_s", "push_pull_s", "element_bytes",
                                      "link_bytes", "l2_lum"})
                    it.bind(i++, at(h, f));
                it.step();
            }
        }
        Stmt fdel(db_, "DELETE FROM failures WHERE key = ?");
        fdel.bind(1, key).step();
        exec("COMMIT");
        // Each run copied into the database at once (SQLite checkpoints
        // only past 1000 pages: a sweep's WAL grew while the file stayed
        // at 4 KB, issue 64); passive: never waits for a reader.
        sqlite3_wal_checkpoint_v2(db_, nullptr, SQLITE_CHECKPOINT_PASSIVE, nullptr, nullptr);
    } catch (...) {
        // A failed COMMIT (disk full) may have rolled back already: a second
        // ROLLBACK would replace the real error with "no transaction is active".
        if (!sqlite3_get_autocommit(db_)) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
        throw;
    }
}

void ResultStore::addFailure(const FailureRecord& f) {
    Stmt st(db_, insertSql("failures",
                           {"key", "study", "point_index", "scene", "settings", "kind", "message",
                            "version", "host", "date", "wall_s", "peak_rss", "slurm_job_id",
                            "slurm_array_task_id"},
                           "INSERT OR REPLACE"));
    auto [slurmJob, slurmTask] = slurmProvenance();
    st.bind(1, f.key).bind(2, f.study).bind(3, f.pointIndex).bind(4, f.scene);
    st.bind(5, f.settingsJson).bind(6, f.kind).bind(7, f.message).bind(8, codeVersion());
    st.bind(9, hostName()).bind(10, isoDateUtc()).bind(11, f.wallSeconds).bind(12, f.peakRss);
    st.step();
}

std::set<std::string> ResultStore::runKeys() const {
    std::set<std::string> out;
    Stmt st(db_, "SELECT key FROM runs");
    while (st.step()) out.insert(reinterpret_cast<const char*>(sqlite3_column_text(st.get(), 0)));
    return out;
}

std::set<std::string> ResultStore::failureKeys() const {
    std::set<std::string> out;
    Stmt st(db_, "SELECT key FROM failures WHERE kind IS NOT 'io'");
    while (st.step()) out.insert(reinterpret_cast<const char*>(sqlite3_column_text(st.get(), 0)));
    return out;
}

int64_t ResultStore::count(const std::string& table) const {
    Stmt st(db_, "SELECT COUNT(*) FROM " + table);
    st.step();
    return sqlite3_column_int64(st.get(), 0);
}

void ResultStore::exportCsv(const fs::path& dir) const {
    ensureOutputFolder(dir, "command line (--csv)");
    for (const char* table : kTables) {
        fs::path file = dir / (std::string(table) + ".csv");
        // A temporary file renamed over the target: never through a symlink,
        // and a full disk is an error naming the file, not a 0-byte CSV.
        writeThroughTemp(file, [&](const fs::path& tmp) {
            std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
            Stmt st(db_, fmt::format("SELECT * FROM {} ORDER BY rowid", table));
            int n = sqlite3_column_count(st.get());
            for (int c = 0; c < n; ++c) out << (c ? "," : "") << sqlite3_column_name(st.get(), c);
            out << "\n";
            while (st.step()) {
                for (int c = 0; c < n; ++c) out << (c ? "," : "") << csvField(st.get(), c);
                out << "\n";
            }
            out.close();
            if (!out) throw IoError(file, "cannot write the CSV export (disk full?)");
        });
    }
}

std::set<std::string> ResultStore::distinct(const std::string& sql) const {
    std::set<std::string> out;
    Stmt st(db_, sql);
    while (st.step()) {
        const char* t = reinterpret_cast<const char*>(sqlite3_column_text(st.get(), 0));
        out.insert(t ? t : "(none)");
    }
    return out;
}

int64_t ResultStore::mergeFrom(const fs::path& other, bool force) {
    // The source passes the same checks as any store (hrad's, readable,
    // not newer) before it is attached.
    { ResultStore check(other, true); }
    int64_t before = count("runs");
    const char* studiesSql = "SELECT study FROM runs UNION SELECT study FROM failures";
    const char* versionsSql = "SELECT version FROM runs UNION SELECT version FROM failures";
    if (!force) {
        ResultStore src(other, true);
        auto join = [](const std::set<std::string>& a) {
            std::string out;
            for (const auto& x : a) out += (out.empty() ? "" : ", ") + x;
            return out;
        };
        for (auto [sql, what] : {std::pair{studiesSql, "study texts (hashes)"},
                                 std::pair{versionsSql, "hrad versions"}}) {
            std::set<std::string> mine = distinct(sql), theirs = src.distinct(sql), all = mine;
            all.insert(theirs.begin(), theirs.end());
            if (all.size() > 1)
                throwInputError({other.string(), 0, 0},
                                "refusing to merge into {}: the rows would mix {} ({} here, {} "
                                "there); pass --force to merge them anyway",
                                path_.string(), what, mine.empty() ? "none" : join(mine),
                                join(theirs));
        }
    }
    Stmt attach(db_, "ATTACH DATABASE ? AS src");
    attach.bind(1, other.string()).step();
    try {
        exec("BEGIN IMMEDIATE");
        // By column name, the columns both stores have: a store written
        // before columns were added merges with NULL in them.
        auto copy = [&](const char* table, const char* where) {
            std::vector<std::string> mine = columns("main", table), theirs = columns("src", table);
            std::string cols;
            for (const std::string& c : mine)
                if (std::find(theirs.begin(), theirs.end(), c) != theirs.end())
                    cols += (cols.empty() ? "" : ", ") + c;
            if (cols.empty()) return;
            exec(fmt::format("INSERT OR IGNORE INTO {0} ({1}) SELECT {1} FROM src.{0} {2}", table,
                             cols, where));
        };
        copy("studies", "");
        copy("runs", "");
        copy("iterations", "WHERE run_key IN (SELECT key FROM runs)");
        copy("failures", "WHERE key NOT IN (SELECT key FROM runs)");
        exec("DELETE FROM failures WHERE key IN (SELECT key FROM runs)");
        exec("COMMIT");
    } catch (...) {
        sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
        exec("DETACH DATABASE src");
        throw;
    }
    exec("DETACH DATABASE src");
    return count("runs") - before;
}

}  // namespace hrad::experiments
