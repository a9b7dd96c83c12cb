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
// runs also carry slurm_job_id and slurm_array_task_id (from SLURM_ARRAY_JOB_ID
// or SLURM_JOB_ID, and SLURM_ARRAY_TASK_ID; NULL outside Slurm) next to host,
// version and study (the study text's hash): the provenance of every row.
//
// Schema version and refusals: an hrad store has PRAGMA application_id
// 0x48524144 ("HRAD") and its schema version in PRAGMA user_version (see
// store.cpp for the history). Opening checks, before anything is written:
// the SQLite header, PRAGMA quick_check, the application id, a version not
// newer than this hrad's, hrad's four tables with no column hrad does not
// know, and no row without a key. Each failure is an InputError naming the
// file with one sentence (exit 2), never an SQL statement. Older versions are
// migrated when opened for writing (columns added, NULL in older rows).
//
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
    /// Keys of failed points, without those of kind "io" (disk full, I/O
    /// errors: the machine's failure, not the point's), which --resume reruns.
    std::set<std::string> failureKeys() const;
    int64_t count(const std::string& table) const;

    /// Writes <dir>/<table>.csv for every table (header = column names).
    void exportCsv(const std::filesystem::path& dir) const;

    /// Copies rows of another store that are not here yet (runs by key;
    /// failures only for keys without a run). Returns runs added.
    /// Refuses (InputError) to mix rows of different study texts or hrad
    /// versions unless `force`.
    int64_t mergeFrom(const std::filesystem::path& other, bool force = false);

    /// PRAGMA user_version (3 for a store written by this hrad).
    int schemaVersion() const;
    /// Distinct values of the first column of `sql` (NULL as "(none)").
    std::set<std::string> distinct(const std::string& sql) const;

    sqlite3* handle() const { return db_; }

  private:
    void checkStore(bool readOnly);
    void exec(const std::string& sql) const;
    /// Column names of `table` in attached database `schema` ("main", "src").
    std::vector<std::string> columns(const std::string& schema, const std::string& table) const;
    sqlite3* db_ = nullptr;
    std::filesystem::path path_;
};

}  // namespace hrad::experiments
