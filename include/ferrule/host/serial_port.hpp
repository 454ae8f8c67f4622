// Opening a serial port on a POSIX host for a protocol session: baud rate and character
// format from a ferrule::serial_format, optional RS-485 mode and low-latency flag.
//
// Settings a port cannot take are not fatal: USB adapters and pseudo-terminals refuse some
// (a pty keeps 8 data bits and no parity whatever it is told, and knows no RS-485 or
// serial ioctls). Each refusal is reported once through the warning handler and the port
// is used as it is. Errors that make the port unusable (no such port, no permission) come
// back as std::error_code; open_error_message() explains them to a user.
#pragma once

#include <fcntl.h>
#include <linux/serial.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <asio/io_context.hpp>
#include <asio/serial_port.hpp>

#include <cerrno>
#include <functional>
#include <string>
#include <string_view>
#include <system_error>

#include "ferrule/core/serial_format.hpp"

namespace ferrule::host {

struct serial_options {
    serial_format format{};
    bool rs485 = false;      // let the kernel driver switch the transceiver (TIOCSRS485)
    bool low_latency = true; // ASYNC_LOW_LATENCY: USB adapters deliver bytes without delay
};

// Called once per setting the port did not take, with a sentence for the user.
using warning_handler = std::function<void(std::string_view)>;

namespace detail {

inline speed_t baud_constant(std::uint32_t baud) noexcept {
    switch (baud) {
    case 1200: return B1200;
    case 2400: return B2400;
    case 4800: return B4800;
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 230400: return B230400;
    case 460800: return B460800;
    case 921600: return B921600;
    default: return B0;
    }
}

inline tcflag_t char_size(std::uint8_t bits) noexcept {
    switch (bits) {
    case 5: return CS5;
    case 6: return CS6;
    case 7: return CS7;
    default: return CS8;
    }
}

inline void warn(const warning_handler& h, const std::string& text) {
    if (h) h(text);
}

// Raw mode in the requested format; what did not stick is reported.
inline std::error_code apply_format(int fd, const serial_format& f, const std::string& path,
                                    const warning_handler& on_warning) {
    const speed_t speed = baud_constant(f.baud);
    if (speed == B0) return std::make_error_code(std::errc::invalid_argument);
    termios t{};
    if (::tcgetattr(fd, &t) != 0) return {errno, std::generic_category()};
    ::cfmakeraw(&t);
    t.c_cflag |= CLOCAL | CREAD;
    t.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | PARODD | CSTOPB | CRTSCTS);
    t.c_cflag |= char_size(f.data_bits);
    if (f.parity != parity::none) t.c_cflag |= PARENB;
    if (f.parity == parity::odd) t.c_cflag |= PARODD;
    if (f.stop_bits == 2) t.c_cflag |= CSTOPB;
    t.c_cc[VMIN] = 1;
    t.c_cc[VTIME] = 0;
    ::cfsetispeed(&t, speed);
    ::cfsetospeed(&t, speed);
    if (::tcsetattr(fd, TCSANOW, &t) != 0) {
        if (errno != EINVAL) return {errno, std::generic_category()};
        // Some ports (a pty that was set up before) refuse the format as a whole: take 8N1
        // and let the checks below say what is missing.
        termios plain = t;
        plain.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | PARODD | CSTOPB);
        plain.c_cflag |= CS8;
        if (::tcsetattr(fd, TCSANOW, &plain) != 0) return {errno, std::generic_category()};
    }

    termios got{};
    if (::tcgetattr(fd, &got) != 0) return {errno, std::generic_category()};
    if ((got.c_cflag & CSIZE) != char_size(f.data_bits))
        warn(on_warning, path + ": the port does not take " + std::to_string(f.data_bits) +
                             " data bits (a pseudo-terminal or a limited adapter); carrying on "
                             "with what it has");
    if ((got.c_cflag & (PARENB | PARODD)) != (t.c_cflag & (PARENB | PARODD)))
        warn(on_warning, path + ": the port does not take the parity setting; carrying on "
                                "without it");
    if ((got.c_cflag & CSTOPB) != (t.c_cflag & CSTOPB))
        warn(on_warning, path + ": the port does not take the stop-bit setting; carrying on");
    if (::cfgetospeed(&got) != speed)
        warn(on_warning,
             path + ": the port does not take " + std::to_string(f.baud) + " baud; carrying on");
    return {};
}

inline void apply_rs485(int fd, const std::string& path, const warning_handler& on_warning) {
    serial_rs485 rs{};
    rs.flags = SER_RS485_ENABLED | SER_RS485_RTS_ON_SEND;
    if (::ioctl(fd, TIOCSRS485, &rs) != 0)
        warn(on_warning, path + ": no RS-485 mode in this driver (TIOCSRS485: " +
                             std::generic_category().message(errno) +
                             "); fine for adapters that switch direction themselves");
}

inline void apply_low_latency(int fd, const std::string& path, const warning_handler& on_warning) {
    serial_struct ss{};
    if (::ioctl(fd, TIOCGSERIAL, &ss) == 0) {
        ss.flags |= ASYNC_LOW_LATENCY;
        if (::ioctl(fd, TIOCSSERIAL, &ss) == 0) return;
    }
    warn(on_warning, path + ": cannot set the low-latency flag (" +
                         std::generic_category().message(errno) +
                         "); replies may arrive in bursts");
}

} // namespace detail

// Opens `path` into `port` with the options. On failure the port stays closed.
inline std::error_code open_serial(::asio::serial_port& port, const std::string& path,
                                   const serial_options& options,
                                   const warning_handler& on_warning = {}) {
    std::error_code ec;
    port.open(path, ec);
    // asio reports errno values in its own category; keep them comparable with std::errc.
    if (ec) return {ec.value(), std::generic_category()};
    const int fd = port.native_handle();
    if (auto fmt = detail::apply_format(fd, options.format, path, on_warning)) {
        port.close(ec);
        return fmt;
    }
    if (options.rs485) detail::apply_rs485(fd, path, on_warning);
    if (options.low_latency) detail::apply_low_latency(fd, path, on_warning);
    ::tcflush(fd, TCIOFLUSH);
    return {};
}

// A sentence for the user: what went wrong opening `path` and what to do about it.
inline std::string open_error_message(const std::string& path, std::error_code ec) {
    if (ec == std::errc::no_such_file_or_directory)
        return "cannot open " + path +
               ": no such port (is the adapter plugged in? see ls /dev/ttyUSB* /dev/serial/by-id/)";
    if (ec == std::errc::permission_denied)
        return "cannot open " + path +
               ": permission denied; add your user to the dialout group "
               "(sudo usermod -aG dialout $USER) and log in again";
    if (ec == std::errc::device_or_resource_busy)
        return "cannot open " + path + ": the port is in use by another program";
    if (ec == std::errc::invalid_argument)
        return "cannot open " + path + ": unsupported baud rate or format";
    return "cannot open " + path + ": " + ec.message();
}

} // namespace ferrule::host
