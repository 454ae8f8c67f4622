// One error model for all of ferrule: std::error_code.
// ferrule::errc covers transport and framing; each protocol adds a category that
// keeps the device's own code (see movilink/error.hpp and friends).
#pragma once

#include <string>
#include <system_error>

namespace ferrule {

enum class errc {
    timeout = 1,          // no (complete) reply before the deadline
    bad_checksum,         // BCC / CRC / FCS mismatch
    malformed,            // bytes that do not form a telegram of this protocol
    unexpected_address,   // a reply from another station than the one asked
    unexpected_type,      // a reply whose type / function does not match the request
    no_response_expected, // a broadcast / group request: done, nothing will come back
    fault_latched,        // too many failures in a row; reset the session to go on
    buffer_too_small,     // the caller's buffer cannot hold the telegram
    invalid_argument,     // a request that the protocol cannot express
    busy,                 // a transaction is already running
    frame_gap,            // a gap inside a telegram longer than the protocol allows
    transport,            // the byte stream failed (port closed, I/O error)
    out_of_range,         // well-formed, but beyond the range the protocol gives it
};

class errc_category_t final : public std::error_category {
public:
    const char* name() const noexcept override { return "ferrule"; }
    std::string message(int ev) const override { return describe(static_cast<errc>(ev)); }

    static const char* describe(errc e) noexcept {
        switch (e) {
        case errc::timeout: return "no reply before the response timeout";
        case errc::bad_checksum: return "checksum mismatch";
        case errc::malformed: return "malformed telegram";
        case errc::unexpected_address: return "reply from an unexpected address";
        case errc::unexpected_type: return "reply of an unexpected type";
        case errc::no_response_expected: return "broadcast or group request: no reply expected";
        case errc::fault_latched: return "fault latched after repeated failures; reset required";
        case errc::buffer_too_small: return "buffer too small for the telegram";
        case errc::invalid_argument: return "invalid argument for this protocol";
        case errc::busy: return "a transaction is already in progress";
        case errc::frame_gap: return "gap inside a telegram exceeds the protocol's limit";
        case errc::transport: return "transport error";
        case errc::out_of_range: return "out of range";
        }
        return "unknown ferrule error";
    }
};

inline const std::error_category& errc_category() noexcept {
    static const errc_category_t instance;
    return instance;
}

inline std::error_code make_error_code(errc e) noexcept {
    return {static_cast<int>(e), errc_category()};
}

} // namespace ferrule

template <>
struct std::is_error_code_enum<ferrule::errc> : std::true_type {};

namespace ferrule {

// A std::error_code kept in a session or a result<T>. Unlike std::error_code it is a literal
// type, so a session can be constant-initialised (constinit), and making an empty one calls
// no category function. Empty holds "no error", whatever its category was.
class stored_error {
public:
    constexpr stored_error() noexcept = default;
    stored_error(std::error_code ec) noexcept
        : value_(ec.value()), category_(ec ? &ec.category() : nullptr) {}
    // A non-zero value of `category` (no test for "no error" at run time).
    stored_error(int value, const std::error_category& category) noexcept
        : value_(value), category_(&category) {}
    stored_error(errc e) noexcept
        : value_(static_cast<int>(e)), category_(e == errc{} ? nullptr : &errc_category()) {}
    template <class E>
    requires std::is_error_code_enum_v<E> stored_error(E e)
    noexcept : stored_error(make_error_code(e)) {}

    constexpr explicit operator bool() const noexcept { return category_ != nullptr; }
    constexpr int value() const noexcept { return value_; }
    operator std::error_code() const noexcept {
        return category_ ? std::error_code(value_, *category_) : std::error_code();
    }
    friend bool operator==(const stored_error& a, const std::error_code& b) noexcept {
        return std::error_code(a) == b;
    }

private:
    int value_ = 0;
    const std::error_category* category_ = nullptr;
};

} // namespace ferrule
