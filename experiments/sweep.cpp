#include "experiments/sweep.h"

#include <fmt/format.h>
#include <signal.h>
#include <spdlog/spdlog.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <fstream>
#include <map>
#include <memory>
#include <new>
#include <set>
#include <sstream>
#include <thread>

#include "core/safe_file.h"
#include "core/timer.h"
#include "experiments/runner.h"
#include "experiments/store.h"

namespace hrad::experiments {

namespace fs = std::filesystem;
using nlohmann::json;

std::pair<int, int> parseShard(const std::string& text) {
    int i = -1, n = 0;
    char slash = 0;
    std::istringstream ss(text);
    if (!(ss >> i >> slash >> n) || slash != '/' || !ss.eof() || n < 1 || i < 0 || i >= n)
        throwInputError({"command line (--shard)", 0, 0},
                        "--shard expects i/N with 0 <= i < N, got '{}'", text);
    return {i, n};
}

double checkMaxSeconds(double seconds) {
    // 0 means none; an itimerval holds a time_t, and beyond a year is a typo.
    if (!std::isfinite(seconds) || seconds < 0 || seconds > 366.0 * 86400)
        throwInputError({"command line (--max-seconds)", 0, 0},
                        "--max-seconds must be a number of seconds from 0 (none) to 31622400, "
                        "got {}", seconds);
    return seconds;
}

std::vector<uint64_t> readPointList(const fs::path& file, const Study& study) {
    requireRegularFile(file, "point list");
    std::ifstream in(file, std::ios::binary);
    if (!in) throwInputError(SourceLocation{file.string(), 0, 0}, "cannot read the point list");
    // Streamed token by token: memory is bounded by the number of distinct
    // indices, which is at most the study's point count.
    std::vector<uint64_t> list;
    std::set<uint64_t> seen;
    int line = 1;
    std::string token;
    int tokenLine = 1;
    auto flush = [&]() {
        if (token.empty()) return;
        SourceLocation where{file.string(), tokenLine, 0};
        bool digits = token.size() <= 19 && std::all_of(token.begin(), token.end(), [](char c) {
                          return c >= '0' && c <= '9';
                      });
        if (!digits)
            throwInputError(where, "expected a point index (0, 1, 2, ...), got '{}'", token);
        uint64_t v = std::stoull(token);
        if (v >= study.pointCount())
            throwInputError(where, "point index {} is out of range: study '{}' has {} point(s)", v,
                            study.name, study.pointCount());
        if (!seen.insert(v).second) throwInputError(where, "point index {} is listed twice", v);
        list.push_back(v);
        token.clear();
    };
    bool comment = false;
    for (int c = in.get(); c != EOF; c = in.get()) {
        if (c == '\n') {
            flush();
            comment = false;
            ++line;
        } else if (comment) {
            continue;
        } else if (c == '#') {
            flush();
            comment = true;
        } else if (c == ' ' || c == '\t' || c == '\r' || c == ',') {
            flush();
        } else {
            if (token.empty()) tokenLine = line;
            if (token.size() > 32)
                throwInputError(SourceLocation{file.string(), tokenLine, 0},
                                "expected a point index, got '{}...'", token);
            token.push_back(char(c));
        }
    }
    flush();
    if (list.empty())
        throwInputError(SourceLocation{file.string(), 0, 0}, "the point list is empty");
    return list;
}

uint64_t parseBytes(const std::string& text) {
    char* end = nullptr;
    double v = std::strtod(text.c_str(), &end);
    std::string unit = end ? std::string(end) : "";
    double mult = 1;
    if (unit == "" || unit == "B")
        mult = 1;
    else if (unit == "K" || unit == "KiB" || unit == "k")
        mult = 1024.0;
    else if (unit == "M" || unit == "MiB")
        mult = 1024.0 * 1024;
    else if (unit == "G" || unit == "GiB")
        mult = 1024.0 * 1024 * 1024;
    else if (unit == "T" || unit == "TiB")
        mult = 1024.0 * 1024 * 1024 * 1024;
    else
        v = -1;
    // Finite and in range before the conversion (a double beyond 2^64 cast
    // to an integer is undefined); below 1 MiB no point can even start.
    const double bytes = v * mult;
    if (!(v >= 0) || end == text.c_str() || !std::isfinite(bytes))
        throwInputError({"command line (--max-memory)", 0, 0},
                        "expected a size such as 512M or 4G, got '{}'", text);
    if (bytes < 1024.0 * 1024 || bytes > 0x1p60)
        throwInputError({"command line (--max-memory)", 0, 0},
                        "--max-memory {} is out of range (1M to 1024P)", text);
    return uint64_t(bytes);
}

namespace {

struct Task {
    bool isReference = false;
    const PointSpec* point = nullptr;
    std::string key;  ///< point key, or reference id
    fs::path resultFile;
};

struct Running {
    Task task;
    Timer timer;
};

/// The child: limits, thread count, the work, its result in a file. Never returns.
[[noreturn]] void childMain(const Task& task, const RunContext& ctx, int threads, double maxSeconds,
                            uint64_t maxMemory, bool progress) {
    json result;
    try {
        if (!progress) spdlog::set_level(spdlog::level::warn);
        if (maxMemory > 0) {
            rlimit rl{rlim_t(maxMemory), rlim_t(maxMemory)};
            setrlimit(RLIMIT_AS, &rl);
        }
        if (maxSeconds > 0) {
            // Wall-clock limit: SIGALRM's default action ends the child; the
            // parent sees the signal and records a timeout.
            itimerval it{};
            it.it_value.tv_sec = time_t(maxSeconds);
            it.it_value.tv_usec = suseconds_t((maxSeconds - std::floor(maxSeconds)) * 1e6);
            setitimer(ITIMER_REAL, &it, nullptr);
        }
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
        if (task.isReference)
            result = {{"ok", true}, {"reference", prepareReference(*task.point, ctx)}};
        else
            result = {{"ok", true}, {"summary", runPoint(*task.point, ctx)}};
    } catch (const std::bad_alloc&) {
        result = {{"ok", false},
                  {"kind", "memory"},
                  {"message", fmt::format("out of memory (std::bad_alloc; --max-memory {} bytes)",
                                          maxMemory)}};
    } catch (const IoError& e) {
        // Disk full, a read-only folder: not the point's fault; --resume reruns it.
        result = {{"ok", false}, {"kind", "io"}, {"message", e.what()}};
    } catch (const InputError& e) {
        result = {{"ok", false}, {"kind", "input"}, {"message", e.what()}};
    } catch (const std::exception& e) {
        result = {{"ok", false}, {"kind", "error"}, {"message", e.what()}};
    } catch (...) {
        result = {{"ok", false}, {"kind", "error"}, {"message", "unknown exception"}};
    }
    try {
        writeFileSafely(task.resultFile, result.dump());
    } catch (...) {
        _exit(3);
    }
    // _exit: no atexit handlers, no destructors of state shared with the
    // parent (its SQLite connection, its logger).
    _exit(0);
}

/// The prefix of the result files a sweep writes into <store>.work: the only
/// files it ever removes there.
const std::string kResultPrefix = "hrad-result-";

/// <store>.work: created, or reused when a killed sweep left it. Only result
/// files this code writes (regular files named hrad-result-*.json, and their
/// temporaries) are removed: their points were not committed (the store is the
/// record), so they rerun. A symlink in its place is refused.
void prepareWorkFolder(const fs::path& work) {
    std::error_code ec;
    if (fs::is_symlink(fs::symlink_status(work, ec)))
        throwInputError(SourceLocation{work.string(), 0, 0},
                        "is a symbolic link; the sweep keeps its result files in this folder and "
                        "does not follow links (remove it)");
    fs::create_directories(work, ec);
    if (!fs::is_directory(fs::symlink_status(work, ec)))
        throw IoError(work, "cannot create the sweep's work folder" +
                                (ec ? ": " + ec.message() : std::string(" (a file is in the way)")));
    for (const auto& e : fs::directory_iterator(work)) {
        std::string name = e.path().filename().string();
        bool ours = name.rfind(kResultPrefix, 0) == 0 ||
                    name.rfind("." + kResultPrefix, 0) == 0;  // a temporary of writeFileSafely
        bool json = name.size() > 5 && (name.ends_with(".json") || name.find(".json.tmp.") != std::string::npos);
        if (ours && json && e.symlink_status().type() == fs::file_type::regular) fs::remove(e.path());
    }
}

std::string signalName(int sig) {
    const char* s = strsignal(sig);
    return s ? s : fmt::format("signal {}", sig);
}

}  // namespace

SweepReport runSweep(const Study& study, const SweepOptions& opt) {
    // A path as seen from the store's folder ("" when it cannot be made
    // relative): what the store records of files (stores are committed).
    auto relativeToStore = [&](const fs::path& file) {
        std::error_code ec;
        fs::path rel = fs::relative(fs::absolute(file), fs::absolute(opt.store).parent_path(), ec);
        return ec ? std::string() : rel.generic_string();
    };
    validateStudy(study);
    SweepReport report;
    report.points = study.pointCount();
    if (opt.referencesOnly && !opt.useCache)
        throwInputError({"command line (--references-only)", 0, 0},
                        "--references-only computes references into the cache; it cannot be "
                        "combined with --no-cache");
    // References only: no store; the children's result files go to a private
    // temporary folder (node-local on a cluster, removed at the end).
    FileLock storeLock;  // declared first: released after the store is closed
    std::unique_ptr<ResultStore> storePtr;
    std::string studyHash;
    std::set<std::string> done, failed;
    fs::path work;
    if (opt.referencesOnly) {
        std::string tmpl = (fs::temp_directory_path() / "hrad-references.XXXXXX").string();
        if (!mkdtemp(tmpl.data()))
            throw Error(
                fmt::format("cannot create a temporary folder {}: {}", tmpl, std::strerror(errno)));
        work = tmpl;
    } else {
        storePtr = std::make_unique<ResultStore>(opt.store);
        // One writer per store: a second sweep refuses instead of running
        // every point again (flock on the database file; SQLite's own locks
        // are per transaction).
        if (!storeLock.tryLock(opt.store))
            throwInputError(SourceLocation{opt.store.string(), 0, 0},
                            "another hrad sweep is writing this results store; wait for it to "
                            "end (or stop it), then run again with --resume");
        ResultStore& st = *storePtr;
        int64_t existing = st.count("runs") + st.count("failures");
        if (existing > 0 && !opt.resume)
            throw Error(
                fmt::format("results store {} already holds {} run(s) and {} failure(s); pass "
                            "--resume to continue it (finished points are skipped)",
                            opt.store.string(), st.count("runs"), st.count("failures")));
        // The study file as seen from the store's folder (e.g.
        // "../studies/x.toml"): stores are committed, and a machine's
        // absolute path would name a folder no other machine has.
        std::string studyPath;
        if (!study.path.empty()) {
            studyPath = relativeToStore(study.path);
            if (studyPath.empty()) studyPath = fs::path(study.path).filename().string();
        }
        studyHash = st.addStudy(study.name, studyPath, study.text);
        done = st.runKeys();
        failed = st.failureKeys();
        work = opt.store;
        work += ".work";
        prepareWorkFolder(work);
    }
    fs::path artefactRoot =
        (opt.store.has_parent_path() ? opt.store.parent_path() : fs::path(".")) /
        (study.pointCount() == 0 ? fs::path("runs") : fs::path(study.point(0).outputs.dir)) /
        study.name;
    // Artefacts go below the store's folder: a planted symlink there (runs ->
    // elsewhere) would take every point's outputs out of it.
    requireNoSymlinkBelow(opt.store.has_parent_path() ? opt.store.parent_path() : fs::path("."),
                          artefactRoot);

    double maxSeconds = opt.maxSeconds > 0 ? opt.maxSeconds : study.limits.maxSeconds;
    uint64_t maxMemory = opt.maxMemoryBytes > 0 ? opt.maxMemoryBytes : study.limits.maxMemoryBytes;
    int jobs = std::max(1, opt.jobs);
    int cores = std::max(1u, std::thread::hardware_concurrency());
    int threads = opt.threads > 0 ? opt.threads : std::max(1, cores / jobs);

    // ---- select this shard's unfinished points ----------------------------------------
    // This shard's points, built once (validateStudy bounded their number by
    // sweep.max_points); tasks point into this list.
    // With a point list the shard picks list positions, so the N tasks of a
    // resubmission share its points evenly.
    std::vector<PointSpec> shardPoints;
    if (!opt.pointList.empty()) {
        for (size_t p = size_t(opt.shardIndex); p < opt.pointList.size();
             p += size_t(opt.shardCount)) {
            if (opt.pointList[p] >= study.pointCount())
                throw Error(fmt::format("point index {} out of range (study has {} points)",
                                        opt.pointList[p], study.pointCount()));
            shardPoints.push_back(study.point(opt.pointList[p]));
        }
    } else {
        for (uint64_t i = uint64_t(opt.shardIndex); i < study.pointCount();
             i += uint64_t(opt.shardCount))
            shardPoints.push_back(study.point(i));
    }
    std::vector<Task> todo;
    std::map<std::string, std::vector<const PointSpec*>> byReference;
    for (const PointSpec& p : shardPoints) {
        ++report.selected;
        std::string key = pointKey(p);
        if (done.count(key) || (!opt.retryFailed && failed.count(key))) {
            ++report.skipped;
            continue;
        }
        todo.push_back(Task{false, &p, key, work / (kResultPrefix + key + ".json")});
        std::string refId = referenceId(p);
        if (!refId.empty()) byReference[refId].push_back(&p);
    }
    spdlog::info("study '{}': {} point(s), {} in shard {}/{}, {} already done, {} to run",
                 study.name, report.points, report.selected, opt.shardIndex, opt.shardCount,
                 report.skipped, todo.size());

    RunContext base;
    base.cacheDir = opt.cacheDir;
    base.useCache = opt.useCache;
    base.progress = opt.progress;

    // Runs tasks `jobs` at a time; calls finish(task, result json or failure).
    auto runTasks =
        [&](std::vector<Task> tasks,
            const std::function<void(const Task&, const json&, uint64_t peak, double secs)>& finish,
            bool limited) {
            std::deque<Task> queue(tasks.begin(), tasks.end());
            std::map<pid_t, Running> running;
            while (!queue.empty() || !running.empty()) {
                while (!queue.empty() && int(running.size()) < jobs) {
                    Task t = queue.front();
                    queue.pop_front();
                    fs::remove(t.resultFile);
                    RunContext ctx = base;
                    if (!t.isReference) ctx.artefactDir = artefactRoot / t.key;
                    std::fflush(nullptr);
                    pid_t parent = getpid();
                    pid_t pid = fork();
                    if (pid < 0) throw Error(fmt::format("fork failed: {}", std::strerror(errno)));
                    if (pid == 0) {
                        // A child dies with its parent (a sweep killed with SIGKILL
                        // cannot stop its children itself); the check after prctl
                        // covers a parent that died before the call, the same way.
                        prctl(PR_SET_PDEATHSIG, SIGKILL);
                        if (getppid() != parent) raise(SIGKILL);
                        storeLock.closeInChild();
                    }
                    if (pid == 0)
                        childMain(t, ctx, threads, limited ? maxSeconds : 0.0,
                                  limited ? maxMemory : 0, opt.progress);
                    running.emplace(pid, Running{t, Timer()});
                }
                int status = 0;
                rusage ru{};
                pid_t pid = wait4(-1, &status, 0, &ru);
                if (pid < 0) {
                    if (errno == EINTR) continue;
                    throw Error(fmt::format("wait4 failed: {}", std::strerror(errno)));
                }
                auto it = running.find(pid);
                if (it == running.end()) continue;  // not ours
                Task t = it->second.task;
                double secs = it->second.timer.seconds();
                running.erase(it);
                uint64_t peak = uint64_t(ru.ru_maxrss) * 1024;  // kilobytes on Linux
                json result;
                if (WIFEXITED(status) && WEXITSTATUS(status) == 0 && fs::exists(t.resultFile)) {
                    std::ifstream in(t.resultFile, std::ios::binary);
                    try {
                        result = json::parse(in);
                    } catch (const std::exception& e) {
                        result = {{"ok", false},
                                  {"kind", "error"},
                                  {"message", fmt::format("unreadable result: {}", e.what())}};
                    }
                    fs::remove(t.resultFile);
                    // The child's CPU time (user + system, all its threads) from
                    // the same wait4: on a loaded machine the phases' wall clocks
                    // grow with the load, this does not.
                    if (result.is_object() && result.contains("summary") &&
                        result["summary"].is_object())
                        result["summary"]["cpu_s"] =
                            double(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
                            1e-6 * double(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
                } else if (WIFSIGNALED(status) &&
                           (WTERMSIG(status) == SIGTERM || WTERMSIG(status) == SIGINT ||
                            WTERMSIG(status) == SIGHUP)) {
                    // Stopped from outside (scancel, a Slurm time limit, Ctrl-C):
                    // not the point's failure. Nothing is recorded, so the point
                    // stays missing and a resumed sweep runs it again; the
                    // parent, sent the same signal, ends too.
                    spdlog::warn(
                        "{} #{} stopped by signal {} ({}); not recorded, it reruns on --resume",
                        t.isReference ? "reference of point" : "point", t.point->index,
                        WTERMSIG(status), signalName(WTERMSIG(status)));
                    fs::remove(t.resultFile);
                    continue;
                } else if (WIFSIGNALED(status)) {
                    int sig = WTERMSIG(status);
                    if (sig == SIGALRM)
                        result = {{"ok", false},
                                  {"kind", "timeout"},
                                  {"message",
                                   fmt::format("exceeded the time limit of {} s", maxSeconds)}};
                    else
                        result = {
                            {"ok", false},
                            {"kind", sig == SIGKILL ? "killed" : "signal"},
                            {"message",
                             fmt::format("child killed by signal {} ({}){}", sig, signalName(sig),
                                         sig == SIGKILL ? "; out of memory?" : "")}};
                } else {
                    result = {
                        {"ok", false},
                        {"kind", "error"},
                        {"message", fmt::format("child exited with status {} without a result",
                                                WIFEXITED(status) ? WEXITSTATUS(status) : -1)}};
                }
                finish(t, result, peak, secs);
            }
        };

    // ---- references, once per (scene, reference settings) ---------------------------
    std::map<std::string, std::string> referenceFailure;  // refId -> message
    if (opt.useCache && !byReference.empty()) {
        std::vector<Task> refTasks;
        int n = 0;
        report.references = byReference.size();
        for (const auto& [refId, pts] : byReference)
            refTasks.push_back(
                Task{true, pts.front(), refId,
                     work / fmt::format("{}reference-{}.json", kResultPrefix, n++)});
        runTasks(
            refTasks,
            [&](const Task& t, const json& r, uint64_t, double secs) {
                if (r.value("ok", false)) {
                    const json& d = r["reference"];
                    spdlog::info("reference {}: {} ({:.2f} s)", t.key,
                                 d.value("cached", false) ? "cached" : "computed", secs);
                } else {
                    referenceFailure[t.key] = r.value("message", "?");
                    ++report.referencesFailed;
                    spdlog::warn("reference {} failed: {}", t.key, referenceFailure[t.key]);
                }
            },
            false);
    }

    if (opt.referencesOnly) {
        std::error_code ec;
        fs::remove_all(work, ec);
        return report;
    }
    ResultStore& store = *storePtr;
    // ---- points ---------------------------------------------------------------------
    std::vector<Task> pointTasks;
    auto recordFailure = [&](const Task& t, const std::string& kind, const std::string& message,
                             double secs, uint64_t peak) {
        FailureRecord f;
        f.key = t.key;
        f.study = studyHash;
        f.pointIndex = int64_t(t.point->index);
        f.scene = t.point->sceneLabel;
        f.settingsJson = paramsToJsonText(t.point->settings);
        f.kind = kind;
        f.message = message;
        f.wallSeconds = secs;
        f.peakRss = peak;
        store.addFailure(f);
        ++report.failed;
        spdlog::warn("point #{} ({}) failed [{}]: {}", t.point->index, t.point->sceneLabel, kind,
                     message);
        if (opt.onPointDone) opt.onPointDone(*t.point, false);
    };
    for (const Task& t : todo) {
        std::string refId = referenceId(*t.point);
        auto it = referenceFailure.find(refId);
        if (it != referenceFailure.end())
            recordFailure(t, "reference", "reference failed: " + it->second, 0.0, 0);
        else
            pointTasks.push_back(t);
    }
    size_t total = pointTasks.size(), count = 0;
    runTasks(
        pointTasks,
        [&](const Task& t, const json& r, uint64_t peak, double secs) {
            ++count;
            if (!r.value("ok", false)) {
                recordFailure(t, r.value("kind", "error"), r.value("message", "?"), secs, peak);
                return;
            }
            json summary = r["summary"];
            // The child's own VmHWM is in memory.peak_rss; wait4's value
            // is the same measure taken by the kernel at exit.
            summary["memory"]["peak_rss_wait4"] = peak;
            // Artefact files as seen from the store's folder (stores are
            // committed; see the study path above).
            if (summary.contains("artefacts") && summary["artefacts"].is_object())
                for (auto& [name, file] : summary["artefacts"].items()) {
                    if (!file.is_string()) continue;
                    std::string rel = relativeToStore(file.get<std::string>());
                    if (!rel.empty()) file = rel;
                }
            store.addRun(t.key, studyHash, int64_t(t.point->index), summary);
            ++report.finished;
            std::string vary;
            for (const auto& [k, v] : t.point->varying) vary += fmt::format(" {}={}", k, v);
            json l2 = summary.contains("error") ? summary["error"].value("l2_lum", json(nullptr))
                                                : json(nullptr);
            spdlog::info("[{}/{}] #{} {}{}: {:.2f} s{}", count, total, t.point->index,
                         t.point->sceneLabel, vary, summary.value("wall_seconds", 0.0),
                         l2.is_number() ? fmt::format(", L2(lum) {:.4g}", l2.get<double>()) : "");
            if (opt.onPointDone) opt.onPointDone(*t.point, true);
        },
        true);
    std::error_code ec;
    fs::remove(work, ec);  // only when empty
    return report;
}

}  // namespace hrad::experiments
