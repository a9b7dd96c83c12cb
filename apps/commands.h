// The hrad subcommands. main.cpp parses the command line (the only file that
// includes CLI11, whose headers are slow to compile) into Params and calls
// one of these. Each returns the process exit code.
#pragma once

#include <string>
#include <vector>

#include "core/params.h"

namespace hrad::app {

struct SolveOptions {
    std::string scene;
    std::string outDir = "out";
    int threads = 0;  ///< 0: all cores
    bool progress = true;
    bool writeImages = true;
    bool writePly = true;
    bool writeGlb = false;  ///< --glb: solution.glb (render/gltf_export.h)
    bool writeLightmap = false;  ///< --lightmap [RES]: lightmap.exr/png/glb (render/lightmap.h)
    bool errorMap = false;  ///< --error-map (needs --reference-level)
    bool writeRegions = false;  ///< --regions: regions.csv (needs --reference-level)
    bool writeSolution = true;  ///< solution.hrsol (--no-solution turns it off)
    /// --reference: "" (none, or --reference-level), "full-matrix" or "montecarlo"
    std::string reference;
    std::string cacheDir;  ///< --cache: reference cache folder ("" : $HRAD_CACHE or ~/.cache/hrad)
};

struct RenderCliOptions {
    std::string scene;
    std::string solution;  ///< a solution.hrsol
    std::string outDir = "out";
    bool writeGlb = false;  ///< --glb: also solution.glb
    std::string compare;    ///< --compare IMAGE.exr: pixel error against it
    bool lightmap = false;  ///< --lightmap [RES]: lightmap.exr/png/glb (RES: render.lightmap_size)
};

struct SweepCliOptions {
    std::string study;
    std::string store;  ///< "" = <study folder>/results/<study name>.sqlite
    int jobs = 1;
    std::string shard;  ///< "i/N" or ""
    bool resume = false;
    bool retryFailed = false;
    bool dryRun = false;
    double maxSeconds = 0.0;
    std::string maxMemory;  ///< "4G" or ""
    int threads = 0;
    bool progress = false;
    std::string cacheDir;
    bool noCache = false;
    int64_t maxPoints = 0;  ///< sweep.max_points override (0: the study's or the default)
    // Slurm pipeline and its parts (experiments/slurm.h)
    bool slurm = false;                  ///< write (and submit) the sbatch pipeline
    std::string slurmDir;                ///< "" = [slurm] dir or <store>.slurm
    std::vector<std::string> slurmSets;  ///< key=value over the study's [slurm] table
    bool referencesOnly = false;         ///< compute the references into the cache only
    std::string pointsFile;              ///< run only these point indices
    bool status = false;                 ///< report finished / failed / missing points
    std::string report;                  ///< --status also writes its report here
};

struct ReferenceCliOptions {
    std::string scene;
    std::string kind = "full-matrix";
    std::string cacheDir;
    bool progress = true;
};

struct SettingsCliOptions {
    std::string prefix;     ///< only keys starting with it ("" : all)
    bool markdown = false;  ///< docs/settings.md
    bool readme = false;    ///< the README's table of the main settings
};

/// `hrad settings [PREFIX]`: every key, default, type, range, reader, doc.
int runSettings(const SettingsCliOptions& options);
/// The names of a registry, comma-separated, for help texts: "solver",
/// "oracle", "cluster" (models), "builder", "format" (file extensions), "builtin".
std::string registryHelp(const std::string& family);
/// metrics.reference_level (hrad solve), read with its doc.
int readReferenceLevel(const Params& params);
/// The keys the app itself reads (for hrad settings).
void readAppSettings(const Params& params);

/// `hrad info SCENE`: counts, area, power, bounds, materials, load time.
int runInfo(const std::string& scene, Params& params);

/// `hrad solve SCENE ...`: solve and write image.exr, image.png, solution.ply,
/// summary.json into the output folder.
int runSolve(const SolveOptions& options, Params& params);

/// `hrad render SCENE SOLUTION`: renders a saved solution (solution.hrsol)
/// with the render.* settings (size, reconstruction, camera) into
/// image.exr and image.png in the output folder.
int runRender(const RenderCliOptions& options, Params& params);

/// `hrad sweep STUDY.toml`: validate, expand and run a study into a results
/// store (experiments/sweep.h); --dry-run prints the points only.
int runSweepCommand(const SweepCliOptions& options);

/// `hrad results export STORE --csv DIR`: one CSV per table.
int runResultsExport(const std::string& store, const std::string& csvDir);
/// `hrad results merge OUT IN... [--force]`: joins shard stores without
/// duplicates; refuses to mix study texts or hrad versions unless `force`.
int runResultsMerge(const std::string& out, const std::vector<std::string>& inputs, bool force);

/// `hrad reference SCENE --kind ...`: computes (or finds) a cached reference
/// and prints where it is. `params` holds fm.* / mc.* and loader keys.
int runReference(const ReferenceCliOptions& options, Params& params);

}  // namespace hrad::app
