// Files a scene names that are not there: scene.missing = error | skip.
//
// Scenes downloaded without all their parts name meshes, includes, spectra
// and textures that do not exist. Every loader records each such file here
// (once per path, where it was first named) and goes on as if the reference
// were absent: a missing mesh or include adds nothing, a missing texture or
// reflectance spectrum leaves the format's grey, a missing emission spectrum
// emits nothing. loadScene then applies the setting:
//   error (default)  one InputError at the first one's FILE:LINE that lists
//                    every missing file, so one run names all of them
//   skip             one warning per missing file, and the rest loads
// Only the first kMaxKept paths are kept (a hostile scene may name millions);
// the others are counted.
#pragma once

#include <cstdint>
#include <string>
#include <unordered_set>
#include <vector>

#include "core/error.h"
#include "core/warning_log.h"

namespace hrad::scene {

class MissingFiles {
  public:
    static constexpr size_t kMaxKept = 1000;
    struct File {
        SourceLocation where;  ///< where the scene names it (first time)
        std::string what;      ///< "mesh file", "included file", "spectrum file", "texture"
        std::string path;
    };

    /// Records a missing file; false when its path was recorded already.
    bool add(const SourceLocation& where, const std::string& what, const std::string& path);
    const std::vector<File>& files() const { return files_; }
    uint64_t count() const { return count_; }
    bool empty() const { return count_ == 0; }

    /// scene.missing: throws (error) listing them, or warns once per file (skip).
    void apply(bool skip, WarningLog& warnings) const;

  private:
    std::vector<File> files_;
    std::unordered_set<std::string> seen_;
    uint64_t count_ = 0;
};

}  // namespace hrad::scene
