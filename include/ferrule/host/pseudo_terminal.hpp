// pseudo_terminal: the simulator's end of a pty pair. path() is the device another program
// opens as its serial port; the simulator reads and writes fd(). Both ends are raw (no echo,
// no line editing, 8-bit clean); the simulator's end is non-blocking, and the other end stays
// open here so that the simulator's end does not hang up between clients. link() adds a
// stable name, removed with the object if it is still the object's link.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <system_error>

namespace ferrule::host {

// Where the symlink at `path` points; nullopt when `path` is no symlink (or is unreadable).
inline std::optional<std::string> read_link(const std::string& path) {
    std::array<char, 4096> buf{};
    const ssize_t n = ::readlink(path.c_str(), buf.data(), buf.size());
    if (n < 0 || static_cast<std::size_t>(n) == buf.size()) return std::nullopt;
    return std::string(buf.data(), static_cast<std::size_t>(n));
}

// A Unix 98 pseudo-terminal's name: /dev/pts/ and a number.
inline bool is_pty_name(const std::string& path) {
    constexpr std::string_view prefix = "/dev/pts/";
    if (path.size() <= prefix.size() || path.compare(0, prefix.size(), prefix) != 0) return false;
    return path.find_first_not_of("0123456789", prefix.size()) == std::string::npos;
}

class pseudo_terminal {
public:
    pseudo_terminal() = default;
    pseudo_terminal(const pseudo_terminal&) = delete;
    pseudo_terminal& operator=(const pseudo_terminal&) = delete;
    ~pseudo_terminal() {
        // Only while the link still names this pty: whatever took its place stays.
        if (!link_.empty() && read_link(link_) == path_) ::unlink(link_.c_str());
        if (master_ >= 0) ::close(master_);
        if (slave_ >= 0) ::close(slave_);
    }

    std::error_code open() {
        std::array<char, 256> name{};
        if (::openpty(&master_, &slave_, name.data(), nullptr, nullptr) != 0)
            return {errno, std::generic_category()};
        path_ = name.data();
        for (int fd : {master_, slave_}) {
            termios t{};
            ::tcgetattr(fd, &t);
            ::cfmakeraw(&t);
            ::tcsetattr(fd, TCSANOW, &t);
        }
        ::fcntl(master_, F_SETFL, ::fcntl(master_, F_GETFL) | O_NONBLOCK);
        return {};
    }

    // Adds `link_path`, a symlink to path(). It is made only where nothing is, or in place of
    // a stale link: a symlink to a /dev/pts/N that no longer exists (or is this pty), left by
    // a simulator that did not end normally. Anything else is left as it is:
    // std::errc::device_or_resource_busy for a link to a pty that exists (another simulator
    // serves it), std::errc::file_exists for anything else; link_refusal() explains both.
    // Simulators linking in one directory take turns (flock on the directory), so two never
    // both take the same stale link.
    std::error_code link(const std::string& link_path) {
        const int dir = ::open(directory_of(link_path).c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        if (dir < 0) return last_error();
        std::error_code ec;
        if (::flock(dir, LOCK_EX) != 0)
            ec = last_error();
        else
            ec = link_locked(link_path);
        ::close(dir); // and the lock with it
        if (!ec) link_ = link_path;
        return ec;
    }

    int fd() const noexcept { return master_; }
    const std::string& path() const noexcept { return path_; }

    // Writes all of `bytes`, waiting while the pty is full; false when nobody can read them
    // (the other end is closed): lost, as on an open line.
    bool write(std::span<const std::uint8_t> bytes) const {
        std::size_t off = 0;
        while (off < bytes.size()) {
            const ssize_t n = ::write(master_, bytes.data() + off, bytes.size() - off);
            if (n > 0) {
                off += static_cast<std::size_t>(n);
            } else if (errno == EAGAIN) {
                pollfd p{master_, POLLOUT, 0};
                ::poll(&p, 1, 10);
            } else {
                return false;
            }
        }
        return true;
    }

private:
    static std::error_code last_error() { return {errno, std::generic_category()}; }

    static std::string directory_of(const std::string& path) {
        const auto slash = path.rfind('/');
        if (slash == std::string::npos) return ".";
        return slash == 0 ? "/" : path.substr(0, slash);
    }

    std::error_code link_locked(const std::string& link_path) const {
        // symlink() makes nothing where anything is: only then is there something to look at.
        if (::symlink(path_.c_str(), link_path.c_str()) == 0) return {};
        if (errno != EEXIST) return last_error();
        const auto target = read_link(link_path);
        if (target == path_) return {}; // a stale link that names this very pty
        if (!target || !is_pty_name(*target)) return std::make_error_code(std::errc::file_exists);
        struct stat st {};
        if (::stat(target->c_str(), &st) == 0 || errno != ENOENT)
            return std::make_error_code(std::errc::device_or_resource_busy);
        if (::unlink(link_path.c_str()) != 0 && errno != ENOENT) return last_error();
        if (::symlink(path_.c_str(), link_path.c_str()) != 0) return last_error();
        return {};
    }

    int master_ = -1;
    int slave_ = -1;
    std::string path_;
    std::string link_;
};

// What is at `path`, in words: "a regular file", "a symlink to /etc/hosts" …
inline std::string describe_path(const std::string& path) {
    struct stat st {};
    if (::lstat(path.c_str(), &st) != 0) return "gone";
    if (S_ISLNK(st.st_mode)) return "a symlink to " + read_link(path).value_or("?");
    if (S_ISREG(st.st_mode)) return "a regular file";
    if (S_ISDIR(st.st_mode)) return "a directory";
    return "a special file";
}

// Why pseudo_terminal::link() refused `link_path`, for a user.
inline std::string link_refusal(const std::string& link_path, std::error_code ec) {
    if (ec == std::errc::device_or_resource_busy)
        return link_path + " is " + describe_path(link_path) +
               ", a pseudo-terminal in use (another simulator's?); left as it is";
    if (ec == std::errc::file_exists)
        return link_path + " is " + describe_path(link_path) +
               ", not a stale simulator link; left as it is";
    return link_path + ": " + ec.message();
}

} // namespace ferrule::host
