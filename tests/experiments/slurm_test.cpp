// The Slurm pipeline's pieces without a Slurm: the [slurm] table's checks,
// the generated scripts, point lists, references-only sweeps, the store
// status and resubmission lists. tests/slurm/ submits the pipeline to a real
// Slurm.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <sstream>

#include <sys/wait.h>

#include <fmt/format.h>

#include "experiments/slurm.h"
#include "experiments/store.h"
#include "experiments/sweep.h"
#include "tests/test_util.h"

namespace hrad::experiments {
namespace {

namespace fs = std::filesystem;
using test::TempDir;
using test::tempDir;
using test::writeFile;

const char* kStudy = R"(name = "slurmstudy"
scenes = ["furnace", "cornell"]
[solver]
"hr.max_iterations" = 3
[reference]
kind = "full-matrix"
"fm.level" = 0
[limits]
max_seconds = 60
max_memory_mb = 1024
[slurm]
partition = "short"
account = "lab-7"
max_parallel = 2
sbatch = ["--qos=normal", "--constraint=avx2"]
[sweep]
"oracle.eps" = [0.5, 0.2, 0.1, 0.05]
)";

std::string errorOf(const std::string& slurmTable) {
    try {
        parseStudy(std::string("scenes = [\"furnace\"]\n[slurm]\n") + slurmTable, "study.toml", ".");
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

std::string readText(const fs::path& p) {
    std::ifstream in(p);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

int countOf(const std::string& text, const std::string& what) {
    int n = 0;
    for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
    return n;
}

SlurmRound round(uint64_t points, size_t references) {
    SlurmRound r;
    r.binary = "/opt/hrad/bin/hrad";
    r.study = "/home/u/s.toml";
    r.store = "/home/u/results/s.sqlite";
    r.dir = "/home/u/results/s.sqlite.slurm";
    r.cache = "/home/u/cache";
    r.scriptDir = r.dir;
    r.points = points;
    r.references = references;
    return r;
}

TEST(SlurmTime, ParsesEverySlurmFormAndFormatsInWholeMinutes) {
    EXPECT_EQ(parseSlurmTime("90"), 90 * 60);
    EXPECT_EQ(parseSlurmTime("10:30"), 10 * 60 + 30);
    EXPECT_EQ(parseSlurmTime("2:00:00"), 7200);
    EXPECT_EQ(parseSlurmTime("1-12"), 86400 + 12 * 3600);
    EXPECT_EQ(parseSlurmTime("1-0:30"), 86400 + 1800);
    EXPECT_EQ(parseSlurmTime("2-01:00:05"), 2 * 86400 + 3600 + 5);
    for (const char* bad : {"", "0", "1h", "1:2:3:4", "-5", "1-", "a-1:00", "1.5", "1-1:2:3:4"})
        EXPECT_EQ(parseSlurmTime(bad), -1) << bad;
    EXPECT_EQ(formatSlurmTime(666), "00:12:00");  // rounded up to whole minutes
    EXPECT_EQ(formatSlurmTime(1), "00:01:00");
    EXPECT_EQ(formatSlurmTime(86400 + 3600 * 2 + 60), "1-02:01:00");
}

TEST(SlurmSettings, StudyTableIsCheckedOnLoadWithFileAndLine) {
    Study s = parseStudy(kStudy, "study.toml", ".");
    SlurmSettings st = slurmSettingsFromParams(s.slurm);
    EXPECT_EQ(st.partition, "short");
    EXPECT_EQ(st.account, "lab-7");
    EXPECT_EQ(st.maxParallel, 2);
    EXPECT_EQ(st.cpus, 1);
    ASSERT_EQ(st.extra.size(), 2u);
    EXPECT_EQ(st.extra[1], "--constraint=avx2");

    EXPECT_NE(errorOf("partiton = \"x\"\n").find("study.toml:3"), std::string::npos);
    EXPECT_NE(errorOf("partiton = \"x\"\n").find("unknown key 'slurm.partiton'"), std::string::npos);
    EXPECT_NE(errorOf("time = \"2h\"\n").find("not a Slurm time"), std::string::npos);
    EXPECT_NE(errorOf("mem = \"4 GB\"\n").find("not a memory size"), std::string::npos);
    EXPECT_NE(errorOf("mem = 0\n").find("not a memory size"), std::string::npos);
    EXPECT_NE(errorOf("partition = \"a b\"\n").find("slurm.partition"), std::string::npos);
    EXPECT_NE(errorOf("job_name = \"x;rm\"\n").find("slurm.job_name"), std::string::npos);
    EXPECT_NE(errorOf("sbatch = [\"qos=long\"]\n").find("sbatch options"), std::string::npos);
    EXPECT_NE(errorOf("sbatch = [\"--qos=long\\n#SBATCH --x\"]\n").find("sbatch options"), std::string::npos);
    EXPECT_NE(errorOf("sbatch = [1]\n").find("list of strings"), std::string::npos);
    EXPECT_NE(errorOf("cpus = 0\n").find("cpus"), std::string::npos);
    EXPECT_NE(errorOf("tasks = 5000\n").find("MaxArraySize"), std::string::npos);
    EXPECT_EQ(errorOf("time = 90\nmem = 4000\ncpus = 4\ntasks = 10\nreference_time = \"1-00:00\"\n"), "");
}

TEST(SlurmScripts, PointsArrayCarriesTheSettingsAndDerivedLimits) {
    Study s = parseStudy(kStudy, "study.toml", ".");
    SlurmSettings st = slurmSettingsFromParams(s.slurm);
    SlurmScripts sc = makeSlurmScripts(s, st, round(8, 2));
    const std::string& p = sc.points;
    EXPECT_NE(p.find("#SBATCH --array=0-7%2\n"), std::string::npos);
    EXPECT_NE(p.find("#SBATCH --cpus-per-task=1\n"), std::string::npos);
    // 1 point per task: 60 s x 1.1 + 600 s = 666 s, rounded up to 12 minutes.
    EXPECT_NE(p.find("#SBATCH --time=00:12:00\n"), std::string::npos);
    // max_memory_mb 1024 + 512 for the parent.
    EXPECT_NE(p.find("#SBATCH --mem=1536M\n"), std::string::npos);
    EXPECT_NE(p.find("--shard \"$SLURM_ARRAY_TASK_ID/8\""), std::string::npos);
    EXPECT_NE(p.find("--store '/home/u/results/s.sqlite.slurm/shards'/task-\"$SLURM_ARRAY_TASK_ID\".sqlite"),
              std::string::npos);
    EXPECT_NE(p.find("--resume --cache '/home/u/cache'"), std::string::npos);
    EXPECT_NE(p.find("exec '/opt/hrad/bin/hrad' --log info --threads 1 sweep '/home/u/s.toml'"), std::string::npos);
    EXPECT_EQ(p.find("--points-file"), std::string::npos);
    // Partition, account and the extra lines in all three jobs.
    for (const std::string* t : {&sc.references, &sc.points, &sc.merge}) {
        EXPECT_EQ(countOf(*t, "#SBATCH --partition=short\n"), 1);
        EXPECT_EQ(countOf(*t, "#SBATCH --account=lab-7\n"), 1);
        EXPECT_EQ(countOf(*t, "#SBATCH --qos=normal\n"), 1);
        EXPECT_EQ(countOf(*t, "#SBATCH --constraint=avx2\n"), 1);
        EXPECT_EQ(t->rfind("#!/bin/bash\n", 0), 0u);
    }
    EXPECT_NE(sc.references.find("--references-only --cache '/home/u/cache'"), std::string::npos);
    EXPECT_NE(sc.references.find("2 distinct reference(s)"), std::string::npos);
    EXPECT_NE(sc.merge.find("results merge '/home/u/results/s.sqlite' \"${shards[@]}\""), std::string::npos);
    EXPECT_NE(sc.merge.find("--status --store '/home/u/results/s.sqlite' --report "
                            "'/home/u/results/s.sqlite.slurm/report.txt'"),
              std::string::npos);
    // The chain: points afterok on the references, merge afterany on the array.
    EXPECT_NE(sc.submit.find("--dependency=afterok:\"$refs\" --kill-on-invalid-dep=yes points.sbatch"),
              std::string::npos);
    EXPECT_NE(sc.submit.find("--dependency=afterany:\"$points\" merge.sbatch"), std::string::npos);
    EXPECT_NE(sc.submit.find("> jobs.txt"), std::string::npos);
}

TEST(SlurmScripts, SeveralPointsPerTaskScaleTheTimeAndOptionsOverride) {
    Study s = parseStudy(kStudy, "study.toml", ".");
    Params p = s.slurm;
    p.set("tasks", int64_t(3), {"command line (--slurm-set)", 0, 0});
    p.set("cpus", int64_t(4), {"command line (--slurm-set)", 0, 0});
    SlurmScripts sc = makeSlurmScripts(s, slurmSettingsFromParams(p), round(8, 2));
    EXPECT_NE(sc.points.find("#SBATCH --array=0-2%2\n"), std::string::npos);
    // ceil(8 / 3) = 3 points: 3 x 60 x 1.1 + 600 = 798 s -> 14 minutes.
    EXPECT_NE(sc.points.find("#SBATCH --time=00:14:00\n"), std::string::npos);
    EXPECT_NE(sc.points.find("#SBATCH --cpus-per-task=4\n"), std::string::npos);
    EXPECT_NE(sc.points.find("--threads 4"), std::string::npos);
    EXPECT_NE(sc.points.find("/3\""), std::string::npos);

    p.set("time", std::string("2-00:00:00"), {"command line (--slurm-set)", 0, 0});
    p.set("mem", std::string("8G"), {"command line (--slurm-set)", 0, 0});
    sc = makeSlurmScripts(s, slurmSettingsFromParams(p), round(8, 2));
    EXPECT_NE(sc.points.find("#SBATCH --time=2-00:00:00\n"), std::string::npos);
    EXPECT_NE(sc.points.find("#SBATCH --mem=8G\n"), std::string::npos);
}

TEST(SlurmScripts, NoReferenceNoReferencesJobAndResumeRoundsReadTheirList) {
    Study s = parseStudy("scenes = [\"furnace\"]\n[sweep]\n\"oracle.eps\" = [0.5, 0.2]\n", "study.toml", ".");
    SlurmRound r = round(2, 0);
    r.scriptDir = r.dir / "resume-1";
    r.shardPrefix = "resume-1-task";
    r.pointsFile = r.scriptDir / "points.txt";
    SlurmScripts sc = makeSlurmScripts(s, slurmSettingsFromParams(s.slurm), r);
    EXPECT_TRUE(sc.references.empty());
    EXPECT_EQ(sc.submit.find("references.sbatch"), std::string::npos);
    EXPECT_EQ(sc.submit.find("afterok"), std::string::npos);
    EXPECT_NE(sc.points.find("#SBATCH --array=0-1\n"), std::string::npos);  // no %P, no limits
    EXPECT_EQ(sc.points.find("--time"), std::string::npos);
    EXPECT_EQ(sc.points.find("--mem"), std::string::npos);
    EXPECT_NE(sc.points.find("--points-file '/home/u/results/s.sqlite.slurm/resume-1/points.txt'"),
              std::string::npos);
    EXPECT_NE(sc.points.find("/resume-1-task-\"$SLURM_ARRAY_TASK_ID\".sqlite"), std::string::npos);
    EXPECT_NE(sc.merge.find("resume-1/report.txt"), std::string::npos);
}

TEST(PointList, ReadsIndicesAndRejectsBadOnesAtTheirLine) {
    TempDir dir = tempDir("pointlist");
    Study s = parseStudy(kStudy, "study.toml", ".");
    fs::path f = writeFile(dir / "p.txt", "# missing\n3, 1\n\n7 # last\n");
    EXPECT_EQ(readPointList(f, s), (std::vector<uint64_t>{3, 1, 7}));
    auto err = [&](const std::string& text) {
        try {
            readPointList(writeFile(dir / "bad.txt", text), s);
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    EXPECT_NE(err("1\n8\n").find("bad.txt:2"), std::string::npos);
    EXPECT_NE(err("1\n8\n").find("out of range"), std::string::npos);
    EXPECT_NE(err("2 2\n").find("listed twice"), std::string::npos);
    EXPECT_NE(err("1\n-1\n").find("bad.txt:2"), std::string::npos);
    EXPECT_NE(err("99999999999999999999999\n").find("expected a point index"), std::string::npos);
    EXPECT_NE(err("# nothing\n").find("empty"), std::string::npos);
}

TEST(SlurmPipeline, ListedPointsStatusAndResumeList) {
    TempDir dir = tempDir("slurmpipe");
    // No address-space limit here: RLIMIT_AS of 1 GiB leaves AddressSanitizer
    // (scripts/sanitize.sh) no room for its shadow memory.
    std::string text = kStudy;
    text.erase(text.find("max_memory_mb = 1024\n"), std::string("max_memory_mb = 1024\n").size());
    fs::path studyFile = writeFile(dir / "s.toml", text);
    Study s = loadStudy(studyFile);
    fs::path store = dir / "s.sqlite";

    // References only: both distinct references into the cache, no store.
    SweepOptions ro;
    ro.store = store;
    ro.cacheDir = (dir / "cache").string();
    ro.referencesOnly = true;
    ro.threads = 1;
    SweepReport rr = runSweep(s, ro);
    EXPECT_EQ(rr.references, 2u);
    EXPECT_EQ(rr.referencesFailed, 0u);
    EXPECT_FALSE(fs::exists(store));

    // Shard 0/2 of the list {6, 1, 3}: positions 0 and 2, points 6 and 3.
    SweepOptions so = ro;
    so.referencesOnly = false;
    so.pointList = {6, 1, 3};
    so.shardIndex = 0;
    so.shardCount = 2;
    SweepReport r = runSweep(s, so);
    EXPECT_EQ(r.selected, 2u);
    EXPECT_EQ(r.finished, 2u);

    StoreStatus st = storeStatus(s, store);
    EXPECT_EQ(st.points, 8u);
    EXPECT_EQ(st.finished, 2u);
    EXPECT_EQ(st.missing, (std::vector<uint64_t>{0, 1, 2, 4, 5, 7}));
    EXPECT_NE(describeStatus(s, st).find("missing: #4 cornell oracle.eps=0.5"), std::string::npos);
    EXPECT_EQ(storeStatus(s, dir / "none.sqlite").missing.size(), 8u);

    // A new submission refuses a store with rows; a dry-run resubmission
    // lists exactly the missing points.
    SlurmOptions o;
    o.store = store;
    o.binary = "/opt/hrad/bin/hrad";
    EXPECT_THROW(runSlurm(s, o), Error);
    o.resume = true;
    o.dryRun = true;
    EXPECT_EQ(runSlurm(s, o), 0);
    fs::path d = fs::path(store.string() + ".slurm");
    std::string list = readText(d / "resume-1" / "points.txt");
    EXPECT_NE(list.find("\n0\n1\n2\n4\n5\n7\n"), std::string::npos) << list;
    EXPECT_NE(readText(d / "resume-1" / "points.sbatch").find("#SBATCH --array=0-5%2"), std::string::npos);
    EXPECT_TRUE(fs::exists(d / "resume-1" / "references.sbatch"));
    EXPECT_FALSE(fs::exists(d / "resume-1" / "jobs.txt"));
}

// Issue 64: every user string reaches the shell quoted. The generated scripts
// are run by bash with a stand-in hrad that records its arguments; the paths
// hold a newline, quotes, $() and spaces, and nothing they spell is executed.
TEST(SlurmScripts, HostilePathsReachTheProgramIntactAndRunNothing) {
    TempDir dir = tempDir("slurm_hostile");
    const std::string evil = "a b'c\"d$(touch PWNED)`touch PWNED2`\n#SBATCH --wrap=x\ntouch PWNED3;";
    fs::path hostile = dir / evil;
    fs::create_directories(hostile);
    fs::path args = dir / "args";
    fs::path fake = writeFile(hostile / "hrad", "#!/bin/sh\nfor a in \"$@\"; do printf '%s\\0' \"$a\"; done >> \"$ARGS_OUT\"\n");
    fs::permissions(fake, fs::perms::owner_all);
    Study s = parseStudy("scenes = [\"furnace\"]\n", "study.toml", ".");
    s.name = "hostile";
    SlurmRound r = round(1, 1);
    r.binary = fake;
    r.study = hostile / "s\n$(touch PWNED4).toml";
    r.store = hostile / "s.sqlite";
    r.cache = hostile / "cache";
    r.dir = dir / "slurm";  // checkScriptPath keeps the folder plain (#SBATCH lines)
    r.scriptDir = r.dir;
    r.pointsFile = hostile / "points.txt";
    SlurmScripts sc = makeSlurmScripts(s, slurmSettingsFromParams(s.slurm), r);
    for (const std::string* script : {&sc.references, &sc.points, &sc.merge}) {
        writeFile(dir / "job.sh", *script);
        std::string cmd = fmt::format("cd '{}' && SLURM_ARRAY_TASK_ID=0 ARGS_OUT='{}' bash job.sh",
                                      dir.string(), args.string());
        int rc = std::system(cmd.c_str());
        EXPECT_TRUE(WIFEXITED(rc)) << *script;
    }
    // Every script called the stand-in with the study path as one argument.
    std::string recorded = readText(args);
    std::vector<std::string> argv;
    for (size_t at = 0, nul; (nul = recorded.find('\0', at)) != std::string::npos; at = nul + 1)
        argv.push_back(recorded.substr(at, nul - at));
    EXPECT_EQ(std::count(argv.begin(), argv.end(), r.study.string()), 3) << recorded;
    EXPECT_EQ(std::count(argv.begin(), argv.end(), r.pointsFile.string()), 2);
    EXPECT_EQ(std::count(argv.begin(), argv.end(), r.cache.string()), 2);
    EXPECT_EQ(std::count(argv.begin(), argv.end(), r.store.string()), 1);
    for (const char* f : {"PWNED", "PWNED2", "PWNED3", "PWNED4"}) {
        EXPECT_FALSE(fs::exists(dir / f)) << f;
        EXPECT_FALSE(fs::exists(dir / "slurm" / f)) << f;
    }
    // No line of the header comment starts a command, nor an #SBATCH line:
    // the first line that is not a comment is the exec (sbatch reads
    // directives only up to it; later newlines are inside quotes).
    std::istringstream lines(sc.points);
    std::string first;
    int directives = 0;
    for (std::string l; std::getline(lines, l);) {
        if (!l.empty() && l[0] != '#') {
            first = l;
            break;
        }
        directives += l.rfind("#SBATCH", 0) == 0 ? 1 : 0;
    }
    EXPECT_EQ(first.rfind("exec ", 0), 0u) << sc.points;
    EXPECT_EQ(directives, 4) << sc.points;  // job name, array, cpus, output
}

}  // namespace
}  // namespace hrad::experiments
