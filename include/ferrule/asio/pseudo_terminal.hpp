// pseudo_terminal: the simulator's end of a pty pair. path() is the device another program
// opens as its serial port; the simulator reads and writes fd(). Both ends are raw (no echo,
// no line editing, 8-bit clean); the simulator's end is non-blocking, and the other end stays
// open here so that the simulator's end does not hang up between clients. link() adds a
// stable name, removed with the object.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdint>
#include <span>
#include <string>
#include <system_error>

namespace ferrule::host {

class pseudo_terminal {
public:
    pseudo_terminal() = default;
    pseudo_terminal(const pseudo_terminal&) = delete;
    pseudo_terminal& operator=(const pseudo_terminal&) = delete;
    ~pseudo_terminal() {
        if (!link_.empty()) ::unlink(link_.c_str());
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

    std::error_code link(const std::string& link_path) {
        ::unlink(link_path.c_str());
        if (::symlink(path_.c_str(), link_path.c_str()) != 0)
            return {errno, std::generic_category()};
        link_ = link_path;
        return {};
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
    int master_ = -1;
    int slave_ = -1;
    std::string path_;
    std::string link_;
};

} // namespace ferrule::host
