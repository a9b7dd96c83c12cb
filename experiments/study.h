// Study files: a TOML description of a parameter sweep, and its expansion
// into points (DESIGN.md "Experiments"; schema in experiments/studies/README.md).
//
//   name        = "oracles"                 optional, default: file stem
//   description = "..."                     optional, free text
//   scenes      = ["cornell", "office:2", "../scenes/x.mgf"]
//                 built-in names, or files relative to the study file's folder
//   [solver]    base settings of every point: any key `hrad solve --set`
//               accepts ("solver", "hr.oracle", "oracle.eps", "ff.vis_rays",
//               "cluster.model", "mgf.resolution", "render.width", ...).
//               Nested tables flatten to dotted keys ([solver.oracle] eps = 1
//               is "oracle.eps").
//   [reference] kind = "full-matrix" | "montecarlo" | "none", plus the keys
//               of that reference ("fm.level", "fm.max_area", "mc.samples"...)
//   [outputs]   exr, ply, glb, solution, history_error, error_map (bools), dir (string,
//               default "runs", relative to the results store). error_map
//               needs a reference: it renders the reference with the same
//               camera and writes reference.png, error.png (16-bit data) and
//               error_fc.png (false colour) next to image.exr/png
//               (render/error_map.h); render.error_floor and
//               render.error_range set its floor and false-colour range,
//               render.error_mode = "regions" (default: the solution's
//               averages over the reference's regions against the reference,
//               the quantities the L1/L2 errors sum) or "pixels" (the two
//               reconstructed renders compared pixel by pixel);
//               render.error_reference = "path-traced" compares the
//               solution's render with a path-traced image of the same camera
//               (render.reference_spp paths per pixel, default 256) pixel by
//               pixel, and needs no reference solution.
//   [limits]    max_seconds (number), max_memory_mb (integer): per point,
//               overridden by --max-seconds / --max-memory; max_points
//               (integer, default 1,000,000; sweep.max_points, overridden by
//               --max-points): a study of more points is refused with the count
//   [slurm]     how `hrad sweep --slurm` writes its sbatch scripts: partition,
//               account, time, mem, cpus, tasks, max_parallel, sbatch (list
//               of extra #SBATCH lines), reference_time, reference_mem,
//               reference_cpus, merge_time, cache, dir, job_name
//               (experiments/slurm.h). Checked on load, used only by --slurm.
//   name must be a plain file name (it names runs/<name> and the store), and
//   [outputs] dir a relative folder inside the store's folder.
//   [sweep]     key = [v1, v2, ...]: every list is an axis of a Cartesian
//               product. Keys starting with "reference." vary the reference.
//   [[zip]]     a group of keys whose lists (equal lengths) vary together; the
//               groups are crossed with each other and with the [sweep] axes.
//
// Points are ordered scene-major, then axes in file order ([sweep] keys in
// the order written, then the [[zip]] groups), the last axis varying fastest.
// The order is deterministic, so `--shard i/N` selects the same points on
// every machine.
//
// Every value remembers its file:line (toml++ source regions), so the real
// components' fromParams + reportUnused report a misspelt or out-of-range
// setting at the line of the study that set it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "core/params.h"

namespace hrad::experiments {

/// Which artefacts and extra metrics each run produces.
struct OutputOptions {
    bool exr = false;           ///< image.exr + image.png of the solution
    bool ply = false;           ///< solution.ply
    bool glb = false;           ///< solution.glb (render/gltf_export.h; interpolated with render.interpolate)
    bool lightmap = false;      ///< lightmap.exr/png/glb (render/lightmap.h; hrad solve --lightmap)
    bool solution = false;      ///< solution.hrsol (reference/cache.h saveSolution; hrad render)
    bool historyError = false;  ///< L2 error after every iteration (hr solver with a reference)
    bool errorMap = false;      ///< per-pixel error map against the reference (implies exr)
    bool regions =
        false;  ///< regions.csv: solution and reference per region (reference::writeRegionsCsv)
    SourceLocation regionsWhere;   ///< where regions was set (for "needs a reference")
    SourceLocation errorMapWhere;  ///< where error_map was set (for "needs a reference")
    std::string dir = "runs";   ///< artefact folder, relative to the results store
};

/// One point of a study: everything a run needs.
struct PointSpec {
    size_t index = 0;         ///< position in the expanded study (0-based)
    std::string scene;        ///< what scene::loadScene receives (resolved path or built-in name)
    std::string sceneLabel;   ///< as written in the study (stable across machines)
    Params settings;          ///< solver, loader and render settings
    Params reference;         ///< "kind" and the reference's own keys (fm.*, mc.*)
    OutputOptions outputs;
    /// Keys varied by the sweep and their values at this point ("hr.oracle=ff").
    std::vector<std::pair<std::string, std::string>> varying;
};

struct Limits {
    double maxSeconds = 0.0;  ///< 0: none
    uint64_t maxMemoryBytes = 0;
    /// sweep.max_points: a study that expands to more points is refused with
    /// the count before anything is expanded ([limits] max_points in the
    /// study, or hrad sweep --max-points).
    uint64_t maxPoints = 1'000'000;
    SourceLocation maxPointsWhere;  ///< where max_points was set ("" = default)
};

struct StudyExpansion;  // scenes x axes, expanded one point at a time (study.cpp)

struct Study {
    std::string name;
    std::string description;
    std::filesystem::path path;  ///< the study file ("" for a study parsed from text)
    std::string text;            ///< the study file's contents (stored with the results)
    Limits limits;
    /// The [slurm] table (partition, time, mem, cpus, ...; experiments/slurm.h
    /// SlurmSettings), each value with its file:line. Unused by local sweeps.
    Params slurm;
    SourceLocation where;        ///< the study file (line of its `scenes` list)

    /// Number of points (scenes x the product of the axis lengths), saturated
    /// at UINT64_MAX instead of wrapping (64 axes of 2 values is 2^64).
    uint64_t pointCount() const;
    /// The point at `index` (< pointCount()), built on demand: a study is never
    /// expanded into memory as a whole.
    PointSpec point(uint64_t index) const;
    /// All points, for studies within limits.maxPoints (checkPointCount first).
    std::vector<PointSpec> points() const;
    /// "3 scene(s) x 10 x 4" (the factors of pointCount()).
    std::string countDescription() const;

    std::shared_ptr<const StudyExpansion> expansion;
};

/// Throws InputError (at the study file) when the study expands to more than
/// limits.maxPoints points, naming the count and the setting.
void checkPointCount(const Study& study);

/// Parses and expands a study. Throws InputError with file:line for syntax
/// errors, unknown top-level keys, bad types, zip groups of unequal lengths,
/// keys set twice, missing scene files. Does not validate setting names or
/// ranges: see validateStudy().
Study loadStudy(const std::filesystem::path& path);
/// Same from text; relative scene paths resolve against `baseDir`, locations
/// name `displayName`.
Study parseStudy(const std::string& text, const std::string& displayName,
                 const std::filesystem::path& baseDir);

/// Dry validation of every point without solving: checks the point count
/// (checkPointCount), then builds each component's settings from the point's
/// Params exactly as a run does and reports unused keys
/// (experiments::validatePoint). Throws the first InputError, prefixed with
/// the point index.
void validateStudy(const Study& study);
/// Same for one point (the prefix names the point and the study).
void validateStudyPoint(const Study& study, const PointSpec& point);

/// Stable key of a point: a hash of its scene (label and, for files, the file
/// contents) and its resolved settings and reference settings. Finished
/// points with the same key are skipped on resume.
std::string pointKey(const PointSpec& point);

/// Params as a JSON object text {"key": value, ...} (sorted keys).
std::string paramsToJsonText(const Params& params);

/// One line per point for --dry-run.
std::string describePoint(const PointSpec& point);
/// The header and one line per point (small studies and tests; --dry-run
/// streams with describePoint instead).
std::string describePoints(const Study& study);

}  // namespace hrad::experiments
