#include "experiments/slurm.h"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <sqlite3.h>

#include "experiments/runner.h"
#include "experiments/store.h"

extern char** environ;

namespace hrad::experiments {

namespace fs = std::filesystem;

namespace {

/// A string setting; integers are accepted as their decimal text (time = 90,
/// --slurm-set partition=1). Marks the key used.
std::string textOf(const Params& p, const std::string& key) {
    if (!p.has(key)) return "";
    const Params::Entry& e = p.entries().at(key);
    p.markUsed(key);
    if (auto s = std::get_if<std::string>(&e.value)) return *s;
    if (auto i = std::get_if<int64_t>(&e.value)) return std::to_string(*i);
    throwInputError(e.where, "'slurm.{}' must be a string", key);
}

/// Names that go into #SBATCH lines unquoted: partition, account, job name.
void checkName(const Params& p, const std::string& key, const std::string& v, const char* allowedExtra) {
    for (char c : v)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || std::strchr(allowedExtra, c)))
            throwInputError(p.where(key), "'slurm.{}' = '{}' may only contain letters, digits and '{}'",
                            key, v, allowedExtra);
}

std::string timeOf(const Params& p, const std::string& key) {
    std::string v = textOf(p, key);
    if (!v.empty() && parseSlurmTime(v) < 0)
        throwInputError(p.where(key),
                        "'slurm.{}' = '{}' is not a Slurm time (minutes, MM:SS, HH:MM:SS, D-HH, "
                        "D-HH:MM or D-HH:MM:SS)",
                        key, v);
    return v;
}

/// Slurm's --mem: an integer (MB) with an optional unit K, M, G or T.
std::string memOf(const Params& p, const std::string& key) {
    std::string v = textOf(p, key);
    if (v.empty()) return v;
    size_t digits = 0;
    while (digits < v.size() && std::isdigit(static_cast<unsigned char>(v[digits]))) ++digits;
    std::string unit = v.substr(digits);
    bool ok = digits > 0 && digits <= 12 &&
              (unit.empty() || unit == "K" || unit == "M" || unit == "G" || unit == "T");
    if (!ok || std::stoull(v.substr(0, digits)) == 0)
        throwInputError(p.where(key),
                        "'slurm.{}' = '{}' is not a memory size for Slurm (MB as an integer, or "
                        "a number with K, M, G or T: 4000M, 4G)",
                        key, v);
    return v;
}

/// Paths that appear in #SBATCH --output lines, which sbatch does not unquote.
void checkScriptPath(const fs::path& p, const std::string& what) {
    for (char c : p.string())
        if (std::isspace(static_cast<unsigned char>(c)) || c == '%' || c == '"' || c == '\'' ||
            c == '\\' || static_cast<unsigned char>(c) < 0x20)
            throwInputError(SourceLocation{"command line (--slurm-dir)", 0, 0},
                            "{} '{}' may not contain whitespace, quotes, backslashes or '%' (it "
                            "goes into #SBATCH --output lines)",
                            what, p.string());
}

/// Single-quoted for bash.
std::string sq(const std::string& s) {
    std::string out = "'";
    for (char c : s) {
        if (c == '\'') out += "'\\''";
        else out += c;
    }
    return out + "'";
}
std::string sq(const fs::path& p) { return sq(p.string()); }

/// Text for a '#' comment line: control characters (a newline would end the
/// comment and start a command) shown as \xNN.
std::string commentText(const std::string& s) {
    std::string out;
    for (char c : s) {
        auto u = static_cast<unsigned char>(c);
        if (u < 0x20 || u == 0x7f) out += fmt::format("\\x{:02x}", u);
        else out += c;
    }
    return out;
}
std::string commentText(const fs::path& p) { return commentText(p.string()); }

std::string readFile(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

void writeFile(const fs::path& p, const std::string& text, bool executable = false) {
    fs::path tmp = p;
    tmp += ".tmp";
    {
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        out << text;
        if (!out) throw Error(fmt::format("cannot write {}", tmp.string()));
    }
    fs::rename(tmp, p);
    if (executable)
        fs::permissions(p, fs::perms::owner_exec | fs::perms::group_exec | fs::perms::others_exec,
                        fs::perm_options::add);
}

fs::path resolveAgainstStudy(const std::string& value, const SourceLocation& where, const Study& study) {
    fs::path v(value);
    if (v.is_absolute()) return v;
    // Relative to the study's folder when the study said it, else to the
    // working directory (--slurm-set).
    if (!study.path.empty() && where.file == study.path.string())
        return fs::absolute(study.path).parent_path() / v;
    return fs::absolute(v);
}

/// Job ids recorded by earlier rounds' submit.sh (jobs.txt files).
std::vector<std::string> recordedJobs(const fs::path& dir) {
    std::vector<fs::path> files;
    if (fs::exists(dir / "jobs.txt")) files.push_back(dir / "jobs.txt");
    if (fs::is_directory(dir))
        for (const auto& e : fs::directory_iterator(dir))
            if (e.is_directory() && e.path().filename().string().rfind("resume-", 0) == 0 &&
                fs::exists(e.path() / "jobs.txt"))
                files.push_back(e.path() / "jobs.txt");
    std::vector<std::string> ids;
    for (const fs::path& f : files) {
        std::istringstream in(readFile(f));
        std::string line;
        while (std::getline(in, line)) {
            auto eq = line.find('=');
            if (eq != std::string::npos && eq + 1 < line.size()) ids.push_back(line.substr(eq + 1));
        }
    }
    return ids;
}

/// Output of a command (argv, no shell); throws Error when it cannot run or
/// exits non-zero.
std::string capture(const std::vector<std::string>& argv) {
    std::string cmd;
    for (const auto& a : argv) cmd += (cmd.empty() ? "" : " ") + sq(a);
    cmd += " 2>&1";
    FILE* f = popen(cmd.c_str(), "r");
    if (!f) throw Error(fmt::format("cannot run {}: {}", argv[0], std::strerror(errno)));
    std::string out;
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0 && out.size() < (1u << 24)) out.append(buf, n);
    int status = pclose(f);
    if (status != 0)
        throw Error(fmt::format("{} failed (status {}): {}", argv[0],
                                WIFEXITED(status) ? WEXITSTATUS(status) : -1, out));
    return out;
}

int runScript(const fs::path& script) {
    std::string bash = "bash", path = script.string();
    char* argv[] = {bash.data(), path.data(), nullptr};
    std::fflush(nullptr);
    pid_t pid = 0;
    int rc = posix_spawnp(&pid, "bash", nullptr, nullptr, argv, environ);
    if (rc != 0) throw Error(fmt::format("cannot run bash {}: {}", path, std::strerror(rc)));
    int status = 0;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR) throw Error(fmt::format("waitpid failed: {}", std::strerror(errno)));
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::string jobNameOf(const Study& study, const SlurmSettings& s) {
    if (!s.jobName.empty()) return s.jobName;
    std::string n = "hrad-";
    for (char c : study.name)
        n += std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' ? c : '_';
    return n;
}

}  // namespace

int64_t parseSlurmTime(const std::string& text) {
    // Slurm's accepted forms (sbatch(1), --time): "minutes", "minutes:seconds",
    // "hours:minutes:seconds", "days-hours", "days-hours:minutes",
    // "days-hours:minutes:seconds".
    if (text.empty() || text.size() > 20) return -1;
    int64_t days = 0;
    std::string rest = text;
    bool hasDays = false;
    if (auto dash = text.find('-'); dash != std::string::npos) {
        std::string d = text.substr(0, dash);
        if (d.empty() || !std::all_of(d.begin(), d.end(), ::isdigit)) return -1;
        days = std::stoll(d);
        rest = text.substr(dash + 1);
        hasDays = true;
    }
    std::vector<int64_t> f;
    std::string cur;
    for (size_t i = 0; i <= rest.size(); ++i) {
        if (i == rest.size() || rest[i] == ':') {
            if (cur.empty() || cur.size() > 9) return -1;
            f.push_back(std::stoll(cur));
            cur.clear();
        } else if (std::isdigit(static_cast<unsigned char>(rest[i]))) {
            cur += rest[i];
        } else {
            return -1;
        }
    }
    int64_t s = 0;
    if (hasDays) {
        if (f.size() == 1) s = f[0] * 3600;
        else if (f.size() == 2) s = f[0] * 3600 + f[1] * 60;
        else if (f.size() == 3) s = f[0] * 3600 + f[1] * 60 + f[2];
        else return -1;
        s += days * 86400;
    } else {
        if (f.size() == 1) s = f[0] * 60;
        else if (f.size() == 2) s = f[0] * 60 + f[1];
        else if (f.size() == 3) s = f[0] * 3600 + f[1] * 60 + f[2];
        else return -1;
    }
    return s > 0 ? s : -1;
}

std::string formatSlurmTime(int64_t seconds) {
    int64_t minutes = std::max<int64_t>(1, (seconds + 59) / 60);
    int64_t d = minutes / 1440, h = (minutes % 1440) / 60, m = minutes % 60;
    return d > 0 ? fmt::format("{}-{:02}:{:02}:00", d, h, m) : fmt::format("{:02}:{:02}:00", h, m);
}

SlurmSettings slurmSettingsFromParams(const Params& p) {
    Params::Scope scope(p, "slurm");
    SlurmSettings s;
    s.partition = textOf(p, "partition");
    checkName(p, "partition", s.partition, "_.,-");
    s.account = textOf(p, "account");
    checkName(p, "account", s.account, "_.-");
    s.jobName = textOf(p, "job_name");
    checkName(p, "job_name", s.jobName, "_.-");
    s.time = timeOf(p, "time");
    s.referenceTime = timeOf(p, "reference_time");
    s.mergeTime = timeOf(p, "merge_time");
    s.mem = memOf(p, "mem");
    s.referenceMem = memOf(p, "reference_mem");
    s.cpus = int(p.getInt({"cpus", "Slurm: CPUs per task of a sweep"}, 1, 1, 4096));
    s.referenceCpus = int(
        p.getInt({"reference_cpus", "Slurm: CPUs of the reference job (0: as cpus)"}, 0, 0, 4096));
    s.tasks = int(p.getInt({"tasks", "Slurm: array tasks (0: one per point)"}, 0, 0, 1'000'000));
    s.maxParallel = int(p.getInt(
        {"max_parallel", "Slurm: array tasks running at once (0: no limit)"}, 0, 0, 1'000'000));
    std::string extra = textOf(p, "sbatch");
    if (!extra.empty()) {
        std::istringstream in(extra);
        std::string line;
        while (std::getline(in, line)) {
            auto b = line.find_first_not_of(" \t");
            auto e = line.find_last_not_of(" \t");
            line = b == std::string::npos ? "" : line.substr(b, e - b + 1);
            bool control = std::any_of(line.begin(), line.end(),
                                       [](char c) { return static_cast<unsigned char>(c) < 0x20; });
            if (line.empty() || line[0] != '-' || control)
                throwInputError(p.where("sbatch"),
                                "'slurm.sbatch' entries are sbatch options, one per entry, such as "
                                "\"--qos=long\" (got '{}')",
                                line);
            s.extra.push_back(line);
        }
    }
    s.cache = textOf(p, "cache");
    s.cacheWhere = p.where("cache");
    s.dir = textOf(p, "dir");
    s.dirWhere = p.where("dir");
    if (p.has("tasks") && s.tasks > kMaxArrayTasks)
        throwInputError(p.where("tasks"),
                        "'slurm.tasks' = {} is more array tasks than Slurm's default MaxArraySize "
                        "allows (at most {}); several points per task are fine",
                        s.tasks, kMaxArrayTasks);
    // Messages name the keys as written in the study: [slurm] table keys.
    for (const std::string& k : p.unusedKeys())
        throwInputError(p.where(k),
                        "unknown key 'slurm.{}' (expected partition, account, time, mem, cpus, "
                        "tasks, max_parallel, sbatch, reference_time, reference_mem, "
                        "reference_cpus, merge_time, cache, dir, job_name)",
                        k);
    return s;
}

int slurmTaskCount(const SlurmSettings& s, uint64_t points) {
    uint64_t cap = s.tasks > 0 ? uint64_t(s.tasks) : uint64_t(kMaxArrayTasks);
    return int(std::max<uint64_t>(1, std::min(points, cap)));
}

SlurmScripts makeSlurmScripts(const Study& study, const SlurmSettings& s, const SlurmRound& r) {
    SlurmScripts out;
    const int tasks = slurmTaskCount(s, r.points);
    const uint64_t perTask = (r.points + uint64_t(tasks) - 1) / uint64_t(tasks);
    const std::string name = jobNameOf(study, s);
    const fs::path logs = r.dir / "logs";
    const fs::path shards = r.dir / "shards";
    std::string round = r.pointsFile.empty() ? std::string("every point of the study")
                                             : fmt::format("the {} point(s) listed in {}", r.points,
                                                           commentText(r.pointsFile));

    // Lines shared by the three jobs.
    auto common = [&](std::string& t) {
        if (!s.partition.empty()) t += fmt::format("#SBATCH --partition={}\n", s.partition);
        if (!s.account.empty()) t += fmt::format("#SBATCH --account={}\n", s.account);
        for (const auto& e : s.extra) t += fmt::format("#SBATCH {}\n", e);
    };
    std::string pointsFileArg = r.pointsFile.empty() ? "" : " --points-file " + sq(r.pointsFile);
    const std::string head = fmt::format(
        "#!/bin/bash\n"
        "# hrad Slurm pipeline of study '{}' ({}),\n"
        "# written by `hrad sweep --slurm` for {}.\n"
        "# A plain script: edit it if needed, then submit the pipeline with\n"
        "#   bash {}\n",
        commentText(study.name), commentText(r.study), round,
        commentText(r.scriptDir / "submit.sh"));

    // ---- references -----------------------------------------------------------------
    if (r.references > 0) {
        std::string& t = out.references;
        int cpus = s.referenceCpus > 0 ? s.referenceCpus : s.cpus;
        t = head;
        t += fmt::format(
            "# Job 1 of 3: computes each of the {} distinct reference(s) once into the\n"
            "# reference cache, which every node reads (the points job waits for this\n"
            "# one: --dependency=afterok).\n",
            r.references);
        t += fmt::format("#SBATCH --job-name={}-references\n", name);
        t += fmt::format("#SBATCH --cpus-per-task={}\n", cpus);
        if (!s.referenceTime.empty()) t += fmt::format("#SBATCH --time={}\n", s.referenceTime);
        if (!s.referenceMem.empty()) t += fmt::format("#SBATCH --mem={}\n", s.referenceMem);
        common(t);
        t += fmt::format("#SBATCH --output={}/references-%j.out\n", logs.string());
        t += fmt::format("exec {} --log info --threads {} sweep {} --references-only --cache {}{}\n",
                         sq(r.binary), cpus, sq(r.study), sq(r.cache), pointsFileArg);
    }

    // ---- points ---------------------------------------------------------------------
    {
        std::string& t = out.points;
        t = head;
        t += fmt::format(
            "# Job 2 of 3: a job array of {} task(s), {} point(s) each at most. Task i\n"
            "# runs the points at positions p % {} == i into its own shard store; every\n"
            "# point is committed when it finishes, so a task that is cancelled or hits\n"
            "# its time limit loses only the point it was running (hrad sweep --slurm\n"
            "# --resume submits the missing points again).\n",
            tasks, perTask, tasks);
        t += fmt::format("#SBATCH --job-name={}-points\n", name);
        t += fmt::format("#SBATCH --array=0-{}{}\n", tasks - 1,
                         s.maxParallel > 0 ? fmt::format("%{}", s.maxParallel) : "");
        t += fmt::format("#SBATCH --cpus-per-task={}\n", s.cpus);
        if (!s.time.empty()) {
            t += fmt::format("#SBATCH --time={}\n", s.time);
        } else if (study.limits.maxSeconds > 0) {
            // ceil(points per task) x max_seconds, plus 10 % and 10 minutes
            // for start-up, reading the cached reference and store writes.
            double secs = double(perTask) * study.limits.maxSeconds * 1.1 + 600.0;
            t += fmt::format("#SBATCH --time={}\n", formatSlurmTime(int64_t(secs)));
        }
        if (!s.mem.empty()) {
            t += fmt::format("#SBATCH --mem={}\n", s.mem);
        } else if (study.limits.maxMemoryBytes > 0) {
            // The point's child is limited to max_memory_mb; 512 MB more for
            // the sweep's parent process and SQLite.
            t += fmt::format("#SBATCH --mem={}M\n", ((study.limits.maxMemoryBytes + (1u << 20) - 1) >> 20) + 512);
        }
        common(t);
        t += fmt::format("#SBATCH --output={}/points-%A_%a.out\n", logs.string());
        t += fmt::format(
            "exec {} --log info --threads {} sweep {} --shard \"$SLURM_ARRAY_TASK_ID/{}\"{} \\\n"
            "  --store {}/{}-\"$SLURM_ARRAY_TASK_ID\".sqlite --resume --cache {}\n",
            sq(r.binary), s.cpus, sq(r.study), tasks, pointsFileArg, sq(shards), r.shardPrefix,
            sq(r.cache));
    }

    // ---- merge ----------------------------------------------------------------------
    {
        std::string& t = out.merge;
        t = head;
        t +=
            "# Job 3 of 3: runs after the array whatever its tasks' states\n"
            "# (--dependency=afterany), joins every shard store into the store and\n"
            "# writes report.txt: finished, failed and missing points. Exits 4 when\n"
            "# points are missing, 3 when points failed.\n";
        t += fmt::format("#SBATCH --job-name={}-merge\n", name);
        t += "#SBATCH --cpus-per-task=1\n";
        if (!s.mergeTime.empty()) t += fmt::format("#SBATCH --time={}\n", s.mergeTime);
        common(t);
        t += fmt::format("#SBATCH --output={}/merge-%j.out\n", logs.string());
        t += fmt::format(
            "set -u\n"
            "shopt -s nullglob\n"
            "shards=({}/*.sqlite)\n"
            "rc=0\n"
            "if [ ${{#shards[@]}} -gt 0 ]; then\n"
            "  {} results merge {} \"${{shards[@]}}\" || rc=$?\n"
            "fi\n"
            "{} sweep {} --status --store {} --report {} || {{ s=$?; [ $rc -eq 0 ] && rc=$s; }}\n"
            "exit $rc\n",
            sq(shards), sq(r.binary), sq(r.store), sq(r.binary), sq(r.study), sq(r.store),
            sq(r.scriptDir / "report.txt"));
    }

    // ---- submit.sh ------------------------------------------------------------------
    {
        std::string& t = out.submit;
        t = fmt::format(
            "#!/bin/bash\n"
            "# Submits the hrad Slurm pipeline of study '{}' written beside this\n"
            "# script, chaining the job ids; they go to jobs.txt (hrad sweep --slurm\n"
            "# --resume reads them). If a submission fails, the jobs already submitted\n"
            "# are cancelled.\n"
            "set -euo pipefail\n"
            "cd -- {}\n"
            "submitted=()\n"
            "trap 'rc=$?; if [ $rc -ne 0 ] && [ ${{#submitted[@]}} -gt 0 ]; then scancel \"${{submitted[@]}}\"; "
            "echo \"submission failed; cancelled job(s) ${{submitted[*]}}\" >&2; fi' EXIT\n",
            commentText(study.name), sq(r.scriptDir));
        // sbatch --parsable prints "jobid" or "jobid;cluster".
        if (r.references > 0) {
            t += "refs=$(sbatch --parsable references.sbatch); refs=${refs%%;*}; submitted+=(\"$refs\")\n";
            t += "points=$(sbatch --parsable --dependency=afterok:\"$refs\" --kill-on-invalid-dep=yes "
                 "points.sbatch)\n";
        } else {
            t += "refs=\n";
            t += "points=$(sbatch --parsable points.sbatch)\n";
        }
        t += "points=${points%%;*}; submitted+=(\"$points\")\n";
        t += "merge=$(sbatch --parsable --dependency=afterany:\"$points\" merge.sbatch); "
             "merge=${merge%%;*}; submitted+=(\"$merge\")\n";
        t += "printf 'references=%s\\npoints=%s\\nmerge=%s\\n' \"$refs\" \"$points\" \"$merge\" > jobs.txt\n";
        t += "echo \"submitted: references job ${refs:-(none)}, points array job $points, merge job $merge\"\n";
    }
    return out;
}

StoreStatus storeStatus(const Study& study, const fs::path& storePath) {
    StoreStatus st;
    st.points = study.pointCount();
    std::set<std::string> runs;
    std::map<std::string, std::pair<std::string, std::string>> failures;
    if (fs::exists(storePath)) {
        ResultStore store(storePath, /*readOnly=*/true);
        runs = store.runKeys();
        sqlite3_stmt* q = nullptr;
        if (sqlite3_prepare_v2(store.handle(), "SELECT key, kind, message FROM failures", -1, &q,
                               nullptr) != SQLITE_OK)
            throw Error(fmt::format("cannot read failures of {}: {}", storePath.string(),
                                    sqlite3_errmsg(store.handle())));
        auto col = [&](int i) {
            const unsigned char* t = sqlite3_column_text(q, i);
            return t ? std::string(reinterpret_cast<const char*>(t)) : std::string();
        };
        while (sqlite3_step(q) == SQLITE_ROW) failures[col(0)] = {col(1), col(2)};
        sqlite3_finalize(q);
    }
    for (uint64_t i = 0; i < st.points; ++i) {
        std::string key = pointKey(study.point(i));
        if (runs.count(key)) {
            ++st.finished;
        } else if (auto it = failures.find(key); it != failures.end()) {
            st.failed.push_back({i, it->second.first, it->second.second});
        } else {
            st.missing.push_back(i);
        }
    }
    return st;
}

std::string describeStatus(const Study& study, const StoreStatus& st) {
    std::string out = fmt::format("study '{}': {} point(s): {} finished, {} failed, {} missing\n",
                                  study.name, st.points, st.finished, st.failed.size(),
                                  st.missing.size());
    auto label = [&](uint64_t i) {
        PointSpec p = study.point(i);
        std::string s = fmt::format("#{} {}", i, p.sceneLabel);
        for (const auto& [k, v] : p.varying) s += fmt::format(" {}={}", k, v);
        return s;
    };
    for (const auto& f : st.failed) {
        std::string msg = f.message.substr(0, f.message.find('\n'));
        out += fmt::format("failed:  {} [{}] {}\n", label(f.index), f.kind, msg);
    }
    for (uint64_t i : st.missing) out += fmt::format("missing: {}\n", label(i));
    return out;
}

int runSlurm(const Study& study, const SlurmOptions& o) {
    // Settings: the study's [slurm] table, then --slurm-set on top.
    Params params = study.slurm;
    for (const auto& [k, e] : o.overrides.entries()) params.set(k, e.value, e.where);
    SlurmSettings s = slurmSettingsFromParams(params);
    if (study.path.empty()) throw Error("a Slurm pipeline needs a study file");

    SlurmRound r;
    r.study = fs::absolute(study.path).lexically_normal();
    r.store = fs::absolute(o.store).lexically_normal();
    if (!o.dir.empty()) r.dir = fs::absolute(o.dir);
    else if (!s.dir.empty()) r.dir = resolveAgainstStudy(s.dir, s.dirWhere, study);
    else r.dir = fs::path(r.store.string() + ".slurm");
    r.dir = r.dir.lexically_normal();
    checkScriptPath(r.dir, "the Slurm folder");
    if (!o.cacheDir.empty()) r.cache = fs::absolute(o.cacheDir);
    else if (!s.cache.empty()) r.cache = resolveAgainstStudy(s.cache, s.cacheWhere, study);
    else r.cache = r.dir / "cache";
    r.cache = r.cache.lexically_normal();
    if (!o.binary.empty()) {
        r.binary = fs::absolute(o.binary);
    } else {
        std::error_code ec;
        r.binary = fs::read_symlink("/proc/self/exe", ec);
        if (ec) throw Error(fmt::format("cannot find this executable (/proc/self/exe): {}", ec.message()));
    }

    std::vector<uint64_t> run;  // the points of this round
    std::string roundName;
    if (o.resume) {
        std::vector<std::string> jobs = recordedJobs(r.dir);
        if (!jobs.empty() && !o.dryRun) {
            // %F: the array job id of an array task, the job id otherwise.
            std::string queued = capture({"squeue", "-h", "-o", "%F"});
            std::istringstream in(queued);
            std::set<std::string> live;
            for (std::string id; in >> id;) live.insert(id);
            std::vector<std::string> still;
            for (const auto& j : jobs)
                if (live.count(j)) still.push_back(j);
            if (!still.empty())
                throw Error(fmt::format("job(s) {} of this pipeline are still queued or running; "
                                        "wait for them or scancel them, then --resume",
                                        fmt::join(still, ", ")));
        }
        // Shard stores not merged yet (a merge job that did not run) count.
        if (fs::is_directory(r.dir / "shards")) {
            std::vector<fs::path> shardFiles;
            for (const auto& e : fs::directory_iterator(r.dir / "shards"))
                if (e.path().extension() == ".sqlite") shardFiles.push_back(e.path());
            std::sort(shardFiles.begin(), shardFiles.end());
            if (!shardFiles.empty()) {
                ResultStore merged(r.store);
                int64_t added = 0;
                for (const auto& f : shardFiles) added += merged.mergeFrom(f);
                if (added > 0)
                    fmt::print("merged {} run(s) from {} shard store(s) into {}\n", added,
                               shardFiles.size(), r.store.string());
            }
        }
        StoreStatus st = storeStatus(study, r.store);
        run = st.missing;
        if (o.retryFailed)
            for (const auto& f : st.failed) run.push_back(f.index);
        std::sort(run.begin(), run.end());
        fmt::print("{}", describeStatus(study, st));
        if (run.empty()) {
            fmt::print("nothing to resubmit{}\n",
                       st.failed.empty() ? "" : " (pass --retry-failed to rerun the failed points)");
            return 0;
        }
        int k = 1;
        while (fs::exists(r.dir / fmt::format("resume-{}", k))) ++k;
        roundName = fmt::format("resume-{}", k);
        r.scriptDir = r.dir / roundName;
        r.shardPrefix = roundName + "-task";
        r.pointsFile = r.scriptDir / "points.txt";
    } else {
        r.scriptDir = r.dir;
        if (!o.dryRun) {
            bool hasRows = false;
            if (fs::exists(r.store)) {
                ResultStore store(r.store, /*readOnly=*/true);
                hasRows = store.count("runs") + store.count("failures") > 0;
            }
            bool hasShards = false;
            if (fs::is_directory(r.dir / "shards"))
                for (const auto& e : fs::directory_iterator(r.dir / "shards"))
                    hasShards |= e.path().extension() == ".sqlite";
            if (hasRows || hasShards || fs::exists(r.dir / "jobs.txt"))
                throw Error(fmt::format("{} already holds results of this study (store rows, shard "
                                        "stores or a submitted pipeline in {}); pass --resume to "
                                        "submit only the missing points",
                                        r.store.string(), r.dir.string()));
        }
        run.resize(study.pointCount());
        for (uint64_t i = 0; i < run.size(); ++i) run[i] = i;
    }
    r.points = run.size();
    if (r.points == 0) throw InputError(study.where, "the study has no points");
    std::set<std::string> refs;
    for (uint64_t i : run) {
        std::string id = referenceId(study.point(i));
        if (!id.empty()) refs.insert(id);
    }
    r.references = refs.size();

    SlurmScripts scripts = makeSlurmScripts(study, s, r);
    fs::create_directories(r.scriptDir);
    fs::create_directories(r.dir / "logs");
    fs::create_directories(r.dir / "shards");
    if (!o.dryRun) fs::create_directories(r.cache);
    fs::create_directories(r.store.parent_path());
    struct File {
        const char* name;
        const std::string* text;
    };
    std::vector<File> files = {{"points.sbatch", &scripts.points},
                               {"merge.sbatch", &scripts.merge},
                               {"submit.sh", &scripts.submit}};
    if (!scripts.references.empty()) files.insert(files.begin(), File{"references.sbatch", &scripts.references});
    else fs::remove(r.scriptDir / "references.sbatch");
    // A submission does not overwrite scripts a user edited after a dry run:
    // they are submitted with submit.sh as they are.
    if (!o.dryRun && !o.resume)
        for (const File& f : files)
            if (fs::exists(r.scriptDir / f.name) && readFile(r.scriptDir / f.name) != *f.text)
                throw Error(fmt::format("{} differs from what hrad would write now (edited after "
                                        "--dry-run, or the study changed): submit the scripts as "
                                        "they are with `bash {}`, or remove them to regenerate",
                                        (r.scriptDir / f.name).string(),
                                        (r.scriptDir / "submit.sh").string()));
    if (!r.pointsFile.empty()) {
        std::string list = fmt::format("# points of study '{}' missing from {}\n", study.name,
                                       r.store.string());
        for (uint64_t i : run) list += fmt::format("{}\n", i);
        writeFile(r.pointsFile, list);
    }
    for (const File& f : files) writeFile(r.scriptDir / f.name, *f.text, true);

    int tasks = slurmTaskCount(s, r.points);
    fmt::print("study '{}': {} point(s) in {} array task(s){}, {} distinct reference(s)\n", study.name,
               r.points, tasks, s.maxParallel > 0 ? fmt::format(" ({} at once)", s.maxParallel) : "",
               r.references);
    fmt::print("scripts: {}\n", r.scriptDir.string());
    for (const File& f : files) fmt::print("  {}\n", f.name);
    fmt::print("store: {}\nreference cache: {}\n", r.store.string(), r.cache.string());
    if (o.dryRun) {
        fmt::print("dry run: nothing submitted; submit with `bash {}`\n",
                   (r.scriptDir / "submit.sh").string());
        return 0;
    }
    int rc = runScript(r.scriptDir / "submit.sh");
    if (rc != 0) throw Error(fmt::format("submission failed: bash {} exited with {}",
                                         (r.scriptDir / "submit.sh").string(), rc));
    fmt::print("job ids: {}\nwhen the merge job has run: {}\n", (r.scriptDir / "jobs.txt").string(),
               (r.scriptDir / "report.txt").string());
    return 0;
}

}  // namespace hrad::experiments
