// The solver registry: one explicit table from the `solver` setting's value to
// a factory taking `const Params&` (like oracles/registry.h; Tungsten's
// IntegratorFactory, pbrt-v4's Integrator::Create; no static
// self-registration, which a linker may drop from a static library).
//
// It lives in experiments/ because it is the one folder that may reach both
// hr/ and reference/ (DESIGN.md, "Layout and dependency rules"). Both callers
// of a solve, the sweep runner (experiments/runner.cpp) and `hrad solve`
// (apps/cmd_solve.cpp, through runPoint), go through it.
//
// Registered solvers (each one's settings, defaults and paper are in the
// header named here; `solver` itself is a string setting, default "hr"):
//
//   hr           hierarchical radiosity with optional volume clustering
//                (Hanrahan, Salzman & Aupperle 1991; Smits, Arvo & Greenberg
//                1994; Sillion 1995). hr/solver.h; keys hr.*, oracle.*,
//                cluster.*, ff.*, memory.*. History: one record per
//                gather iteration.
//   full-matrix  uniform mesh, all n^2 form factors, Jacobi / Gauss-Seidel /
//                Southwell (Cohen & Wallace 1993, ch. 5).
//                reference/fullmatrix.h; keys fm.*. No history.
//   progressive  progressive refinement with adaptive substructuring and
//                the ambient term (Cohen, Chen, Wallace & Greenberg 1988).
//                reference/progressive.h; keys pr.*. History: one record
//                every pr.history_every shots.
//
// A new method is one entry in the table of solvers.cpp: a factory that reads
// and validates its settings (so a dry run of a study checks them), and a
// solve that returns a RadiosityField with its counts, history, timings and
// memory (SolveOutput below).
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/cancel.h"
#include "core/memory.h"
#include "core/params.h"
#include "scene/field.h"
#include "scene/scene.h"
#include "transport/visibility.h"

namespace hrad::experiments {

/// What a caller passes to a solve.
struct SolveContext {
    bool progress = false;
    /// If set, the solver calls it at every history record with the current
    /// solution and stores the returned relative L2 error (luminance) in the
    /// record's l2_lum. Only solvers with SolverInfo::keepsHistory call it.
    std::function<double(const scene::RadiosityField&)> historyError;
    /// A caller's stop request (core/cancel.h). The hr solver polls it
    /// (hr/budget.h) and throws hrad::Cancelled; full-matrix and progressive
    /// do not poll it yet and finish their solve.
    const CancelToken* cancel = nullptr;
    /// If set, called with every history record as it is made (the fields
    /// of summary.history[i], l2_lum included with historyError): progress
    /// for a caller that shows it (the Python module's on_iteration).
    std::function<void(const nlohmann::json&)> onRecord;
    /// If set, the hr solver calls it when an eps stage has converged, with
    /// the solution and the stage's eps; a smaller eps it returns is refined
    /// to next on the same hierarchy (hr/stage_controller.h; a target-error
    /// solve, experiments/target_error.h). Other solvers do not call it.
    std::function<std::optional<double>(const scene::RadiosityField&, double)> afterStage;
    /// If set, the render camera (render.eye/target, or the scene's, or the
    /// automatic one) and the image size: hr.importance = camera reads them.
    std::function<scene::Camera()> camera;
    int imageWidth = 0, imageHeight = 0;
};

/// What both callers need from a solve.
struct SolveOutput {
    /// The solution. It may refer to solver state (HR's hierarchy) that
    /// `owner` keeps alive.
    const scene::RadiosityField* field = nullptr;
    std::shared_ptr<const void> owner;
    /// Summary entries of the run: at least counts (elements, leaves,
    /// form_factors, rays, iterations), residual, converged; history when the
    /// solver keeps one; solver-specific entries beside them (HR: oracle,
    /// cluster_model, link_cap_hit, ...). Merged into the run's summary.
    nlohmann::json summary = nlohmann::json::object();
    /// Phase timings in seconds (merged into summary.timings).
    nlohmann::json timings = nlohmann::json::object();
    /// Bytes by category (merged into summary.memory).
    MemoryCounters memory;
};

/// A configured solver: its settings are read and validated by the factory.
class Solver {
public:
    virtual ~Solver() = default;
    // The settings written next to every result are the Params records of
    // every key read (summary.resolved_settings), not a describe() line.
    virtual SolveOutput solve(const scene::Scene& scene, const transport::Visibility& visibility,
                              const SolveContext& ctx) const = 0;
};

/// What a caller may ask about a registered solver without creating it.
struct SolverInfo {
    std::string name;
    std::string description;               ///< one line: method and paper
    std::vector<std::string> keyPrefixes;  ///< setting keys it reads ("fm." ...)
    bool keepsHistory = false;             ///< calls SolveContext::historyError
    std::string historyNote;               ///< what summary.history holds

    bool readsKey(const std::string& key) const;
};

/// Creates the named solver from its settings. An unknown name is an
/// InputError at `where` listing the registered names. Reads only the keys
/// of that solver; the caller calls params.reportUnused().
std::unique_ptr<Solver> createSolver(const std::string& name, const Params& params,
                                     const SourceLocation& where = {});

/// The registered solver of that name, or nullptr.
const SolverInfo* findSolver(const std::string& name);
/// The registered solver of that name; unknown: InputError at `where`.
const SolverInfo& solverInfo(const std::string& name, const SourceLocation& where = {});
std::vector<std::string> solverNames();

}  // namespace hrad::experiments
