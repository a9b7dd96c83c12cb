// Safe file access: every output file hrad writes, every input file it opens.
//
// Outputs (summary.json, images, .hrsol, .ply, .glb, CSV exports, store side
// files, Slurm scripts) go through writeFileSafely / writeThroughTemp: the bytes
// are written to a new temporary file in the target's folder (created with
// O_CREAT|O_EXCL|O_NOFOLLOW, so never through a planted symlink), then renamed
// over the target. rename(2) replaces a symlink at the target by the file; it
// never writes through it, so `ln -s victim o/summary.json` leaves victim
// intact. A reader never sees half a file, and a failed write (disk full,
// read-only folder) leaves the old file and throws IoError naming the path.
//
// Inputs go through requireRegularFile: a FIFO, a device (/dev/zero) or a
// folder given as a scene, spectrum, texture or solution is an input error
// instead of a hang or an endless read.
//
// FileLock is an advisory flock(2) held for a process's lifetime, used to
// keep one writer per results store (issue 64).
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>

#include "core/error.h"

namespace hrad {

/// A failed read or write of the file system (disk full, permissions, a
/// folder where a file is expected): an input problem of the run's
/// environment, exit 2; a sweep records it as kind "io" and --resume reruns it.
class IoError : public InputError {
  public:
    IoError(const std::filesystem::path& path, const std::string& message);
};

/// Writes bytes to path through a temporary file in the same folder and a rename.
void writeFileSafely(const std::filesystem::path& path, std::string_view bytes);

/// As writeFileSafely for writers that need a file name (libpng, OpenEXR):
/// write(tmp) writes the temporary file, which is then renamed over path.
/// The temporary is removed when write throws.
void writeThroughTemp(const std::filesystem::path& path,
                      const std::function<void(const std::filesystem::path& tmp)>& write);

/// Throws InputError (at `where`, else naming the file) unless path is a
/// regular file (symlinks to one are followed: the user named it).
void requireRegularFile(const std::filesystem::path& path, const std::string& what);

/// Throws InputError when `path` or one of its folders below `base` is a
/// symlink: outputs under a folder hrad chose must not escape it.
void requireNoSymlinkBelow(const std::filesystem::path& base, const std::filesystem::path& path);

/// Creates the output folder `dir` (and its parents) or throws IoError: an
/// empty name, a file, a device (/dev/null) or an unwritable folder.
void ensureOutputFolder(const std::filesystem::path& dir, const std::string& what);

/// An exclusive advisory lock on an existing file, released on destruction.
class FileLock {
  public:
    /// Returns false (and holds nothing) when another process holds the lock.
    bool tryLock(const std::filesystem::path& path);
    /// In a child after fork(): closes the inherited descriptor, leaving the
    /// parent's lock held (it ends with the parent, not with its children).
    void closeInChild();
    ~FileLock();
    FileLock() = default;
    FileLock(const FileLock&) = delete;
    FileLock& operator=(const FileLock&) = delete;

  private:
    int fd_ = -1;
};

}  // namespace hrad
