// Sweeps into a results store: every point runs in a child process, so these
// tests exercise the real fork / wait / commit path on tiny scenes (the
// furnace and two plates; full-matrix references at level 1).
#include "experiments/sweep.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <set>

#include "core/safe_file.h"
#include "experiments/store.h"
#include "render/error_map.h"
#include "tests/test_util.h"

namespace hrad::experiments {
namespace {

namespace fs = std::filesystem;

// Six points: 2 scenes x 3 eps, against a cached level-1 full matrix.
const char* kStudy = R"(
name = "tiny"
scenes = ["furnace", "plates:parallel:1:1:1"]
[solver]
"hr.max_iterations" = 4
"ff.vis_rays" = 4
[reference]
kind = "full-matrix"
"fm.level" = 1
[sweep]
"oracle.eps" = [0.5, 0.1, 0.02]
)";

SweepOptions options(const fs::path& dir, const std::string& store) {
    SweepOptions o;
    o.store = dir / store;
    o.cacheDir = (dir / "cache").string();
    o.threads = 1;
    return o;
}

std::set<std::string> keysOf(const fs::path& store, const char* sql = "SELECT key FROM runs") {
    ResultStore s(store, true);
    std::set<std::string> out;
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(s.handle(), sql, -1, &st, nullptr);
    while (sqlite3_step(st) == SQLITE_ROW)
        out.insert(reinterpret_cast<const char*>(sqlite3_column_text(st, 0)));
    sqlite3_finalize(st);
    return out;
}

std::string readText(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

TEST(Sweep, RunsEveryPointWithMetricsAndHistory) {
    auto dir = test::tempDir("sweep_all");
    Study study = parseStudy(kStudy, "tiny.toml", dir);
    SweepReport r = runSweep(study, options(dir, "all.sqlite"));
    EXPECT_EQ(r.points, 6u);
    EXPECT_EQ(r.finished, 6u);
    EXPECT_EQ(r.failed, 0u);
    ResultStore s(dir / "all.sqlite", true);
    EXPECT_EQ(s.count("runs"), 6);
    EXPECT_EQ(s.count("failures"), 0);
    EXPECT_EQ(s.count("studies"), 1);
    EXPECT_GT(s.count("iterations"), 6);
    // Every run has an error vs the reference, a peak RSS and timings.
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(s.handle(),
                       "SELECT COUNT(*) FROM runs WHERE l2_lum IS NOT NULL AND peak_rss > 0 AND "
                       "wall_s > 0 AND load_s >= 0 AND links > 0 AND version != ''",
                       -1, &st, nullptr);
    ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
    EXPECT_EQ(sqlite3_column_int(st, 0), 6);
    sqlite3_finalize(st);
    // The furnace is solved exactly by any subdivision (B = E / (1 - rho)
    // everywhere), so its error is at the level of the form-factor quadrature.
    sqlite3_prepare_v2(s.handle(), "SELECT MAX(l2_lum) FROM runs WHERE scene = 'furnace'", -1, &st,
                       nullptr);
    ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
    EXPECT_LT(sqlite3_column_double(st, 0), 0.05);
    sqlite3_finalize(st);
}

// A store is committed with the study it ran: it names the study file as seen
// from the store's folder, never by this machine's absolute path.
TEST(Sweep, StoreNamesItsStudyRelativeToItself) {
    auto dir = test::tempDir("sweep_path");
    fs::create_directories(dir / "papers" / "studies");
    fs::create_directories(dir / "papers" / "results");
    {
        std::ofstream f(dir / "papers" / "studies" / "tiny.toml");
        f << "name = \"tiny\"\nscenes = [\"furnace\"]\n[solver]\n\"hr.max_iterations\" = 2\n"
          << "[outputs]\nsolution = true\n";
    }
    Study study = loadStudy(dir / "papers" / "studies" / "tiny.toml");
    SweepReport r = runSweep(study, options(dir / "papers" / "results", "tiny.sqlite"));
    EXPECT_EQ(r.finished, 1u);
    std::set<std::string> paths =
        keysOf(dir / "papers" / "results" / "tiny.sqlite", "SELECT path FROM studies");
    ASSERT_EQ(paths.size(), 1u);
    EXPECT_EQ(*paths.begin(), "../studies/tiny.toml");
    // So are the run's files.
    std::set<std::string> files = keysOf(dir / "papers" / "results" / "tiny.sqlite",
                                         "SELECT json_extract(summary, '$.artefacts.solution') "
                                         "FROM runs");
    ASSERT_EQ(files.size(), 1u);
    EXPECT_EQ(files.begin()->rfind("runs/tiny/", 0), 0u) << *files.begin();
    EXPECT_TRUE(fs::exists(dir / "papers" / "results" / *files.begin())) << *files.begin();
}

// outputs.history_error: the L2 error after every iteration is stored, and
// the last iteration's error is the run's final error.
TEST(Sweep, HistoryErrorIsRecordedPerIteration) {
    auto dir = test::tempDir("sweep_history");
    Study study = parseStudy(R"(
scenes = ["plates:perpendicular:1:1:1"]
[solver]
"hr.max_iterations" = 6
"oracle.eps" = 0.01
[reference]
kind = "full-matrix"
"fm.level" = 2
[outputs]
history_error = true
)",
                             "hist.toml", dir);
    SweepReport r = runSweep(study, options(dir, "hist.sqlite"));
    ASSERT_EQ(r.finished, 1u);
    ResultStore s(dir / "hist.sqlite", true);
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(s.handle(), "SELECT COUNT(*), SUM(i.l2_lum IS NULL) FROM iterations i", -1,
                       &st, nullptr);
    ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
    EXPECT_GT(sqlite3_column_int(st, 0), 1);
    EXPECT_EQ(sqlite3_column_int(st, 1), 0) << "every iteration has an error";
    sqlite3_finalize(st);
    sqlite3_prepare_v2(s.handle(),
                       "SELECT r.l2_lum, i.l2_lum FROM runs r JOIN iterations i ON i.run_key = "
                       "r.key ORDER BY i.iteration DESC LIMIT 1",
                       -1, &st, nullptr);
    ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
    EXPECT_DOUBLE_EQ(sqlite3_column_double(st, 0), sqlite3_column_double(st, 1));
    sqlite3_finalize(st);
    // The per-iteration errors are error work, not solve time: error_s holds them.
    sqlite3_prepare_v2(s.handle(), "SELECT error_s, summary FROM runs", -1, &st, nullptr);
    ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
    auto summary = nlohmann::json::parse(reinterpret_cast<const char*>(sqlite3_column_text(st, 1)));
    double hist = summary.at("timings").at("history_error").get<double>();
    EXPECT_GT(hist, 0.0);
    EXPECT_GE(sqlite3_column_double(st, 0), hist);
    sqlite3_finalize(st);
}

// solver = progressive: the history (one record every pr.history_every shots)
// goes to the iterations table with its error, the unshot power falls, and
// the last record's error is the run's error.
TEST(Sweep, ProgressiveSolverRecordsHistoryEveryNShots) {
    auto dir = test::tempDir("sweep_progressive");
    Study study = parseStudy(R"(
scenes = ["plates:perpendicular:1:1:1"]
[solver]
solver = "progressive"
"pr.level" = 1
"pr.history_every" = 2
"pr.tolerance" = 1e-4
[reference]
kind = "full-matrix"
"fm.level" = 2
[outputs]
history_error = true
)",
                             "pr.toml", dir);
    SweepReport r = runSweep(study, options(dir, "pr.sqlite"));
    ASSERT_EQ(r.finished, 1u);
    ResultStore s(dir / "pr.sqlite", true);
    EXPECT_GT(s.count("iterations"), 2);
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(s.handle(),
                       "SELECT iteration, residual, l2_lum FROM iterations ORDER BY iteration", -1,
                       &st, nullptr);
    double prevResidual = 2.0, lastL2 = -1;
    int prevIter = -1;
    while (sqlite3_step(st) == SQLITE_ROW) {
        int it = sqlite3_column_int(st, 0);
        double res = sqlite3_column_double(st, 1);
        EXPECT_GT(it, prevIter);
        EXPECT_LT(res, prevResidual) << "shots " << it;
        EXPECT_NE(sqlite3_column_type(st, 2), SQLITE_NULL);
        prevIter = it;
        prevResidual = res;
        lastL2 = sqlite3_column_double(st, 2);
    }
    sqlite3_finalize(st);
    EXPECT_LE(prevResidual, 1e-4);
    sqlite3_prepare_v2(s.handle(), "SELECT l2_lum, solver FROM runs", -1, &st, nullptr);
    ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
    EXPECT_DOUBLE_EQ(sqlite3_column_double(st, 0), lastL2);
    EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(st, 1)), "progressive");
    sqlite3_finalize(st);
}

// outputs.error_map: the reference render, the 16-bit data map and the false
// colours are written next to the image; a solution equal to the reference
// (the same full matrix) has zero error everywhere, a coarse one does not,
// and the data file holds what the summary's statistics describe.
TEST(Sweep, ErrorMapsAgainstTheReference) {
    auto dir = test::tempDir("sweep_errmap");
    Study study = parseStudy(R"(
name = "maps"
scenes = [
  { scene = "cornell", solver = { solver = "full-matrix", "fm.level" = 1 } },
  { scene = "cornell", solver = { "oracle.eps" = 0.05, "cluster.model" = "none" } },
]
[solver]
"render.width" = 48
"render.height" = 48
[reference]
kind = "full-matrix"
"fm.level" = 1
[outputs]
error_map = true
)",
                             "maps.toml", dir);
    SweepReport r = runSweep(study, options(dir, "maps.sqlite"));
    ASSERT_EQ(r.finished, 2u);
    ResultStore s(dir / "maps.sqlite", true);
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(s.handle(), "SELECT key, solver, summary FROM runs ORDER BY solver", -1, &st,
                       nullptr);
    int rows = 0;
    while (sqlite3_step(st) == SQLITE_ROW) {
        ++rows;
        std::string key = reinterpret_cast<const char*>(sqlite3_column_text(st, 0));
        std::string solver = reinterpret_cast<const char*>(sqlite3_column_text(st, 1));
        auto summary =
            nlohmann::json::parse(reinterpret_cast<const char*>(sqlite3_column_text(st, 2)));
        fs::path run = dir / "runs" / "maps" / key;
        for (const char* f : {"image.png", "reference.png", "error.png", "error_fc.png"})
            EXPECT_TRUE(fs::exists(run / f)) << solver << " " << f;
        const auto& em = summary.at("error_map");
        EXPECT_EQ(em.at("mode"), "regions");
        render::ErrorMap data = render::readErrorData((run / "error.png").string());
        ASSERT_EQ(data.width, 48);
        double sum = 0;
        size_t n = 0;
        for (float e : data.values)
            if (!std::isnan(e)) sum += std::abs(e), ++n;
        EXPECT_EQ(n, em.at("pixels").get<size_t>());
        if (solver == "full-matrix") {
            EXPECT_EQ(em.at("mean_abs").get<double>(), 0.0) << "the reference itself";
            EXPECT_LT(sum / double(n), 1e-4);  // quantisation of 0 is exact
        } else {
            EXPECT_GT(em.at("mean_abs").get<double>(), 0.01);
            // 16-bit quantisation: within half a step, unless clipped at +-1.
            if (em.at("max_abs").get<double>() <= 1.0) {
                EXPECT_NEAR(sum / double(n), em.at("mean_abs").get<double>(), 2e-5);
            }
            // The image-space L1 of the per-region map follows the region L1.
            EXPECT_NEAR(em.at("l1").get<double>(), summary.at("error").at("l1_lum").get<double>(),
                        0.5 * summary.at("error").at("l1_lum").get<double>());
        }
    }
    sqlite3_finalize(st);
    EXPECT_EQ(rows, 2);
}

TEST(Sweep, ResumeAfterKillLosesAndDuplicatesNothing) {
    auto dir = test::tempDir("sweep_resume");
    Study study = parseStudy(kStudy, "tiny.toml", dir);
    SweepOptions o = options(dir, "resume.sqlite");
    // A sweep in a child process that is SIGKILLed right after its 2nd commit.
    pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        int n = 0;
        o.onPointDone = [&](const PointSpec&, bool) {
            if (++n == 2) raise(SIGKILL);
        };
        try {
            runSweep(study, o);
        } catch (...) {
        }
        _exit(0);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status));
    EXPECT_EQ(keysOf(o.store).size(), 2u);

    // Without --resume the store is refused.
    EXPECT_THROW(runSweep(study, o), Error);
    o.resume = true;
    SweepReport r = runSweep(study, o);
    EXPECT_EQ(r.skipped, 2u);
    EXPECT_EQ(r.finished, 4u);
    ResultStore s(o.store, true);
    EXPECT_EQ(s.count("runs"), 6);
    std::set<std::string> expected;
    for (const auto& p : study.points()) expected.insert(pointKey(p));
    EXPECT_EQ(keysOf(o.store), expected);
    // Iteration rows only for committed runs, none orphaned or duplicated.
    EXPECT_EQ(keysOf(o.store, "SELECT DISTINCT run_key FROM iterations"), expected);
    // A second resume has nothing to do.
    r = runSweep(study, o);
    EXPECT_EQ(r.skipped, 6u);
    EXPECT_EQ(r.finished, 0u);
}

// Issue 16: the children of a sweep killed with SIGKILL ran on to the end of
// their points. They now die with it (PR_SET_PDEATHSIG); this test process
// adopts them (child subreaper) to see how they end.
TEST(Sweep, ChildrenDieWithAKilledParent) {
    auto dir = test::tempDir("sweep_parent_killed");
    // Points that take a while (a second or more each), so that the children
    // are mid-solve when the parent is killed.
    Study study = parseStudy(
        "name = \"slow\"\nscenes = [\"cornell\"]\n[sweep]\n\"oracle.eps\" = [0.0005, 0.0006]\n",
        "slow.toml", dir);
    SweepOptions o = options(dir, "killed.sqlite");
    o.jobs = 2;
    ASSERT_EQ(prctl(PR_SET_CHILD_SUBREAPER, 1), 0);
    pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        try {
            runSweep(study, o);
        } catch (...) {
        }
        _exit(0);
    }
    // Kill the parent once both children run (/proc lists a process's children).
    auto children = [&] {
        std::ifstream in(fmt::format("/proc/{}/task/{}/children", pid, pid));
        std::vector<pid_t> out;
        long c;
        while (in >> c) out.push_back(pid_t(c));
        return out;
    };
    for (int i = 0; i < 3000 && children().size() < 2; ++i) usleep(10000);
    std::vector<pid_t> kids = children();
    ASSERT_EQ(kids.size(), 2u);
    kill(pid, SIGKILL);
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    // The orphans are now this process's children: each must have been
    // killed, not have finished its point.
    int orphans = 0, finished = 0;
    for (pid_t k : kids) {
        if (waitpid(k, &status, 0) != k) continue;
        ++orphans;
        if (!(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL)) ++finished;
    }
    prctl(PR_SET_CHILD_SUBREAPER, 0);
    EXPECT_EQ(orphans, 2);
    EXPECT_EQ(finished, 0) << "children finished their points after the parent was killed";
    EXPECT_EQ(keysOf(o.store).size(), 0u);
}

TEST(Sweep, FailingPointsAreRecordedAndOthersComplete) {
    auto dir = test::tempDir("sweep_fail");
    // furnace:1.5 has rho >= 1: the loader rejects it at run time (dry
    // validation does not load scenes). A malformed OBJ fails while parsing.
    test::writeFile(dir / "bad.obj", "v 0 0 0\nv 1 0 0\nf 1 2 7\n");
    Study study = parseStudy(R"(
scenes = ["furnace", "furnace:1.5", "bad.obj"]
[solver]
"hr.max_iterations" = 3
)",
                             "fail.toml", dir);
    SweepReport r = runSweep(study, options(dir, "fail.sqlite"));
    EXPECT_EQ(r.finished, 1u);
    EXPECT_EQ(r.failed, 2u);
    ResultStore s(dir / "fail.sqlite", true);
    EXPECT_EQ(s.count("runs"), 1);
    EXPECT_EQ(s.count("failures"), 2);
    auto kinds = keysOf(dir / "fail.sqlite", "SELECT kind || ':' || scene FROM failures");
    EXPECT_TRUE(kinds.count("input:furnace:1.5")) << *kinds.begin();
    EXPECT_TRUE(kinds.count("input:bad.obj"));
    auto msgs = keysOf(dir / "fail.sqlite", "SELECT message FROM failures WHERE scene='bad.obj'");
    ASSERT_EQ(msgs.size(), 1u);
    EXPECT_NE(msgs.begin()->find("bad.obj"), std::string::npos) << *msgs.begin();
}

TEST(Sweep, TimeLimitIsAFailureNotAnAbort) {
    auto dir = test::tempDir("sweep_timeout");
    Study study = parseStudy(R"(
scenes = [{ scene = "furnace", solver = { "oracle.eps" = 0.5 } },
          { scene = "cornell", solver = { "oracle.eps" = 1e-5 } }]
[solver]
"hr.max_iterations" = 50
"metrics.error_estimate" = false  # its ~1 s would time out the furnace too
)",
                             "timeout.toml", dir);
    SweepOptions o = options(dir, "timeout.sqlite");
    o.maxSeconds = 0.3;  // the furnace takes ~10 ms, the Cornell box at eps 1e-5 far longer
    SweepReport r = runSweep(study, o);
    EXPECT_EQ(r.finished, 1u);
    EXPECT_EQ(r.failed, 1u);
    auto kinds = keysOf(o.store, "SELECT kind || ':' || scene FROM failures");
    EXPECT_TRUE(kinds.count("timeout:cornell"));
}

// Issue 64: a sweep removes only the result files it writes, follows no
// symlink planted where it keeps files, refuses a store another sweep
// holds, and records disk and folder failures as "io", which --resume reruns.
TEST(Sweep, WritesOnlyWhatItOwnsAndOneSweepPerStore) {
    auto dir = test::tempDir("sweep_hostile");
    Study study = parseStudy(R"(
scenes = ["furnace"]
[solver]
"hr.max_iterations" = 2
[outputs]
ply = true
)",
                             "h.toml", dir);
    test::writeFile(dir / "victim.json", "precious");
    // A folder of the work folder's name with the user's files, a symlink
    // and a result file a killed sweep left.
    fs::create_directories(dir / "a.sqlite.work");
    test::writeFile(dir / "a.sqlite.work" / "mine.json", "mine");
    fs::create_symlink(dir / "victim.json", dir / "a.sqlite.work" / "link.json");
    test::writeFile(dir / "a.sqlite.work" / "hrad-result-stale.json", "{}");
    SweepOptions first = options(dir, "a.sqlite");
    // Each committed run is checkpointed into the database file (it stayed
    // at 4 KB beside a growing WAL).
    uintmax_t dbBytes = 0;
    first.onPointDone = [&](const PointSpec&, bool) { dbBytes = fs::file_size(first.store); };
    SweepReport r = runSweep(study, first);
    EXPECT_GT(dbBytes, 4096u);
    EXPECT_EQ(r.finished, 1u);
    EXPECT_EQ(readText(dir / "a.sqlite.work" / "mine.json"), "mine");
    EXPECT_TRUE(fs::is_symlink(dir / "a.sqlite.work" / "link.json"));
    EXPECT_FALSE(fs::exists(dir / "a.sqlite.work" / "hrad-result-stale.json"));
    EXPECT_EQ(readText(dir / "victim.json"), "precious");
    // The CSV export replaces a planted symlink, never writes through it.
    fs::create_directories(dir / "csv");
    fs::create_symlink(dir / "victim.json", dir / "csv" / "runs.csv");
    ResultStore(dir / "a.sqlite", true).exportCsv(dir / "csv");
    EXPECT_EQ(readText(dir / "victim.json"), "precious");
    EXPECT_FALSE(fs::is_symlink(dir / "csv" / "runs.csv"));

    // A symlink as the work folder, or in the artefacts' path: refused.
    fs::create_directories(dir / "elsewhere");
    fs::create_symlink(dir / "elsewhere", dir / "b.sqlite.work");
    EXPECT_THROW(runSweep(study, options(dir, "b.sqlite")), InputError);
    fs::create_directories(dir / "c");
    fs::create_symlink(dir / "elsewhere", dir / "c" / "runs");
    EXPECT_THROW(runSweep(study, options(dir, "c/c.sqlite")), InputError);
    EXPECT_TRUE(fs::is_empty(dir / "elsewhere"));

    // A second sweep on a store another one holds.
    {
        FileLock other;
        ASSERT_TRUE(other.tryLock(dir / "a.sqlite"));
        SweepOptions o = options(dir, "a.sqlite");
        o.resume = true;
        try {
            runSweep(study, o);
            ADD_FAILURE() << "no error";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("another hrad sweep is writing this results store"),
                      std::string::npos) << e.what();
        }
    }

    // An output folder that cannot be made (a file in its place; permissions
    // would not stop root): kind "io", and --resume runs the point again.
    test::writeFile(dir / "d" / "runs" / "h", "in the way");
    SweepReport f = runSweep(study, options(dir, "d/d.sqlite"));
    EXPECT_EQ(f.failed, 1u);
    EXPECT_EQ(keysOf(dir / "d" / "d.sqlite", "SELECT kind FROM failures"), std::set<std::string>{"io"});
    fs::remove(dir / "d" / "runs" / "h");
    SweepOptions again = options(dir, "d/d.sqlite");
    again.resume = true;
    SweepReport g = runSweep(study, again);
    EXPECT_EQ(g.finished, 1u);
    EXPECT_EQ(g.skipped, 0u);
}

TEST(Sweep, ShardsMergeToTheUnshardedRows) {
    auto dir = test::tempDir("sweep_shards");
    Study study = parseStudy(kStudy, "tiny.toml", dir);
    SweepOptions o0 = options(dir, "shard0.sqlite"), o1 = options(dir, "shard1.sqlite");
    o0.shardIndex = 0, o0.shardCount = 2;
    o1.shardIndex = 1, o1.shardCount = 2;
    o1.jobs = 2;  // parallel children in one shard
    SweepReport r0 = runSweep(study, o0), r1 = runSweep(study, o1);
    EXPECT_EQ(r0.finished, 3u);
    EXPECT_EQ(r1.finished, 3u);
    {
        ResultStore merged(dir / "merged.sqlite");
        EXPECT_EQ(merged.mergeFrom(dir / "shard0.sqlite"), 3);
        EXPECT_EQ(merged.mergeFrom(dir / "shard1.sqlite"), 3);
        EXPECT_EQ(merged.mergeFrom(dir / "shard1.sqlite"), 0);  // no duplicates
        EXPECT_EQ(merged.count("runs"), 6);
        EXPECT_EQ(merged.count("studies"), 1);
    }
    runSweep(study, options(dir, "whole.sqlite"));
    EXPECT_EQ(keysOf(dir / "merged.sqlite"), keysOf(dir / "whole.sqlite"));
    // Same results, not only the same keys: the solver is deterministic.
    const char* q = "SELECT key || ':' || links || ':' || printf('%.12g', l2_lum) FROM runs";
    EXPECT_EQ(keysOf(dir / "merged.sqlite", q), keysOf(dir / "whole.sqlite", q));
    const char* qi = "SELECT run_key || ':' || iteration || ':' || links FROM iterations";
    EXPECT_EQ(keysOf(dir / "merged.sqlite", qi), keysOf(dir / "whole.sqlite", qi));
}

// The error columns of reference/metrics.h are stored (with a reference),
// and a store written before they existed is upgraded on opening and merges
// by column name.
TEST(Store, ErrorColumnsAndOlderStores) {
    auto dir = test::tempDir("store_columns");
    Study study = parseStudy(kStudy, "tiny.toml", dir);
    runSweep(study, options(dir, "new.sqlite"));
    auto rows = keysOf(dir / "new.sqlite",
                       "SELECT printf('%d', l1_reflected_lum > 0 AND l2_nonemitter_lum > 0 AND "
                       "mean_ratio_nonemitter > 0 AND error_estimate >= 0 AND residual >= 0 AND "
                       "noise_estimate >= 0 AND noise_l2_nonemitter >= 0 AND "
                       "error_estimate_leaves >= 0 AND error_estimate_points >= 0 AND "
                       "json_extract(summary, '$.error_estimate_uncovered_share') = 0 AND "
                       "json_extract(summary, '$.refinement_checks[0].name') = 'receiver' AND "
                       "json_array_length(json_extract(summary, '$.refinement_checks')) = 7) "
                       "FROM runs WHERE scene LIKE 'plates%'");
    EXPECT_EQ(rows, std::set<std::string>{"1"});
    // An older store: the same file without the added columns.
    fs::copy_file(dir / "new.sqlite", dir / "old.sqlite");
    {
        sqlite3* db = nullptr;
        ASSERT_EQ(sqlite3_open((dir / "old.sqlite").string().c_str(), &db), SQLITE_OK);
        for (const char* c :
             {"l1_reflected_lum", "l2_reflected_lum", "l1_nonemitter_lum", "l2_nonemitter_lum",
              "mean_ratio_nonemitter", "error_estimate", "residual"})
            ASSERT_EQ(sqlite3_exec(db, fmt::format("ALTER TABLE runs DROP COLUMN {}", c).c_str(),
                                   nullptr, nullptr, nullptr),
                      SQLITE_OK);
        sqlite3_close(db);
    }
    int64_t n = ResultStore(dir / "new.sqlite").count("runs");
    {
        ResultStore merged(dir / "merged.sqlite");
        EXPECT_EQ(merged.mergeFrom(dir / "old.sqlite"), n);
    }
    EXPECT_EQ(
        keysOf(dir / "merged.sqlite", "SELECT printf('%d', l1_reflected_lum IS NULL) FROM runs"),
        std::set<std::string>{"1"});
    // Opened for writing, the older store gets the columns.
    { ResultStore upgraded(dir / "old.sqlite"); }
    EXPECT_EQ(keysOf(dir / "old.sqlite", "SELECT printf('%d', error_estimate IS NULL) FROM runs"),
              std::set<std::string>{"1"});
}

TEST(Store, CsvExportHasTheColumns) {
    auto dir = test::tempDir("store_csv");
    Study study = parseStudy(R"(
scenes = ["furnace"]
[solver]
"hr.max_iterations" = 3
)",
                             "csv.toml", dir);
    runSweep(study, options(dir, "csv.sqlite"));
    ResultStore s(dir / "csv.sqlite", true);
    s.exportCsv(dir / "csv");
    auto header = [&](const char* t) {
        std::ifstream in(dir / "csv" / (std::string(t) + ".csv"));
        std::string line;
        std::getline(in, line);
        return line;
    };
    std::string runs = header("runs");
    for (const char* col : {"key",      "scene",    "solver",          "oracle",   "settings",
                            "version",  "host",     "wall_s",          "load_s",   "visibility_s",
                            "refine_s", "gather_s", "push_pull_s",     "peak_rss", "elements",
                            "links",    "rays",     "iterations",      "l1_lum",   "l2_lum",
                            "linf_lum", "l2_rgb",   "mc_stderr_l2_lum"})
        EXPECT_NE(runs.find(col), std::string::npos) << col;
    EXPECT_NE(header("iterations").find("residual"), std::string::npos);
    EXPECT_NE(header("failures").find("message"), std::string::npos);
    EXPECT_NE(header("studies").find("text"), std::string::npos);
    std::ifstream in(dir / "csv" / "runs.csv");
    std::string line;
    int lines = 0;
    while (std::getline(in, line)) ++lines;
    // Header + one row (summary JSON is quoted, and has no raw newlines).
    EXPECT_EQ(lines, 2);
}

}  // namespace
}  // namespace hrad::experiments
