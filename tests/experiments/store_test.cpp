// Results stores that are not hrad's, are corrupt, newer or older, or hold
// rows without keys (issue 16 item 6), and the provenance and merge checks
// of stores written on a cluster (issue 15 item 4).
#include <gtest/gtest.h>

#include <sqlite3.h>
#include <stdlib.h>

#include <fstream>
#include <set>

#include <fmt/format.h>

#include "core/error.h"
#include "experiments/store.h"
#include "experiments/sweep.h"
#include "tests/test_util.h"

namespace hrad::experiments {
namespace {

namespace fs = std::filesystem;

void sql(const fs::path& db, const std::string& text) {
    sqlite3* h = nullptr;
    ASSERT_EQ(sqlite3_open(db.string().c_str(), &h), SQLITE_OK);
    char* err = nullptr;
    ASSERT_EQ(sqlite3_exec(h, text.c_str(), nullptr, nullptr, &err), SQLITE_OK) << (err ? err : "");
    sqlite3_close(h);
}

std::string query(const fs::path& db, const std::string& text) {
    ResultStore s(db, true);
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(s.handle(), text.c_str(), -1, &st, nullptr);
    std::string out;
    while (sqlite3_step(st) == SQLITE_ROW) {
        const char* t = reinterpret_cast<const char*>(sqlite3_column_text(st, 0));
        out += std::string(t ? t : "NULL") + ";";
    }
    sqlite3_finalize(st);
    return out;
}

// The message of the InputError that opening `db` throws ("" if none).
std::string refusal(const fs::path& db, bool readOnly) {
    try {
        ResultStore s(db, readOnly);
    } catch (const InputError& e) {
        EXPECT_EQ(e.where().file, db.string());
        return e.message();
    }
    return "";
}

const char* kStudy = R"(
name = "one"
scenes = ["furnace"]
[solver]
"hr.max_iterations" = 3
[sweep]
"oracle.eps" = [0.5, 0.1]
)";

SweepOptions options(const fs::path& dir, const std::string& store) {
    SweepOptions o;
    o.store = dir / store;
    o.threads = 1;
    o.useCache = false;
    return o;
}

TEST(Store, NewStoresCarryTheSchemaVersion) {
    auto dir = test::tempDir("store_version");
    {
        ResultStore s(dir / "a.sqlite");
        EXPECT_EQ(s.schemaVersion(), 7);
    }
    EXPECT_EQ(query(dir / "a.sqlite", "PRAGMA application_id"), "1213350212;");
    EXPECT_EQ(refusal(dir / "a.sqlite", true), "");
    EXPECT_EQ(refusal(dir / "a.sqlite", false), "");
}

TEST(Store, RefusesFilesThatAreNotSqlite) {
    auto dir = test::tempDir("store_notsqlite");
    { std::ofstream(dir / "text.sqlite") << "name,value\na,1\n"; }
    for (bool ro : {true, false})
        EXPECT_NE(refusal(dir / "text.sqlite", ro).find("not an SQLite database"), std::string::npos);
    // Nothing was written over the file.
    std::ifstream in(dir / "text.sqlite");
    std::string line;
    std::getline(in, line);
    EXPECT_EQ(line, "name,value");
}

TEST(Store, RefusesForeignSqliteDatabases) {
    auto dir = test::tempDir("store_foreign");
    sql(dir / "other.sqlite", "CREATE TABLE people (name TEXT, age INTEGER); INSERT INTO people VALUES ('a', 1)");
    EXPECT_NE(refusal(dir / "other.sqlite", false).find("not an hrad results store: it has the tables people"),
              std::string::npos);
    sql(dir / "app.sqlite", "PRAGMA application_id = 1234; CREATE TABLE t (x)");
    EXPECT_NE(refusal(dir / "app.sqlite", true).find("another application"), std::string::npos);
    // Same table names, other columns: refused, also for export (read-only).
    sql(dir / "lookalike.sqlite",
        "CREATE TABLE studies (hash TEXT); CREATE TABLE runs (key TEXT PRIMARY KEY, colour TEXT);"
        "CREATE TABLE iterations (run_key TEXT); CREATE TABLE failures (key TEXT)");
    std::string m = refusal(dir / "lookalike.sqlite", true);
    EXPECT_NE(m.find("not an hrad results store: its table 'studies' lacks the column 'name'"),
              std::string::npos) << m;
    // A real store whose runs gained a column hrad does not write.
    { ResultStore s(dir / "extra.sqlite"); }
    sql(dir / "extra.sqlite", "ALTER TABLE runs ADD COLUMN colour TEXT");
    m = refusal(dir / "extra.sqlite", true);
    EXPECT_NE(m.find("its table 'runs' has a column 'colour' that hrad does not write"),
              std::string::npos) << m;
}

TEST(Store, RefusesCorruptAndTruncatedStores) {
    auto dir = test::tempDir("store_corrupt");
    Study study = parseStudy(kStudy, "one.toml", dir);
    runSweep(study, options(dir, "good.sqlite"));
    { ResultStore s(dir / "good.sqlite"); sql(dir / "good.sqlite", "PRAGMA wal_checkpoint(TRUNCATE)"); }
    uintmax_t size = fs::file_size(dir / "good.sqlite");
    ASSERT_GT(size, 4096u);
    // Truncated in the middle of its pages.
    fs::copy_file(dir / "good.sqlite", dir / "cut.sqlite");
    fs::resize_file(dir / "cut.sqlite", size / 2 + 17);
    std::string m = refusal(dir / "cut.sqlite", true);
    EXPECT_NE(m.find("corrupt"), std::string::npos) << m;
    EXPECT_EQ(m.find("SELECT"), std::string::npos) << m;
    fs::copy_file(dir / "good.sqlite", dir / "head.sqlite");
    fs::resize_file(dir / "head.sqlite", 50);
    EXPECT_NE(refusal(dir / "head.sqlite", false).find("truncated"), std::string::npos);
    // Garbage written over the pages after the first.
    fs::copy_file(dir / "good.sqlite", dir / "bad.sqlite");
    {
        std::fstream f(dir / "bad.sqlite", std::ios::in | std::ios::out | std::ios::binary);
        f.seekp(4096);
        std::string junk(size - 4096, '\x5a');
        f.write(junk.data(), std::streamsize(junk.size()));
    }
    m = refusal(dir / "bad.sqlite", true);
    EXPECT_NE(m.find("corrupt"), std::string::npos) << m;
    // Merging a corrupt shard refuses before touching the output.
    ResultStore out(dir / "out.sqlite");
    EXPECT_THROW(out.mergeFrom(dir / "bad.sqlite"), InputError);
    EXPECT_EQ(out.count("runs"), 0);
}

TEST(Store, RefusesNewerSchemaVersions) {
    auto dir = test::tempDir("store_newer");
    { ResultStore s(dir / "s.sqlite"); }
    sql(dir / "s.sqlite", "PRAGMA user_version = 99");
    EXPECT_NE(refusal(dir / "s.sqlite", false).find("schema version 99, written by a newer hrad"),
              std::string::npos);
}

TEST(Store, MigratesVersionOneStores) {
    auto dir = test::tempDir("store_v1");
    Study study = parseStudy(kStudy, "one.toml", dir);
    runSweep(study, options(dir, "v1.sqlite"));
    // Back to version 1: no version pragmas, none of the later columns.
    std::string drop = "PRAGMA application_id = 0; PRAGMA user_version = 0;";
    for (const char* c :
         {"l1_reflected_lum", "l2_reflected_lum", "l1_nonemitter_lum", "l2_nonemitter_lum",
          "mean_ratio_nonemitter", "error_estimate", "residual", "slurm_job_id",
          "slurm_array_task_id", "noise_estimate", "noise_l2_nonemitter", "error_estimate_leaves",
          "error_estimate_points", "resolved_settings", "estimate_l2_nonemitter",
          "estimate_l1_reflected", "estimate_mean_ratio", "true_l2_nonemitter", "target_error",
          "target_met"})
        drop += fmt::format("ALTER TABLE runs DROP COLUMN {};", c);
    drop += "ALTER TABLE failures DROP COLUMN slurm_job_id; ALTER TABLE failures DROP COLUMN slurm_array_task_id;";
    sql(dir / "v1.sqlite", drop);
    EXPECT_EQ(refusal(dir / "v1.sqlite", true), "");  // readable as it is
    {
        ResultStore s(dir / "v1.sqlite");
        EXPECT_EQ(s.schemaVersion(), 7);
        EXPECT_EQ(s.count("runs"), 2);
    }
    EXPECT_EQ(query(dir / "v1.sqlite", "SELECT slurm_job_id FROM runs"), "NULL;NULL;");
    EXPECT_EQ(query(dir / "v1.sqlite", "SELECT error_estimate_leaves FROM runs"), "NULL;NULL;");
    EXPECT_EQ(query(dir / "v1.sqlite", "SELECT resolved_settings FROM runs"), "NULL;NULL;");
    // ... and resumes: nothing to rerun.
    SweepOptions o = options(dir, "v1.sqlite");
    o.resume = true;
    EXPECT_EQ(runSweep(study, o).finished, 0u);
}

TEST(Store, RowWithoutKeyIsRefusedNotACrash) {
    auto dir = test::tempDir("store_nullkey");
    Study study = parseStudy(kStudy, "one.toml", dir);
    runSweep(study, options(dir, "n.sqlite"));
    sql(dir / "n.sqlite", "UPDATE runs SET key = NULL WHERE point_index = 1");
    std::string m = refusal(dir / "n.sqlite", false);
    EXPECT_NE(m.find("table 'runs'"), std::string::npos) << m;
    EXPECT_NE(m.find("has no key (NULL)"), std::string::npos) << m;
    SweepOptions o = options(dir, "n.sqlite");
    o.resume = true;
    EXPECT_THROW(runSweep(study, o), InputError);
}

TEST(Store, RowsCarrySlurmProvenance) {
    auto dir = test::tempDir("store_provenance");
    Study study = parseStudy(kStudy, "one.toml", dir);
    setenv("SLURM_ARRAY_JOB_ID", "4242", 1);
    setenv("SLURM_ARRAY_TASK_ID", "7", 1);
    runSweep(study, options(dir, "p.sqlite"));
    unsetenv("SLURM_ARRAY_JOB_ID");
    unsetenv("SLURM_ARRAY_TASK_ID");
    EXPECT_EQ(query(dir / "p.sqlite",
                    "SELECT slurm_job_id || '/' || slurm_array_task_id || '/' || (host <> '') FROM runs"),
              "4242/7/1;4242/7/1;");
    runSweep(study, options(dir, "q.sqlite"));
    EXPECT_EQ(query(dir / "q.sqlite", "SELECT slurm_job_id FROM runs"), "NULL;NULL;");
}

TEST(Store, MergeRefusesMixedStudiesUnlessForced) {
    auto dir = test::tempDir("store_mix");
    Study a = parseStudy(kStudy, "one.toml", dir);
    Study b = parseStudy(std::string(kStudy) + "# edited\n", "one.toml", dir);
    runSweep(a, options(dir, "a.sqlite"));
    runSweep(b, options(dir, "b.sqlite"));
    ResultStore m(dir / "m.sqlite");
    EXPECT_EQ(m.mergeFrom(dir / "a.sqlite"), 2);
    try {
        m.mergeFrom(dir / "b.sqlite");
        FAIL() << "mixed studies merged";
    } catch (const InputError& e) {
        EXPECT_NE(e.message().find("study texts"), std::string::npos) << e.message();
        EXPECT_NE(e.message().find("--force"), std::string::npos);
    }
    EXPECT_EQ(m.count("runs"), 2);
    // Different hrad versions.
    fs::copy_file(dir / "a.sqlite", dir / "v.sqlite");
    sql(dir / "v.sqlite", "UPDATE runs SET version = 'v0.0-old'");
    EXPECT_THROW(m.mergeFrom(dir / "v.sqlite"), InputError);
    // Forced: the edited study's points have other keys, so they are added.
    EXPECT_EQ(m.mergeFrom(dir / "b.sqlite", true), 0 + 0);  // same points, same keys
    EXPECT_EQ(m.count("studies"), 2);
}

}  // namespace
}  // namespace hrad::experiments

namespace hrad::experiments {

TEST(Store, EveryRowCarriesTheResolvedSettingsWhole) {
    auto dir = test::tempDir("store_resolved");
    Study study = parseStudy(kStudy, "one.toml", dir);
    runSweep(study, options(dir, "r.sqlite"));
    // Keys the study never set are there with the value the run used.
    auto key = [&](const char* k) {
        return query(dir / "r.sqlite",
                     fmt::format("SELECT json_extract(resolved_settings, '$.\"{}\"') FROM runs "
                                 "ORDER BY point_index",
                                 k));
    };
    EXPECT_EQ(key("hr.max_level"), "14;14;");
    EXPECT_EQ(key("hr.max_iterations"), "3;3;");
    EXPECT_EQ(key("oracle.eps"), "0.5;0.1;");
    EXPECT_EQ(key("cluster.model"), "none;none;");  // auto, resolved by the solve
}

}  // namespace hrad::experiments
