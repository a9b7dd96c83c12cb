#include "scene/missing_files.h"

#include <fmt/format.h>

#include <algorithm>

namespace hrad::scene {

bool MissingFiles::add(const SourceLocation& where, const std::string& what,
                       const std::string& path) {
    if (seen_.count(path)) return false;
    ++count_;
    if (files_.size() >= kMaxKept) return true;
    seen_.insert(path);
    files_.push_back({where, what, path});
    return true;
}

void MissingFiles::apply(bool skip, WarningLog& warnings) const {
    if (files_.empty()) return;
    if (skip) {
        for (const File& f : files_)
            warnings.add("missing:" + f.path, fmt::format("{}: warning: {} '{}' not found: skipped "
                                                          "(scene.missing = skip)",
                                                          f.where.str(), f.what, f.path));
        if (count_ > files_.size())
            warnings.add("missing:more", fmt::format("{} more missing files skipped", count_ - files_.size()));
        return;
    }
    // Every one of them in one message, in file and line order (includes are
    // read before the shapes): the user fetches them all at once.
    std::vector<File> sorted = files_;
    std::stable_sort(sorted.begin(), sorted.end(), [](const File& a, const File& b) {
        return a.where.file != b.where.file ? a.where.file < b.where.file : a.where.line < b.where.line;
    });
    constexpr size_t kListed = 20;
    std::string list;
    for (size_t i = 1; i < sorted.size() && i <= kListed; ++i)
        list += fmt::format("\n  {}: {} '{}'", sorted[i].where.str(), sorted[i].what, sorted[i].path);
    if (count_ > kListed + 1) list += fmt::format("\n  ... and {} more", count_ - kListed - 1);
    const File& first = sorted.front();
    if (count_ == 1)
        throwInputError(first.where, "{} '{}' not found (scene.missing = skip loads the rest)",
                        first.what, first.path);
    throwInputError(first.where,
                    "{} '{}' not found, and {} more files the scene names are missing "
                    "(scene.missing = skip loads the rest):{}",
                    first.what, first.path, count_ - 1, list);
}

}  // namespace hrad::scene
