// Full-matrix reference solver; see fullmatrix.h for the settings and the math.
#include "reference/fullmatrix.h"

#include "core/rng.h"
#include "transport/light_irradiance.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/log.h"
#include "core/timer.h"
#include "scene/element.h"

namespace hrad::reference {

namespace {

double l1(const RGB& c) { return std::fabs(c.r) + std::fabs(c.g) + std::fabs(c.b); }

/// Serial sum of per-element terms: parallel reductions in floating point are
/// not deterministic, these sums are cheap.
double serialSum(const std::vector<double>& v) {
    double s = 0.0;
    for (double x : v) s += x;
    return s;
}

double ratio(double num, double den) {
    if (den > 0) return num / den;
    return num > 0 ? std::numeric_limits<double>::infinity() : 0.0;
}

/// Per-element inputs of the linear system.
struct System {
    std::vector<RGB> E, rho;
    std::vector<double> A;
};

System makeSystem(const scene::Scene& scene, const FormFactorMatrix& m) {
    System s;
    size_t n = m.size();
    s.E.resize(n);
    s.rho.resize(n);
    s.A = m.areas;
    for (size_t i = 0; i < n; ++i) {
        const scene::Patch& p = scene.patches[m.patchOf[i]];
        s.E[i] = p.emission + (m.lightE.empty() ? RGB(0.0) : m.lightE[i]);
        s.rho[i] = p.rho;
    }
    return s;
}

/// (F B)_i for one row.
inline RGB rowTimes(const FormFactorMatrix& m, size_t i, const std::vector<RGB>& B) {
    RGB acc(0.0);
    for (uint64_t k = m.rowStart[i]; k < m.rowStart[i + 1]; ++k) acc += m.values[k] * B[m.cols[k]];
    return acc;
}

/// Relative residual of B, and optionally the Jacobi update E + rho F B.
double residualAndUpdate(const System& sys, const FormFactorMatrix& m, const std::vector<RGB>& B,
                         std::vector<RGB>* next) {
    size_t n = m.size();
    std::vector<double> num(n), den(n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 64),
                      [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t i = r.begin(); i != r.end(); ++i) {
                              RGB b = sys.E[i] + sys.rho[i] * rowTimes(m, i, B);
                              num[i] = sys.A[i] * l1(b - B[i]);
                              den[i] = sys.A[i] * l1(B[i]);
                              if (next) (*next)[i] = b;
                          }
                      });
    return ratio(serialSum(num), serialSum(den));
}

/// Transpose of the CSR matrix (columns of F as rows), for Southwell shooting.
struct Transpose {
    std::vector<uint64_t> start;
    std::vector<uint32_t> rows;
    std::vector<double> values;
};

Transpose transpose(const FormFactorMatrix& m) {
    size_t n = m.size();
    Transpose t;
    t.start.assign(n + 1, 0);
    for (uint32_t c : m.cols) ++t.start[c + 1];
    for (size_t j = 0; j < n; ++j) t.start[j + 1] += t.start[j];
    t.rows.resize(m.cols.size());
    t.values.resize(m.values.size());
    std::vector<uint64_t> fill(t.start.begin(), t.start.end() - 1);
    // Rows in increasing order, so each column lists receivers in order.
    for (size_t i = 0; i < n; ++i)
        for (uint64_t k = m.rowStart[i]; k < m.rowStart[i + 1]; ++k) {
            uint64_t pos = fill[m.cols[k]]++;
            t.rows[pos] = uint32_t(i);
            t.values[pos] = m.values[k];
        }
    return t;
}

}  // namespace

std::string solverName(MatrixSolver s) {
    switch (s) {
        case MatrixSolver::Jacobi:
            return "jacobi";
        case MatrixSolver::GaussSeidel:
            return "gauss-seidel";
        case MatrixSolver::Southwell:
            return "southwell";
    }
    return "?";
}

FullMatrixSettings FullMatrixSettings::fromParams(const Params& params, const std::string& prefix) {
    Params::Scope scope(params, "full-matrix reference");
    FullMatrixSettings s;
    auto key = [&](const char* k) { return prefix.empty() ? std::string(k) : prefix + "." + k; };
    s.level = int(
        params.getInt({key("level"), "full matrix: uniform subdivision level of every root patch"},
                      s.level, 0, scene::kMaxLevel));
    s.maxArea = params.getDouble(
        {key("max_area"), "full matrix: subdivide elements above this area (0: by level only)"},
        s.maxArea, 0.0, 1e300);
    s.maxLevel = int(
        params.getInt({key("max_level"), "full matrix: subdivision level at most with max_area"},
                      s.maxLevel, 0, scene::kMaxLevel));
    std::string solver = params.getEnum(
        {key("solver"), "full-matrix linear solver: jacobi, gauss-seidel or southwell"},
        "gauss-seidel", {"jacobi", "gauss-seidel", "southwell"});
    s.solver = solver == "jacobi"      ? MatrixSolver::Jacobi
               : solver == "southwell" ? MatrixSolver::Southwell
                                       : MatrixSolver::GaussSeidel;
    s.tolerance =
        params.getDouble({key("tolerance"), "full matrix: residual tolerance of the linear solve"},
                         s.tolerance, 0.0, 1.0, true);
    s.maxIterations = int(params.getInt(
        {key("max_iterations"), "full matrix: iterations of the linear solve at most"},
        s.maxIterations, 1, 1000000000));
    s.ambient = params.getBool(
        {key("ambient"), "full matrix: ambient term for light not yet shot (southwell)"},
        s.ambient);
    s.ff = transport::FormFactorSettings::fromParams(params, key("ff"), fullMatrixFormFactorDefaults());
    s.hemicube = transport::HemicubeSettings::fromParams(params, key("ff"));
    return s;
}

std::string FullMatrixSettings::describe() const {
    return fmt::format(
        "level={} max_area={} max_level={} solver={} tolerance={} max_iterations={} ambient={} "
        "ff={{{}{}}}",
        level, maxArea, maxLevel, solverName(solver), tolerance, maxIterations, ambient,
        ff.describe(), hemicube.describe());
}

uint64_t FormFactorMatrix::bytes() const {
    return rowStart.size() * sizeof(uint64_t) + cols.size() * sizeof(uint32_t) +
           values.size() * sizeof(double);
}

double FormFactorMatrix::rowSum(size_t i) const {
    double s = 0.0;
    for (uint64_t k = rowStart[i]; k < rowStart[i + 1]; ++k) s += values[k];
    return s;
}

/// FormFactorMatrix::lightE: the lights' direct irradiance per element times rho.
static void computeLightE(const scene::Scene& scene, const transport::Visibility& visibility,
                   const scene::UniformField& layout, const std::vector<transport::ElementRef>& refs,
                   FormFactorMatrix& m) {
    if (scene.lights.empty()) return;
    const size_t n = layout.numElements();
    m.lightE.assign(n, RGB(0.0));
    std::vector<uint64_t> rays(n, 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16), [&](const auto& r) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
            const uint32_t p = refs[i].patch;
            const RGB E = transport::elementLightsIrradiance(
                scene, visibility, p, refs[i].dom, FormFactorMatrix::kLightPoints,
                FormFactorMatrix::kLightStrata, hashIds(0x6c69676874ULL, i), rays[i]);
            m.lightE[i] = scene.patches[p].rho * E;
        }
    });
    for (uint64_t x : rays) m.rays += x;
}

FormFactorMatrix computeFormFactorMatrix(const scene::Scene& scene,
                                         const transport::Visibility& visibility,
                                         const FullMatrixSettings& settings, bool showProgress,
                                         const StopPoll& stop) {
    Timer timer;
    FormFactorMatrix m;
    m.levels = scene::uniformLevels(scene, settings.level, settings.maxArea, settings.maxLevel);
    scene::UniformField layout(scene, m.levels);
    size_t n = layout.numElements();
    HRAD_CHECK_MSG(n < size_t(UINT32_MAX), "{} elements exceed 32-bit indices", n);

    // Element i <-> ElementRef with the flat index as its stable id (seeds the
    // engine's visibility samples).
    std::vector<transport::ElementRef> refs(n);
    m.patchOf.resize(n);
    m.areas.resize(n);
    for (uint32_t p = 0; p < scene.patches.size(); ++p) {
        const scene::Patch& patch = scene.patches[p];
        for (size_t l = 0; l < layout.count(p); ++l) {
            size_t i = layout.offset(p) + l;
            refs[i] = transport::ElementRef{p, scene::keyDomain(patch.kind, layout.key(p, l)), i};
            m.patchOf[i] = p;
            m.areas[i] = layout.area(i);
        }
    }

    transport::FormFactorEngine engine(scene, &visibility, settings.ff);
    std::vector<std::vector<uint32_t>> rowCols(n);
    std::vector<std::vector<double>> rowVals(n);
    std::vector<uint64_t> rowRays(n, 0);
    ProgressBar bar(fmt::format("form factors ({} el.)", n), n, showProgress);
    // A signal leaves the remaining rows empty; the matrix is then marked.
    std::atomic<bool> stopped{false};
    auto stopRow = [&] {
        if (stopped.load(std::memory_order_relaxed)) return true;
        if (!stop()) return false;
        stopped = true;
        return true;
    };
    if (settings.hemicube.enabled) {
        // Hemicube rows (Cohen & Greenberg 1985): F_ij = sum_p w_p F_{dA(p) -> j}
        // over the hemicubes' sample points p of element i.
        const transport::Hemicube cube(settings.hemicube.res);
        tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1), [&](const tbb::blocked_range<size_t>& r) {
            std::vector<double> row(n, 0.0);
            std::vector<uint32_t> touched;
            std::vector<Vec3> pts;
            std::vector<double> w;
            for (size_t i = r.begin(); i != r.end(); ++i) {
                if (stopRow()) break;
                const transport::ElementRef& ri = refs[i];
                const scene::Patch& patch = scene.patches[ri.patch];
                transport::hemicubePoints(patch, ri.dom, settings.hemicube.points, pts, w);
                for (size_t k = 0; k < pts.size(); ++k)
                    rowRays[i] += cube.project(
                        visibility, scene, pts[k], patch.normal, ri.patch,
                        [&](uint32_t q, const Vec3& x, double dF) {
                            const scene::Patch& pq = scene.patches[q];
                            Vec2 uv = glm::clamp(scene::patchInverse(pq, x), Vec2(0.0), Vec2(1.0));
                            if (pq.kind == scene::PatchKind::Triangle && uv.x + uv.y > 1)
                                uv /= uv.x + uv.y;
                            scene::ElementKey key = scene::keyAt(pq.kind, uv.x, uv.y, m.levels[q]);
                            size_t j = layout.offset(q) + size_t(key - (scene::ElementKey(1) << (2 * m.levels[q])));
                            if (row[j] == 0) touched.push_back(uint32_t(j));
                            row[j] += w[k] * dF;
                        });
                std::sort(touched.begin(), touched.end());
                for (uint32_t j : touched) {
                    rowCols[i].push_back(j);
                    rowVals[i].push_back(row[j]);
                    row[j] = 0;
                }
                touched.clear();
                bar.add(1);
            }
        });
    } else {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1),
                      [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t i = r.begin(); i != r.end(); ++i) {
                              if (stopRow()) break;
                              const transport::ElementRef& ri = refs[i];
                              for (size_t j = 0; j < n; ++j) {
                                  // Root patches are planar: elements of the same patch (and
                                  // the element itself) exchange nothing.
                                  if (m.patchOf[j] == ri.patch) continue;
                                  if (!engine.facing(ri, refs[j])) continue;
                                  transport::FormFactorResult f = engine.compute(ri, refs[j]);
                                  rowRays[i] += f.rays;
                                  if (f.F > 0) {
                                      rowCols[i].push_back(uint32_t(j));
                                      rowVals[i].push_back(f.F);
                                  }
                              }
                              bar.add(1);
                          }
                      });
    }
    bar.done();
    m.interrupted = stopped;
    if (m.interrupted)
        spdlog::warn("signal {} received: the form-factor matrix stops with rows missing; it is not "
                     "solved (B = E), and the result is marked interrupted", interruptSignal());

    // Pack into CSR, freeing each row as it is copied.
    m.rowStart.assign(n + 1, 0);
    for (size_t i = 0; i < n; ++i) m.rowStart[i + 1] = m.rowStart[i] + rowCols[i].size();
    m.cols.resize(m.rowStart[n]);
    m.values.resize(m.rowStart[n]);
    for (size_t i = 0; i < n; ++i) {
        std::copy(rowCols[i].begin(), rowCols[i].end(), m.cols.begin() + int64_t(m.rowStart[i]));
        std::copy(rowVals[i].begin(), rowVals[i].end(), m.values.begin() + int64_t(m.rowStart[i]));
        std::vector<uint32_t>().swap(rowCols[i]);
        std::vector<double>().swap(rowVals[i]);
        m.rays += rowRays[i];
    }
    computeLightE(scene, visibility, layout, refs, m);
    m.seconds = timer.seconds();
    return m;
}

double relativeResidual(const scene::Scene& scene, const FormFactorMatrix& matrix,
                        const std::vector<RGB>& B) {
    HRAD_CHECK(B.size() == matrix.size());
    return residualAndUpdate(makeSystem(scene, matrix), matrix, B, nullptr);
}

FullMatrixResult solveFormFactorMatrix(const scene::Scene& scene, const FormFactorMatrix& m,
                                       const FullMatrixSettings& settings, const StopPoll& stop) {
    Timer timer;
    const size_t n = m.size();
    const System sys = makeSystem(scene, m);
    FullMatrixResult result;
    result.field = std::make_unique<scene::UniformField>(scene, m.levels);
    HRAD_CHECK(result.field->numElements() == n);
    FullMatrixStats& st = result.stats;
    st.elements = n;
    st.formFactors = m.nonZeros();
    st.rays = m.rays;
    st.ffSeconds = m.seconds;
    st.matrixBytes = m.bytes();

    std::vector<RGB> B = sys.E;  // every method starts from B = E
    const double tol = settings.tolerance;
    // A signal: the iterate so far is the result, marked interrupted.
    auto stopped = [&] {
        if (!stop()) return false;
        if (!st.interrupted)
            spdlog::warn("signal {} received after {} iterations: the full-matrix iterate so far is the "
                         "result, marked interrupted", interruptSignal(), st.iterations);
        st.interrupted = true;
        return true;
    };
    if (m.interrupted) {
        st.interrupted = true;
        st.residual = std::nan("");
        result.field->values() = std::move(B);
        st.solveSeconds = timer.seconds();
        return result;
    }

    if (settings.solver == MatrixSolver::Jacobi) {
        // B' = E + rho F B; the residual of B is B' - B, so each sweep yields
        // the residual of the current iterate for free.
        std::vector<RGB> next(n);
        for (;;) {
            double res = residualAndUpdate(sys, m, B, &next);
            st.residualHistory.push_back(res);
            st.residual = res;
            if (res <= tol) {
                st.converged = true;
                break;
            }
            if (st.iterations >= settings.maxIterations || stopped()) break;
            B.swap(next);
            ++st.iterations;
        }
    } else if (settings.solver == MatrixSolver::GaussSeidel) {
        // In-place sweeps in element order (Cohen & Wallace 1993 §5.3.2); the
        // residual of each iterate costs one extra (parallel) product.
        for (;;) {
            double res = residualAndUpdate(sys, m, B, nullptr);
            st.residualHistory.push_back(res);
            st.residual = res;
            if (res <= tol) {
                st.converged = true;
                break;
            }
            if (st.iterations >= settings.maxIterations || stopped()) break;
            for (size_t i = 0; i < n; ++i) B[i] = sys.E[i] + sys.rho[i] * rowTimes(m, i, B);
            ++st.iterations;
        }
    } else {
        // Southwell / progressive refinement (Cohen et al. 1988; Cohen &
        // Wallace 1993 §5.3.3). U is the unshot radiosity; the invariant
        //   B = E + rho F (B - U)
        // holds throughout (initially B = U = E), so the residual of B is
        //   r = E + rho F B - B = rho F U.
        // A shot from j adds rho_i F_ij U_j to B_i and U_i for every i (a
        // column of F, hence the transpose) and sets U_j = 0. The shooter is
        // the element with the largest unshot power A_j |U_j|_1.
        Transpose t = transpose(m);
        st.matrixBytes += t.start.size() * sizeof(uint64_t) + t.rows.size() * sizeof(uint32_t) +
                          t.values.size() * sizeof(double);
        std::vector<RGB> U = sys.E;
        const int64_t maxShots = int64_t(settings.maxIterations) * int64_t(std::max<size_t>(n, 1));
        std::vector<double> num(n), den(n);
        auto residual = [&]() {
            tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 64),
                              [&](const tbb::blocked_range<size_t>& r) {
                                  for (size_t i = r.begin(); i != r.end(); ++i) {
                                      num[i] = sys.A[i] * l1(sys.rho[i] * rowTimes(m, i, U));
                                      den[i] = sys.A[i] * l1(B[i]);
                                  }
                              });
            return ratio(serialSum(num), serialSum(den));
        };
        for (;;) {
            double res = residual();
            st.residualHistory.push_back(res);
            st.residual = res;
            if (res <= tol) {
                st.converged = true;
                break;
            }
            if (st.iterations >= maxShots || st.interrupted) break;
            // n shots between residual checks: one check costs about as much
            // as n shots.
            for (size_t s = 0; s < n && st.iterations < maxShots && !stopped(); ++s) {
                size_t j = 0;
                double best = -1.0;
                for (size_t i = 0; i < n; ++i) {
                    double p = sys.A[i] * l1(U[i]);
                    if (p > best) {
                        best = p;
                        j = i;
                    }
                }
                if (!(best > 0)) break;
                RGB u = U[j];
                U[j] = RGB(0.0);
                for (uint64_t k = t.start[j]; k < t.start[j + 1]; ++k) {
                    uint32_t i = t.rows[k];
                    RGB d = sys.rho[i] * (t.values[k] * u);
                    B[i] += d;
                    U[i] += d;
                }
                ++st.iterations;
            }
        }
        if (settings.ambient) {
            // Ambient term (Cohen et al. 1988): the unshot power spread over
            // the scene's area and reflected with the average reflectance,
            // A_amb = 1/(1 - rho_avg) * sum_j U_j A_j / sum_j A_j, displayed
            // as B_i + rho_i A_amb.
            double area = 0.0;
            RGB rhoAvg(0.0), unshot(0.0);
            for (size_t i = 0; i < n; ++i) {
                area += sys.A[i];
                rhoAvg += sys.rho[i] * sys.A[i];
                unshot += U[i] * sys.A[i];
            }
            if (area > 0) {
                rhoAvg /= area;
                RGB ambient = unshot / area / (RGB(1.0) - rhoAvg);
                for (size_t i = 0; i < n; ++i) B[i] += sys.rho[i] * ambient;
            }
        }
    }
    result.field->values() = std::move(B);
    st.solveSeconds = timer.seconds();
    if (!st.converged && !st.interrupted)
        spdlog::warn("full matrix ({}): residual {:.3g} > tolerance {:.3g} after {} iterations",
                     solverName(settings.solver), st.residual, tol, st.iterations);
    return result;
}

FullMatrixResult solveFullMatrix(const scene::Scene& scene, const transport::Visibility& visibility,
                                 const FullMatrixSettings& settings, bool showProgress,
                                 const StopPoll& stop) {
    FormFactorMatrix m = computeFormFactorMatrix(scene, visibility, settings, showProgress, stop);
    return solveFormFactorMatrix(scene, m, settings, stop);
}

}  // namespace hrad::reference
