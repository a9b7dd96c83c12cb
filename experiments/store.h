// The results store: one SQLite file per sweep (or per shard), WAL mode.
//
// Tables (every column is also in the CSV export):
//   studies    (hash PK, name, path, added, text)            the study file's text
//   runs       (key PK, study, point_index, scene, solver, oracle, settings JSON,
//               reference JSON, version, build_type, host, date, wall_s,
//               load_s, visibility_s, cluster_build_s, linking_s, refine_s,
//               gather_s, push_pull_s, solve_s, reference_s, error_s, render_s,
//               peak_rss, elements, leaves, links, rays, form_factors,
//               iterations, converged, links_ss, links_sc, links_cs, links_cc, l1_lum, l2_lum, linf_lum, l1_rgb,
//               l2_rgb, linf_rgb, mc_stderr_l2_lum, mc_stderr_l2_rgb, regions,
//               reference_desc, bytes JSON, summary JSON)
//   iterations (run_key, iteration, stage, eps, links, elements, leaves,
//               refined_links, rays, form_factors, residual, refine_s,
//               gather_s, push_pull_s, element_bytes, link_bytes, l2_lum;
//               PK (run_key, iteration))
//   failures   (key PK, study, point_index, scene, settings JSON, kind, message,
//               version, host, date, wall_s, peak_rss)
// A point's run row and its iterations are written in one transaction, so a
// killed sweep never leaves a half-written run. Only the parent process of a
// sweep writes; children hand their summary over in a file.
#pragma once

#include <cstdint>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

struct sqlite3;

namespace hrad::experiments {

struct FailureRecord {
    std::string key;
    std::string study;
    int64_t pointIndex = -1;
    std::string scene;
    std::string settingsJson;
    std::string kind;  ///< "error", "input", "timeout", "memory", "signal"
    std::string message;
    double wallSeconds = 0.0;
    uint64_t peakRss = 0;
};

class ResultStore {
  public:
    /// Opens (creating if needed) the store and its schema; WAL journal.
    explicit ResultStore(const std::filesystem::path& path, bool readOnly = false);
    ~ResultStore();
    ResultStore(const ResultStore&) = delete;
    ResultStore& operator=(const ResultStore&) = delete;

    /// Records a study's text once (keyed by a hash of the text); returns the hash.
    std::string addStudy(const std::string& name, const std::string& path, const std::string& text);

    /// Inserts one finished run (its row and its iterations) in one
    /// transaction and removes an earlier failure of the same key.
    void addRun(const std::string& key, const std::string& study, int64_t pointIndex,
                const nlohmann::json& summary);
    void addFailure(const FailureRecord& f);

    std::set<std::string> runKeys() const;
    std::set<std::string> failureKeys() const;
    int64_t count(const std::string& table) const;

    /// Writes <dir>/<table>.csv for every table (header = column names).
    void exportCsv(const std::filesystem::path& dir) const;

    /// Copies rows of another store that are not here yet (runs by key;
    /// failures only for keys without a run). Returns runs added.
    int64_t mergeFrom(const std::filesystem::path& other);

    sqlite3* handle() const { return db_; }

  private:
    void exec(const std::string& sql) const;
    /// Column names of `table` in attached database `schema` ("main", "src").
    std::vector<std::string> columns(const std::string& schema, const std::string& table) const;
    sqlite3* db_ = nullptr;
    std::filesystem::path path_;
};

}  // namespace hrad::experiments
