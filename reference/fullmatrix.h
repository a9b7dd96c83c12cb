// Full-matrix reference radiosity (DESIGN.md "Reference solves and error").
//
// Every root patch is subdivided uniformly (scene::uniformLevels, a fixed
// level or an element-area bound) and all n^2 element-to-element form factors
// F_ij are computed with transport::FormFactorEngine (quadrature and
// visibility). The classical radiosity system (Cohen & Wallace 1993, eq. 5.1)
//
//     B_i = E_i + rho_i sum_j F_ij B_j        (per RGB channel)
//
// is then solved by Jacobi (§5.3.1), Gauss-Seidel (§5.3.2, in place, rows in
// element order) or Southwell / progressive refinement (§5.3.3, Cohen, Chen,
// Wallace & Greenberg 1988: shoot the unshot radiosity of the element with
// the largest unshot power). All three converge to the same solution. The
// iteration stops at a relative residual of the unbalanced power,
//     res(B) = sum_i A_i |r_i|_1 / sum_i A_i |B_i|_1,  r = E + rho (F B) - B.
// The form factors use the adaptive rule by default (ff.adaptive_depth 3,
// fullMatrixFormFactorDefaults): the mesh is fixed, so near pairs need an
// accurate rule (papers/notes/2026-12-02-header-notes.md).
//
// Storage: sparse rows (CSR), double values and 32-bit column indices, 12
// bytes per non-zero plus 8 per row; pairs that cannot exchange energy and
// the diagonal (planar elements, F_ii = 0) are not stored. Southwell builds
// the transpose (reciprocity holds only up to quadrature error, so using it
// instead would solve a slightly different system). Cost grows as n^2 in
// time and memory (measured limits: the notes page above). solveFullMatrix()
// does not cache; reference/cache.h's cachedFullMatrix() does, keyed by a
// hash of the scene and the settings.
//
// A stop request (core/stop.h) is polled per row and per sweep or shot: an
// interrupted matrix is not solved (B = E), an interrupted solve keeps its
// iterate; both set `interrupted`.
//
// Settings: the keys below a prefix, "fm" by default (`hrad settings fm.`;
// a study's reference: `hrad settings reference.fm.`).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/params.h"
#include "core/stop.h"
#include "scene/field.h"
#include "scene/scene.h"
#include "transport/formfactor.h"
#include "transport/hemicube.h"
#include "transport/visibility.h"

namespace hrad::reference {

enum class MatrixSolver { Jacobi, GaussSeidel, Southwell };

std::string solverName(MatrixSolver s);

/// The full matrix's form-factor defaults: the engine's, with adaptive_depth 3.
inline transport::FormFactorSettings fullMatrixFormFactorDefaults() {
    transport::FormFactorSettings f;
    f.adaptiveDepth = 3;
    return f;
}

struct FullMatrixSettings {
    int level = 3;
    double maxArea = 0.0;
    int maxLevel = 12;
    MatrixSolver solver = MatrixSolver::GaussSeidel;
    double tolerance = 1e-7;
    int maxIterations = 10000;
    bool ambient = false;
    transport::FormFactorSettings ff = fullMatrixFormFactorDefaults();
    /// ff.method = hemicube (transport/hemicube.h): rows of F from hemicubes
    /// at the receiver instead of the quadrature engine; ff.rule etc. unused.
    transport::HemicubeSettings hemicube;

    /// Reads the keys listed above below `prefix` ("fm.level", ..., "fm.ff.points").
    static FullMatrixSettings fromParams(const Params& params, const std::string& prefix = "fm");
    /// One line, "level=3 solver=gauss-seidel tolerance=1e-07 ... ff={...}".
    std::string describe() const;
};

/// Sparse form-factor matrix on a uniform subdivision. Element i is the
/// UniformField element with flat index i (UniformField::offset(patch) + local).
struct FormFactorMatrix {
    std::vector<uint8_t> levels;     ///< subdivision level per patch
    std::vector<uint32_t> patchOf;   ///< patch of element i
    std::vector<double> areas;       ///< A_i
    std::vector<uint64_t> rowStart;  ///< n+1 offsets into cols/values
    std::vector<uint32_t> cols;      ///< sender j of each non-zero F_ij
    std::vector<double> values;      ///< F_ij
    /// rho_i times element i's mean irradiance from the non-area lights
    /// (scene/lights/light.h), part of E_direct: B = E + lightE + rho F B.
    /// Midpoint rule of kLightPoints^2 points (transport::elementMeanPoints),
    /// environments by kLightStrata^2 stratified cosine directions per point
    /// (transport/light_irradiance.h). Empty without lights.
    std::vector<RGB> lightE;
    static constexpr int kLightPoints = 4, kLightStrata = 16;
    uint64_t rays = 0;               ///< occlusion rays cast
    double seconds = 0.0;            ///< wall time of the form-factor pass
    bool interrupted = false;        ///< stopped by a signal: some rows are missing

    size_t size() const { return areas.size(); }
    uint64_t nonZeros() const { return values.size(); }
    uint64_t bytes() const;
    /// sum_j F_ij (1 for an interior element of a closed scene, up to quadrature error).
    double rowSum(size_t i) const;
};

struct FullMatrixStats {
    size_t elements = 0;
    uint64_t formFactors = 0;  ///< stored non-zeros
    uint64_t rays = 0;
    double ffSeconds = 0.0;
    double solveSeconds = 0.0;
    /// Sweeps (Jacobi, Gauss-Seidel) or shots (Southwell).
    int64_t iterations = 0;
    double residual = 0.0;  ///< final relative residual (see "tolerance")
    bool converged = false;
    bool interrupted = false;  ///< stopped by a signal (core/stop.h)
    uint64_t matrixBytes = 0;  ///< CSR bytes (plus the transpose for Southwell)
    /// Relative residual after each sweep (Southwell: after every n shots).
    std::vector<double> residualHistory;
};

struct FullMatrixResult {
    std::unique_ptr<scene::UniformField> field;
    FullMatrixStats stats;
};

/// Computes all element-to-element form factors (parallel over receiver rows;
/// every row is written by one task and the engine is deterministic, so the
/// matrix does not depend on thread scheduling).
FormFactorMatrix computeFormFactorMatrix(const scene::Scene& scene,
                                         const transport::Visibility& visibility,
                                         const FullMatrixSettings& settings,
                                         bool showProgress = true, const StopPoll& stop = {});

/// Solves B = E + rho F B on a precomputed matrix with settings.solver. Only
/// the solver settings (solver, tolerance, max_iterations, ambient) are read.
/// Non-convergence within max_iterations is not an error: stats.converged says.
FullMatrixResult solveFormFactorMatrix(const scene::Scene& scene, const FormFactorMatrix& matrix,
                                       const FullMatrixSettings& settings, const StopPoll& stop = {});

/// computeFormFactorMatrix + solveFormFactorMatrix.
FullMatrixResult solveFullMatrix(const scene::Scene& scene, const transport::Visibility& visibility,
                                 const FullMatrixSettings& settings, bool showProgress = true,
                                 const StopPoll& stop = {});

/// Relative residual (see "tolerance") of an arbitrary field on the matrix's
/// elements: useful to check any solution against the full-matrix system.
double relativeResidual(const scene::Scene& scene, const FormFactorMatrix& matrix,
                        const std::vector<RGB>& B);

}  // namespace hrad::reference
