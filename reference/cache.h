// On-disk cache of reference solutions (DESIGN.md "Reference solves and
// error": "Cached on disk, keyed by a hash of the scene contents and the
// settings").
//
// Key. sceneContentHash() is a 64-bit FNV-1a hash of the *loaded* geometry:
// the patch count and, per patch, its kind, its vertices, reflectance and
// emission (the IEEE bit patterns of the doubles, so any change to a
// coordinate or material, however small, changes it; 0.0 and -0.0 differ).
// It does not read the file name, camera or material names: a renamed but
// identical scene hits, an edited scene file misses. referenceCacheKey()
// combines it with the solver kind (which carries an algorithm version,
// bumped when a solver's output changes) and the settings' describe() line
// into 32 hex digits: 16 of the scene hash, then 16 of FNV-1a over
// kind + '\n' + settings.
//
// File format (version 1, host byte order, little-endian on every machine
// hrad runs on):
//   char[8]   magic "HRADREF\0"
//   u32       version (1)
//   u32 len + bytes   key
//   u32 len + bytes   metadata (free text, "name=value" lines; for humans and
//                     the helpers below)
//   u64       patch count P, then u8 levels[P] (UniformField levels)
//   u64       element count N (must equal sum_p 4^levels[p])
//   u8        1 when standard errors follow, else 0
//   f64[3N]   values (RGB per element, UniformField flat order)
//   f64[3N]   standard errors (only when flagged)
//   u64       FNV-1a of every byte above
// A missing file or a different key is a silent miss. A file that cannot be
// parsed (bad magic or version, truncated, trailing bytes, sizes that do not
// match the scene, checksum mismatch) is a miss with a warning, never a crash.
// saveReference writes to a temporary file in the same directory and renames
// it, so concurrent readers never see a half-written file.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/types.h"
#include "reference/fullmatrix.h"
#include "reference/montecarlo.h"
#include "scene/field.h"
#include "scene/scene.h"
#include "transport/visibility.h"

namespace hrad::reference {

/// FNV-1a (64-bit) of the scene's patches: kind, vertices, rho, E (see above).
uint64_t sceneContentHash(const scene::Scene& scene);

/// 32 hex digits: scene hash, then a hash of kind and settings description.
std::string referenceCacheKey(const scene::Scene& scene, const std::string& kind,
                              const std::string& settingsDescription);

/// Writes `field` (and the per-element standard errors, when given; same
/// size as the field) to `path`, creating parent directories. Throws
/// hrad::Error when the file cannot be written.
void saveReference(const std::string& path, const scene::UniformField& field,
                   const std::vector<RGB>* stdError, const std::string& key,
                   const std::string& metadata);

struct CachedReference {
    std::unique_ptr<scene::UniformField> field;  ///< on the scene passed to loadReference
    std::optional<std::vector<RGB>> stdError;
    std::string metadata;
};

/// The stored reference when `path` exists, its key equals `expectedKey`, and
/// it fits `scene` (patch count); otherwise std::nullopt (see above).
std::optional<CachedReference> loadReference(const std::string& path, const scene::Scene& scene,
                                             const std::string& expectedKey);

/// $HRAD_CACHE when set and non-empty, else $HOME/.cache/hrad, else
/// ./.hrad-cache. Not created here.
std::filesystem::path defaultCacheDir();

/// The file the helpers below use for a reference: <dir>/<prefix>-<key>.bin
/// with prefix "fullmatrix" or "montecarlo".
std::filesystem::path referenceCacheFile(const std::filesystem::path& dir,
                                         const std::string& prefix, const std::string& key);

/// Kinds (with algorithm versions) used in the keys by the helpers below.
// fullmatrix 2: adaptive receiver rule on near pairs; 3: kernel-weighted
// visibility; 4 (with montecarlo 2): a face in the plane of a ray's end
// point or origin never blocks it (transport/visibility.h).
inline constexpr const char* kFullMatrixKind = "fullmatrix/4";
inline constexpr const char* kMonteCarloKind = "montecarlo/2";

/// Full-matrix reference through the cache in `cacheDir` (file
/// "fullmatrix-<key>.bin"): loaded when present, else solved and stored
/// (only when the solve converged). On a hit the field comes from the file
/// and stats hold what the metadata recorded (elements, form factors,
/// iterations, residual, seconds of the original solve); residualHistory is
/// empty. `hit` (optional) says which happened. A cache that cannot be
/// written is a warning, not an error; an interrupted solve is not stored.
FullMatrixResult cachedFullMatrix(const scene::Scene& scene,
                                  const transport::Visibility& visibility,
                                  const FullMatrixSettings& settings,
                                  const std::filesystem::path& cacheDir, bool* hit = nullptr,
                                  bool showProgress = true, const StopPoll& stop = {});

/// Monte Carlo reference through the cache (file "montecarlo-<key>.bin"),
/// with the standard errors; stats restored from the metadata on a hit. Note
/// that with time_budget the stored result is whatever the first run managed.
MonteCarloResult cachedMonteCarlo(const scene::Scene& scene,
                                  const transport::Visibility& visibility,
                                  const MonteCarloSettings& settings,
                                  const std::filesystem::path& cacheDir, bool* hit = nullptr,
                                  bool showProgress = true, const StopPoll& stop = {});

/// Solution files (`solution.hrsol`, written by `hrad solve`, read by
/// `hrad render`): the leaves of any field with their radiosities, so a
/// solution can be rendered again (other camera, size, reconstruction)
/// without solving. Format (host byte order):
///   char[8] "HRADSOL\0", u32 version, u64 sceneContentHash, u64 patch count,
///   [version 2: u32 basis degree p, 1..3]
///   per patch: u32 leaf count, then per leaf u64 key and f64 r, g, b (the
///   leaf's mean), [version 2: then (basisSize(p) - 1) x f64 r, g, b, the
///   coefficients c_1.. of the leaf's polynomial, scene/basis.h];
///   u64 FNV-1a of every byte above.
/// Version 1 is written for piecewise constant fields (hr.basis = constant,
/// the full matrix, Monte Carlo), version 2 for polynomial ones, so that
/// `hrad render` draws the solver's polynomials, not their means.
/// Version 3 (a field with leafTextureRho, hr.texture_rho = element): u32
/// degree (0..3) and u32 flags (bit 0: leafTextureRho) after the patch count,
/// then the leaves as version 2, so that the picture divides by each leaf's
/// reflectance (render/texturing.h).
/// Written atomically (temporary file + rename). Throws hrad::InputError
/// naming the path when the file cannot be written.
void saveSolution(const std::string& path, const scene::RadiosityField& field);
/// The solution in `path` on `scene`. Throws hrad::InputError naming the path
/// when the file is missing, malformed, fails its checksum, or was computed
/// for a scene with other contents (the content hash differs).
std::unique_ptr<scene::LeafField> loadSolution(const std::string& path, const scene::Scene& scene);

}  // namespace hrad::reference
