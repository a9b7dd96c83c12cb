#include "core/safe_file.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <random>

namespace hrad {

namespace fs = std::filesystem;

IoError::IoError(const fs::path& path, const std::string& message)
    : InputError(SourceLocation{path.string(), 0, 0}, message) {}

namespace {

std::string errnoText(int e) { return std::strerror(e); }

/// Creates a new file beside `path` (O_EXCL|O_NOFOLLOW: never an existing
/// file or a symlink); returns its descriptor and sets tmp to its name.
int createTemp(const fs::path& path, fs::path& tmp) {
    fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
    std::random_device rd;
    for (int attempt = 0; attempt < 100; ++attempt) {
        tmp = dir / fmt::format(".{}.tmp.{}.{}", path.filename().string(), getpid(), rd());
        int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
        if (fd >= 0) return fd;
        if (errno != EEXIST) {
            int e = errno;
            throw IoError(path, "cannot create a file in " + dir.string() + ": " + errnoText(e));
        }
    }
    throw IoError(path, "cannot create a temporary file beside it");
}

/// Renames tmp over path unless path is a folder; removes tmp on failure.
void moveIntoPlace(const fs::path& tmp, const fs::path& path) {
    struct stat st {};
    if (::lstat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
        ::unlink(tmp.c_str());
        throw IoError(path, "is a folder; expected a file name to write");
    }
    if (::rename(tmp.c_str(), path.c_str()) != 0) {
        int e = errno;
        ::unlink(tmp.c_str());
        throw IoError(path, "cannot write: " + errnoText(e));
    }
}

}  // namespace

void writeFileSafely(const fs::path& path, std::string_view bytes) {
    fs::path tmp;
    int fd = createTemp(path, tmp);
    const char* p = bytes.data();
    size_t left = bytes.size();
    while (left > 0) {
        ssize_t n = ::write(fd, p, left);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            int e = n < 0 ? errno : ENOSPC;
            ::close(fd);
            ::unlink(tmp.c_str());
            throw IoError(path, "cannot write: " + errnoText(e));
        }
        p += n;
        left -= size_t(n);
    }
    if (::close(fd) != 0) {
        int e = errno;
        ::unlink(tmp.c_str());
        throw IoError(path, "cannot write: " + errnoText(e));
    }
    moveIntoPlace(tmp, path);
}

void writeThroughTemp(const fs::path& path, const std::function<void(const fs::path& tmp)>& write) {
    fs::path tmp;
    ::close(createTemp(path, tmp));
    try {
        write(tmp);
    } catch (...) {
        ::unlink(tmp.c_str());
        throw;
    }
    moveIntoPlace(tmp, path);
}

void requireRegularFile(const fs::path& path, const std::string& what) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) {
        int e = errno;
        throwInputError(SourceLocation{path.string(), 0, 0}, "cannot open the {}: {}", what,
                        errnoText(e));
    }
    if (!S_ISREG(st.st_mode))
        throwInputError(SourceLocation{path.string(), 0, 0},
                        "the {} is not a regular file (a {}); expected a file", what,
                        S_ISDIR(st.st_mode)    ? "folder"
                        : S_ISFIFO(st.st_mode) ? "FIFO"
                        : S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode) ? "device"
                                                                     : "socket or special file");
}

void requireNoSymlinkBelow(const fs::path& base, const fs::path& path) {
    fs::path rel = path.lexically_relative(base);
    if (rel.empty() || *rel.begin() == "..") return;
    fs::path cur = base;
    for (const fs::path& part : rel) {
        cur /= part;
        struct stat st {};
        if (::lstat(cur.c_str(), &st) != 0) return;  // not there yet: hrad creates it
        if (S_ISLNK(st.st_mode))
            throwInputError(SourceLocation{cur.string(), 0, 0},
                            "is a symbolic link; hrad writes its outputs below {} and does not "
                            "follow links there (remove it or choose another folder)",
                            base.string());
    }
}

void ensureOutputFolder(const fs::path& dir, const std::string& what) {
    if (dir.empty())
        throwInputError(SourceLocation{what, 0, 0}, "the output folder name is empty");
    struct stat st {};
    if (::stat(dir.c_str(), &st) == 0 && !S_ISDIR(st.st_mode))
        throw IoError(dir, "is not a folder; expected an output folder");
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
        throw IoError(dir, "cannot create the output folder: " +
                               (ec ? ec.message() : std::string("unknown error")));
    if (::access(dir.c_str(), W_OK | X_OK) != 0) {
        int e = errno;
        throw IoError(dir, "cannot write into the output folder: " + errnoText(e));
    }
}

bool FileLock::tryLock(const fs::path& path) {
    int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) {
        int e = errno;
        throw IoError(path, "cannot open to lock it: " + errnoText(e));
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
        ::close(fd);
        return false;
    }
    fd_ = fd;
    return true;
}

void FileLock::closeInChild() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
}

FileLock::~FileLock() {
    if (fd_ >= 0) ::close(fd_);
}

}  // namespace hrad
