// Reference cache; see cache.h for the key and the file format.
#include "reference/cache.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <system_error>

#include "core/error.h"
#include "core/safe_file.h"
#include "core/log.h"
#include "transport/light_irradiance.h"

namespace hrad::reference {

namespace {

constexpr char kMagic[8] = {'H', 'R', 'A', 'D', 'R', 'E', 'F', '\0'};
constexpr uint32_t kVersion = 1;
constexpr uint64_t kFnvOffset = 0xcbf29ce484222325ULL;
constexpr uint64_t kFnvPrime = 0x100000001b3ULL;

struct Fnv {
    uint64_t h = kFnvOffset;
    void bytes(const void* data, size_t n) {
        const auto* p = static_cast<const unsigned char*>(data);
        for (size_t i = 0; i < n; ++i) {
            h ^= p[i];
            h *= kFnvPrime;
        }
    }
    template <typename T>
    void pod(const T& v) {
        bytes(&v, sizeof(T));
    }
    void vec(const Vec3& v) {
        pod(v.x);
        pod(v.y);
        pod(v.z);
    }
};

/// Appends plain values to a byte buffer.
struct Writer {
    std::string buf;
    template <typename T>
    void pod(const T& v) {
        buf.append(reinterpret_cast<const char*>(&v), sizeof(T));
    }
    void str(const std::string& s) {
        pod(uint32_t(s.size()));
        buf += s;
    }
    void rgbs(const std::vector<RGB>& v) {
        for (const RGB& c : v) {
            pod(c.r);
            pod(c.g);
            pod(c.b);
        }
    }
};

/// Bounds-checked reads from a byte buffer; any overrun sets `bad`.
struct Reader {
    const std::string& buf;
    size_t pos = 0;
    bool bad = false;
    bool take(void* out, size_t n) {
        if (bad || buf.size() - pos < n) {
            bad = true;
            return false;
        }
        std::memcpy(out, buf.data() + pos, n);
        pos += n;
        return true;
    }
    template <typename T>
    T pod() {
        T v{};
        take(&v, sizeof(T));
        return v;
    }
    std::string str() {
        auto n = pod<uint32_t>();
        if (bad || buf.size() - pos < n) {
            bad = true;
            return {};
        }
        std::string s = buf.substr(pos, n);
        pos += n;
        return s;
    }
    bool rgbs(std::vector<RGB>& v, size_t n) {
        if (bad || (buf.size() - pos) / (3 * sizeof(double)) < n) {
            bad = true;
            return false;
        }
        v.resize(n);
        for (RGB& c : v) {
            c.r = pod<double>();
            c.g = pod<double>();
            c.b = pod<double>();
        }
        return !bad;
    }
};

std::string hex64(uint64_t v) { return fmt::format("{:016x}", v); }

std::map<std::string, std::string> parseMetadata(const std::string& text) {
    std::map<std::string, std::string> out;
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line)) {
        auto eq = line.find('=');
        if (eq != std::string::npos) out[line.substr(0, eq)] = line.substr(eq + 1);
    }
    return out;
}

double metaDouble(const std::map<std::string, std::string>& m, const char* key) {
    auto it = m.find(key);
    if (it == m.end()) return 0.0;
    char* end = nullptr;
    double v = std::strtod(it->second.c_str(), &end);
    return end != it->second.c_str() ? v : 0.0;
}

uint64_t metaUint(const std::map<std::string, std::string>& m, const char* key) {
    auto it = m.find(key);
    if (it == m.end()) return 0;
    return std::strtoull(it->second.c_str(), nullptr, 10);
}

/// saveReference that only warns (a read-only cache must not fail a solve).
void trySave(const std::filesystem::path& path, const scene::UniformField& field,
             const std::vector<RGB>* stdError, const std::string& key, const std::string& meta) {
    try {
        saveReference(path.string(), field, stdError, key, meta);
        spdlog::info("reference cache: stored {}", path.string());
    } catch (const std::exception& e) {
        spdlog::warn("reference cache: could not store {}: {}", path.string(), e.what());
    }
}

/// Writes `bytes` to a temporary file next to `path` and renames it over
/// `path` (creating parent directories), so readers never see half a file.
void writeFileAtomically(const std::string& path, const std::string& bytes) {
    std::filesystem::path target(path);
    std::error_code ec;
    if (target.has_parent_path()) std::filesystem::create_directories(target.parent_path(), ec);
    if (ec) throw IoError(target.parent_path(), "cannot create the folder: " + ec.message());
    writeFileSafely(target, bytes);  // a temporary file beside it, then a rename
}

}  // namespace

uint64_t sceneContentHash(const scene::Scene& scene) {
    Fnv f;
    f.pod(uint64_t(scene.patches.size()));
    for (const scene::Patch& p : scene.patches) {
        f.pod(uint8_t(p.kind));
        for (int i = 0; i < p.numVertices(); ++i) f.vec(p.v[size_t(i)]);
        f.vec(p.rho);
        f.vec(p.emission);
    }
    // Non-area lights (scene/lights/light.h); a scene without them keeps its hash.
    for (const auto& l : scene.lights) {
        const std::string d = std::string("light-v1 ") + l->describe();
        f.bytes(d.data(), d.size());
    }
    return f.h;
}

std::string referenceCacheKey(const scene::Scene& scene, const std::string& kind,
                              const std::string& settingsDescription) {
    Fnv f;
    f.bytes(kind.data(), kind.size());
    f.bytes("\n", 1);
    f.bytes(settingsDescription.data(), settingsDescription.size());
    return hex64(sceneContentHash(scene)) + hex64(f.h);
}

void saveReference(const std::string& path, const scene::UniformField& field,
                   const std::vector<RGB>* stdError, const std::string& key,
                   const std::string& metadata) {
    const scene::Scene& s = field.scene();
    const size_t n = field.numElements();
    if (stdError && stdError->size() != n)
        throw Error(
            fmt::format("saveReference: {} standard errors for {} elements", stdError->size(), n));
    Writer w;
    w.buf.append(kMagic, sizeof(kMagic));
    w.pod(kVersion);
    w.str(key);
    w.str(metadata);
    w.pod(uint64_t(s.patches.size()));
    for (uint32_t p = 0; p < s.patches.size(); ++p) w.pod(uint8_t(field.level(p)));
    w.pod(uint64_t(n));
    w.pod(uint8_t(stdError ? 1 : 0));
    w.rgbs(field.values());
    if (stdError) w.rgbs(*stdError);
    Fnv f;
    f.bytes(w.buf.data(), w.buf.size());
    w.pod(f.h);

    writeFileAtomically(path, w.buf);
}

std::optional<CachedReference> loadReference(const std::string& path, const scene::Scene& scene,
                                             const std::string& expectedKey) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return std::nullopt;  // no file: a plain miss
    std::string buf((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) {
        spdlog::warn("reference cache: cannot read {}; ignoring it", path);
        return std::nullopt;
    }
    auto corrupt = [&](const std::string& why) -> std::optional<CachedReference> {
        spdlog::warn("reference cache: {} is unusable ({}); ignoring it", path, why);
        return std::nullopt;
    };
    Reader r{buf};
    char magic[8];
    if (!r.take(magic, sizeof(magic)) || std::memcmp(magic, kMagic, sizeof(kMagic)) != 0)
        return corrupt("not a reference file");
    auto version = r.pod<uint32_t>();
    if (r.bad) return corrupt("truncated header");
    if (version != kVersion)
        return corrupt(fmt::format("format version {} != {}", version, kVersion));
    std::string key = r.str();
    if (r.bad) return corrupt("truncated header");
    if (key != expectedKey) {
        spdlog::debug("reference cache: {} has key {}, expected {}", path, key, expectedKey);
        return std::nullopt;
    }
    CachedReference out;
    out.metadata = r.str();
    auto patches = r.pod<uint64_t>();
    if (r.bad) return corrupt("truncated header");
    if (patches != scene.patches.size())
        return corrupt(fmt::format("{} patches, the scene has {}", patches, scene.patches.size()));
    std::vector<uint8_t> levels(patches);
    if (patches > 0 && !r.take(levels.data(), patches)) return corrupt("truncated levels");
    uint64_t expectedElements = 0;
    for (uint8_t l : levels) {
        // 4^15 elements per patch (24 GB of values) is far beyond any
        // reference; the cap also keeps the sizes below from overflowing.
        if (l > 15) return corrupt(fmt::format("level {} out of range", l));
        expectedElements += uint64_t(1) << (2 * l);
    }
    auto elements = r.pod<uint64_t>();
    auto hasStdError = r.pod<uint8_t>();
    if (r.bad) return corrupt("truncated header");
    if (elements != expectedElements)
        return corrupt(fmt::format("{} elements, levels give {}", elements, expectedElements));
    if (hasStdError > 1) return corrupt("bad standard-error flag");
    // Check the exact size before allocating anything proportional to it.
    const uint64_t body = elements * 3 * sizeof(double) * (hasStdError ? 2 : 1);
    if (buf.size() - r.pos != body + sizeof(uint64_t))
        return corrupt(fmt::format("{} bytes after the header, expected {}", buf.size() - r.pos,
                                   body + sizeof(uint64_t)));
    std::vector<RGB> values, errors;
    r.rgbs(values, elements);
    if (hasStdError) r.rgbs(errors, elements);
    size_t checked = r.pos;
    auto stored = r.pod<uint64_t>();
    if (r.bad) return corrupt("truncated data");
    Fnv f;
    f.bytes(buf.data(), checked);
    if (f.h != stored) return corrupt("checksum mismatch");

    out.field = std::make_unique<scene::UniformField>(scene, std::move(levels));
    out.field->values() = std::move(values);
    if (hasStdError) out.stdError = std::move(errors);
    return out;
}

std::filesystem::path referenceCacheFile(const std::filesystem::path& dir,
                                         const std::string& prefix, const std::string& key) {
    return dir / (prefix + "-" + key + ".bin");
}

std::filesystem::path defaultCacheDir() {
    if (const char* c = std::getenv("HRAD_CACHE"); c && *c) return std::filesystem::path(c);
    if (const char* h = std::getenv("HOME"); h && *h)
        return std::filesystem::path(h) / ".cache" / "hrad";
    return std::filesystem::path(".hrad-cache");
}

FullMatrixResult cachedFullMatrix(const scene::Scene& scene,
                                  const transport::Visibility& visibility,
                                  const FullMatrixSettings& settings,
                                  const std::filesystem::path& cacheDir, bool* hit,
                                  bool showProgress, const StopPoll& stop) {
    const std::string desc = settings.describe();
    const std::string key = referenceCacheKey(scene, kFullMatrixKind, desc);
    const std::filesystem::path path = referenceCacheFile(cacheDir, "fullmatrix", key);
    if (auto cached = loadReference(path.string(), scene, key)) {
        if (hit) *hit = true;
        auto m = parseMetadata(cached->metadata);
        FullMatrixResult r;
        r.field = std::move(cached->field);
        r.stats.elements = r.field->numElements();
        r.stats.formFactors = metaUint(m, "form_factors");
        r.stats.rays = metaUint(m, "rays");
        r.stats.ffSeconds = metaDouble(m, "ff_seconds");
        r.stats.solveSeconds = metaDouble(m, "solve_seconds");
        r.stats.iterations = int64_t(metaUint(m, "iterations"));
        r.stats.residual = metaDouble(m, "residual");
        r.stats.converged = true;  // only converged solves are stored
        r.stats.matrixBytes = metaUint(m, "matrix_bytes");
        spdlog::info("reference cache: full matrix from {}", path.string());
        return r;
    }
    if (hit) *hit = false;
    FullMatrixResult r = solveFullMatrix(scene, visibility, settings, showProgress, stop);
    if (r.stats.interrupted) {
        spdlog::warn("reference cache: full matrix interrupted; not stored");
        return r;
    }
    if (!r.stats.converged) {
        spdlog::warn("reference cache: full matrix did not converge; not stored");
        return r;
    }
    std::string meta = fmt::format(
        "kind={}\nscene={}\nsettings={}\nelements={}\nform_factors={}\nrays={}\nff_seconds={}\n"
        "solve_seconds={}\niterations={}\nresidual={}\nmatrix_bytes={}\n",
        kFullMatrixKind, scene.name, desc, r.stats.elements, r.stats.formFactors, r.stats.rays,
        r.stats.ffSeconds, r.stats.solveSeconds, r.stats.iterations, r.stats.residual,
        r.stats.matrixBytes);
    trySave(path, *r.field, nullptr, key, meta);
    return r;
}

MonteCarloResult cachedMonteCarlo(const scene::Scene& scene,
                                  const transport::Visibility& visibility,
                                  const MonteCarloSettings& settings,
                                  const std::filesystem::path& cacheDir, bool* hit,
                                  bool showProgress, const StopPoll& stop) {
    const std::string desc = settings.describe();
    const std::string key = referenceCacheKey(scene, kMonteCarloKind, desc);
    const std::filesystem::path path = referenceCacheFile(cacheDir, "montecarlo", key);
    if (auto cached = loadReference(path.string(), scene, key)) {
        if (cached->stdError) {
            if (hit) *hit = true;
            auto m = parseMetadata(cached->metadata);
            MonteCarloResult r;
            r.field = std::move(cached->field);
            r.stdError = std::move(*cached->stdError);
            r.stats.regions = r.field->numElements();
            r.stats.paths = metaUint(m, "paths");
            r.stats.rays = metaUint(m, "rays");
            r.stats.seconds = metaDouble(m, "seconds");
            r.stats.rounds = int(metaUint(m, "rounds"));
            spdlog::info("reference cache: monte carlo from {}", path.string());
            return r;
        }
        spdlog::warn("reference cache: {} has no standard errors; recomputing", path.string());
    }
    if (hit) *hit = false;
    MonteCarloResult r = solveMonteCarlo(scene, visibility, settings, showProgress, stop);
    if (r.stats.interrupted) {
        spdlog::warn("reference cache: Monte Carlo reference interrupted; not stored");
        return r;
    }
    std::string meta = fmt::format(
        "kind={}\nscene={}\nsettings={}\nregions={}\npaths={}\nrays={}\nseconds={}\n"
        "rounds={}\n",
        kMonteCarloKind, scene.name, desc, r.stats.regions, r.stats.paths, r.stats.rays,
        r.stats.seconds, r.stats.rounds);
    trySave(path, *r.field, &r.stdError, key, meta);
    return r;
}

// ---- solution files -----------------------------------------------------------

namespace {
constexpr char kSolutionMagic[8] = {'H', 'R', 'A', 'D', 'S', 'O', 'L', '\0'};
// Version 1: piecewise constant leaves; version 2: leaves with polynomials
// (a field whose basisDegree() > 0). A constant solution is still written as
// version 1, byte for byte as before.
constexpr uint32_t kSolutionVersion = 1;
constexpr uint32_t kSolutionVersionPolynomial = 2;
// Version 3: a field whose textured leaves carry their own reflectance
// (RadiosityField::leafTextureRho): u32 degree (0..3) and u32 flags (bit 0)
// after the patch count, then the leaves as version 2 (none after the mean
// for degree 0). Versions 1 and 2 are still written for every other field.
constexpr uint32_t kSolutionVersionFlags = 3;
constexpr uint32_t kFlagLeafTextureRho = 1;

/// The largest |B| (and basis coefficient) a patch of `scene` can hold, by
/// which loadSolution refuses 1e308 or NaN, which the checksum cannot (a
/// checksum only says the bytes are as written). With reflectances below
/// rho_max and emissions below E_max, every radiosity lies in
/// [0, E_max / (1 - rho_max)] (the Neumann series of B = E + rho F B with row
/// sums of F <= 1). Lights that are not patches (point, spot, sun, sky:
/// scene/lights/) bound a patch by power instead: A_p B_p is at most the
/// radiosity power of the whole scene, P / (1 - rho_max), P their power into
/// the scene's bounding sphere (transport::lightsPower). Both are widened
/// 1000x for quadrature error in F and Aitken extrapolation.
class RadiosityBound {
  public:
    explicit RadiosityBound(const scene::Scene& scene) : scene_(scene) {
        double eMax = 0.0, rhoMax = 0.0;
        for (const auto& m : scene.materials) {
            eMax = std::max(eMax, maxComponent(m.emission));
            rhoMax = std::max(rhoMax, maxComponent(m.rho));
        }
        const double amplification = 1000.0 / std::max(1e-12, 1.0 - rhoMax);
        emitters_ = amplification * eMax + 1e-300;
        lights_ = scene.lights.empty() ? 0.0 : amplification * transport::lightsPower(scene);
    }
    double operator()(uint64_t patch) const {
        return lights_ > 0 ? emitters_ + lights_ / std::max(1e-300, scene_.patches[patch].area)
                           : emitters_;
    }

  private:
    const scene::Scene& scene_;
    double emitters_ = 0.0, lights_ = 0.0;
};
/// The header's fields after the patch count: the basis degree (versions 2
/// and 3) and the flags (version 3). Throws InputError at `path`.
struct SolutionOptions {
    uint32_t degree = 0, flags = 0;
};
SolutionOptions readSolutionOptions(Reader& r, uint32_t version, const std::string& path) {
    auto fail = [&](const std::string& why) {
        throw InputError(SourceLocation{path, 0, 0}, "not a usable hrad solution: " + why);
    };
    SolutionOptions o;
    if (version == kSolutionVersionPolynomial || version == kSolutionVersionFlags) {
        size_t at = r.pos;
        o.degree = r.pod<uint32_t>();
        const uint32_t lowest = version == kSolutionVersionFlags ? 0 : 1;
        if (r.bad) fail(fmt::format("truncated header ({} bytes, the header has 32)", r.buf.size()));
        if (o.degree < lowest || o.degree > uint32_t(scene::kMaxBasisDegree))
            fail(fmt::format("basis degree {} (at byte offset {}) is not {}..{}", o.degree, at, lowest,
                             scene::kMaxBasisDegree));
    }
    if (version == kSolutionVersionFlags) {
        size_t at = r.pos;
        o.flags = r.pod<uint32_t>();
        if (r.bad) fail(fmt::format("truncated header ({} bytes, the header has 36)", r.buf.size()));
        if (o.flags & ~kFlagLeafTextureRho)
            fail(fmt::format("unknown flags {:#x} (at byte offset {})", o.flags, at));
    }
    return o;
}
}  // namespace

void saveSolution(const std::string& path, const scene::RadiosityField& field) {
    const scene::Scene& s = field.scene();
    Writer w;
    w.buf.append(kSolutionMagic, sizeof(kSolutionMagic));
    const int degree = field.basisDegree();
    const int extra = scene::basisSize(degree) - 1;
    const bool flags = field.leafTextureRho();
    w.pod(flags ? kSolutionVersionFlags : degree > 0 ? kSolutionVersionPolynomial : kSolutionVersion);
    w.pod(sceneContentHash(s));
    w.pod(uint64_t(s.patches.size()));
    if (degree > 0 || flags) w.pod(uint32_t(degree));
    if (flags) w.pod(kFlagLeafTextureRho);
    std::array<RGB, scene::kMaxBasisSize> higher{};
    for (uint32_t p = 0; p < s.patches.size(); ++p) {
        std::vector<std::pair<scene::ElementKey, RGB>> leaves;
        field.forEachLeaf(p, [&](scene::ElementKey k, const RGB& b) { leaves.emplace_back(k, b); });
        w.pod(uint32_t(leaves.size()));
        for (const auto& [k, b] : leaves) {
            w.pod(uint64_t(k));
            w.pod(b.r);
            w.pod(b.g);
            w.pod(b.b);
            if (degree == 0) continue;
            field.leafHigherCoefficients(p, k, higher.data());
            for (int a = 0; a < extra; ++a) {
                w.pod(higher[size_t(a)].r);
                w.pod(higher[size_t(a)].g);
                w.pod(higher[size_t(a)].b);
            }
        }
    }
    Fnv f;
    f.bytes(w.buf.data(), w.buf.size());
    w.pod(f.h);
    // An IoError (disk full, read-only) stays one, with its path once: the
    // sweep records it as kind io, which --resume reruns (issue 64).
    try {
        writeFileAtomically(path, w.buf);
    } catch (const IoError&) {
        throw;
    } catch (const Error& e) {
        throw IoError(path, e.what());
    }
}

std::unique_ptr<scene::LeafField> loadSolution(const std::string& path, const scene::Scene& scene) {
    auto fail = [&](const std::string& why) -> std::unique_ptr<scene::LeafField> {
        throw InputError(SourceLocation{path, 0, 0}, "not a usable hrad solution: " + why);
    };
    requireRegularFile(path, "solution file");  // a FIFO would block, /dev/zero never end
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(SourceLocation{path, 0, 0}, "cannot open the solution file");
    std::string buf((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    Reader r{buf};
    char magic[8];
    if (!r.take(magic, sizeof(magic)) || std::memcmp(magic, kSolutionMagic, sizeof(magic)) != 0)
        return fail("no HRADSOL header (at byte offset 0)");
    auto version = r.pod<uint32_t>();
    auto hash = r.pod<uint64_t>();
    auto patches = r.pod<uint64_t>();
    if (r.bad)
        return fail(fmt::format("truncated header ({} bytes, the header has 28)", buf.size()));
    if (version != kSolutionVersion && version != kSolutionVersionPolynomial &&
        version != kSolutionVersionFlags)
        return fail(fmt::format("format version {} is not {}, {} or {} (at byte offset 8)", version,
                                kSolutionVersion, kSolutionVersionPolynomial, kSolutionVersionFlags));
    if (hash != sceneContentHash(scene) || patches != scene.patches.size())
        throw InputError(SourceLocation{path, 0, 0},
                         fmt::format("the solution was computed for another scene (content hash "
                                     "{}, {} patches; this scene: {}, {} patches)",
                                     hex64(hash), patches, hex64(sceneContentHash(scene)),
                                     scene.patches.size()));
    const RadiosityBound boundOf(scene);
    const auto [degree, flags] = readSolutionOptions(r, version, path);
    const size_t extra = size_t(scene::basisSize(int(degree)) - 1);
    const size_t leafBytes = 4 * sizeof(uint64_t) + 3 * sizeof(double) * extra;
    std::vector<std::vector<scene::LeafField::Leaf>> leaves(patches);
    std::vector<std::vector<RGB>> higher(degree > 0 ? patches : 0);
    for (uint64_t p = 0; p < patches; ++p) {
        const double bound = boundOf(p);
        size_t countAt = r.pos;
        auto n = r.pod<uint32_t>();
        if (r.bad || (buf.size() - r.pos) / leafBytes < n)
            return fail(
                fmt::format("truncated at patch {} (its leaf count {} at byte offset {} exceeds "
                            "the bytes left)",
                            p, n, countAt));
        leaves[p].resize(n);
        if (degree > 0) higher[p].resize(extra * n);
        for (size_t i = 0; i < n; ++i) {
            auto& l = leaves[p][i];
            size_t at = r.pos;
            l.key = r.pod<uint64_t>();
            l.value.r = r.pod<double>();
            l.value.g = r.pod<double>();
            l.value.b = r.pod<double>();
            for (size_t a = 0; a < extra; ++a) {
                size_t cAt = r.pos;
                RGB& c = higher[p][i * extra + a];
                c.r = r.pod<double>();
                c.g = r.pod<double>();
                c.b = r.pod<double>();
                // An orthonormal coefficient is bounded by the L2 norm of B
                // over the leaf, itself within the radiosity bound below.
                for (int ch = 0; ch < 3; ++ch)
                    if (!(std::isfinite(c[ch]) && std::abs(c[ch]) <= bound))
                        return fail(fmt::format(
                            "patch {}: basis coefficient {} of the leaf at byte offset {} "
                            "(at byte offset {}) is not finite or outside what the scene "
                            "can produce (|c| <= {:.6g})",
                            p, a + 1, at, cAt, bound));
            }
            if (!scene::isValidKey(l.key))
                return fail(
                    fmt::format("patch {}: key {} (at byte offset {}) is not an element of the "
                                "patch's quadtree",
                                p, l.key, at));
            for (int c = 0; c < 3; ++c)
                if (!(std::isfinite(l.value[c]) && l.value[c] >= -bound && l.value[c] <= bound))
                    return fail(fmt::format(
                        "patch {}: radiosity ({:.6g}, {:.6g}, {:.6g}) of the leaf {} at "
                        "byte offset {} is not finite or outside what the scene "
                        "can produce (|B| <= {:.6g})",
                        p, l.value.r, l.value.g, l.value.b, l.key, at, bound));
        }
    }
    size_t checked = r.pos;
    auto stored = r.pod<uint64_t>();
    if (r.bad || r.pos != buf.size())
        return fail(
            fmt::format("the leaves end at byte offset {}, then {} bytes follow where the 8-byte "
                        "checksum belongs",
                        checked, buf.size() - checked));
    Fnv f;
    f.bytes(buf.data(), checked);
    if (f.h != stored)
        return fail(fmt::format("checksum mismatch (checksum at byte offset {})", checked));
    try {
        auto field = std::make_unique<scene::LeafField>(scene, std::move(leaves), int(degree),
                                                        std::move(higher));
        field->setLeafTextureRho((flags & kFlagLeafTextureRho) != 0);
        return field;
    } catch (const Error& e) {
        return fail(e.what());
    }
}

}  // namespace hrad::reference
