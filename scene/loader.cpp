// loadScene: built-in names, else files by extension (see loader.h).
#include "scene/loader.h"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "core/error.h"
#include "core/timer.h"
#include "scene/builtin.h"
#include "scene/mgf_loader.h"
#include "scene/obj_loader.h"
#include "scene/ply_loader.h"

namespace hrad::scene {

bool isBuiltinName(const std::string& spec) {
    std::string head = spec.substr(0, spec.find(':'));
    const auto& names = builtinNames();
    return std::find(names.begin(), names.end(), head) != names.end();
}

Scene loadScene(const std::string& spec, const Params& params) {
    Timer timer;
    // Every key is read up front, whether or not it applies to this format,
    // so that the caller's reportUnused() only flags misspellings.
    MgfOptions mgf;
    mgf.resolution = int(params.getInt("mgf.resolution", mgf.resolution, 3, 4096));
    mgf.whitePoint = params.getEnum("mgf.white_point", mgf.whitePoint, {"E", "D65"});
    mgf.maxFaces = size_t(params.getInt("mgf.max_faces", int64_t(mgf.maxFaces), 1, int64_t(1) << 40));
    ObjOptions obj;
    obj.defaultRho = params.getDouble("obj.default_rho", obj.defaultRho, 0.0, 1.0);
    if (!(obj.defaultRho < 1.0))
        throwInputError(params.where("obj.default_rho"), "setting 'obj.default_rho' must be < 1");
    obj.clampRho = params.getDouble("obj.clamp_rho", obj.clampRho, 0.0, 0.999999);
    PlyOptions ply;
    ply.emission = params.getDouble("ply.emission", ply.emission, 0.0, 1e30);
    ply.defaultRho = params.getDouble("ply.default_rho", ply.defaultRho, 0.0, 1.0);
    if (!(ply.defaultRho < 1.0))
        throwInputError(params.where("ply.default_rho"), "setting 'ply.default_rho' must be < 1");
    bool validate = params.getBool("validate", true);

    Scene scene;
    if (isBuiltinName(spec)) {
        scene = makeBuiltin(spec);
    } else {
        std::filesystem::path path(spec);
        std::string ext = path.extension().string();
        std::transform(ext.begin(), ext.end(), ext.begin(),
                       [](unsigned char c) { return char(std::tolower(c)); });
        if (ext != ".obj" && ext != ".mgf" && ext != ".ply")
            throwInputError(SourceLocation{spec, 0, 0},
                            "unknown scene file extension '{}' (expected .obj, .mgf or .ply, or a "
                            "built-in name: cornell, furnace, plates:..., office:N)",
                            ext);
        // error_code forms: a name the system refuses (too long, ...) is an
        // input error, not a std::filesystem exception.
        std::error_code ec;
        if (!std::filesystem::exists(path, ec))
            throwInputError(SourceLocation{spec, 0, 0}, "scene file not found{}",
                            ec ? " (" + ec.message() + ")" : std::string());
        if (!std::filesystem::is_regular_file(path, ec))
            throwInputError(SourceLocation{spec, 0, 0}, "scene path is not a regular file (a folder or device)");
        if (ext == ".obj")
            scene = loadObj(spec, obj);
        else if (ext == ".mgf")
            scene = loadMgf(spec, mgf);
        else
            scene = loadPly(spec, ply);
        scene.name = spec;
    }
    if (validate) scene.validate();
    scene.stats.loadSeconds = timer.seconds();
    return scene;
}

}  // namespace hrad::scene
