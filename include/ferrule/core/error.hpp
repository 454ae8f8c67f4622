// One error model for all of ferrule: ferrule::error, a value and a pointer to a constexpr
// error_domain (in the spirit of P1028 status_code). It is constexpr and trivially copyable,
// its message() is a const char*, and nothing about it allocates, so firmware keeps and
// reports errors without libstdc++'s <system_error>. ferrule::errc covers transport and
// framing; each protocol adds a domain that keeps the device's own code (movilink/error.hpp
// and friends).
//
// Host code gets a std::error_code by converting implicitly (the bridge at the end of this
// header): one std::error_category per domain, built on first use, with the domain's name
// and texts. Nothing of the bridge is instantiated unless host code converts.
#pragma once

#include <cstddef>
#include <type_traits>

// The host bridge only: nothing below instantiates these unless an error is converted.
#include <atomic>
#include <cstring>
#include <string>
#include <system_error>

namespace ferrule {

// What the values of one kind of error mean: one constexpr object per domain.
//
// FERRULE_NO_ERROR_TEXTS (a compile definition, the same in every translation unit of a
// program) leaves the texts out: a domain then keeps only its name, which message() returns,
// and no text function or string is linked. For firmware that reports error values, never
// texts; the values, comparisons and the device's own codes are unchanged.
struct error_domain {
    using message_fn = const char* (*)(int value) noexcept;
    using format_fn = std::size_t (*)(int value, char* buf, std::size_t size) noexcept;

    constexpr error_domain(const char* domain_name, message_fn text,
                           format_fn full_text = nullptr) noexcept
        : name(domain_name)
#if !defined(FERRULE_NO_ERROR_TEXTS)
          ,
          message(text), format(full_text)
#endif
    {
        (void)text;
        (void)full_text;
    }

    const char* name;
    // The fixed text of a value (never nullptr when texts are built in).
    message_fn message = nullptr;
    // Optional, for values a fixed text cannot say in full (MOVILINK's class, code and
    // additional code): writes the whole text into buf, NUL-terminated and cut to size, and
    // returns its length. Allocation-free.
    format_fn format = nullptr;
};

// An enum whose values are errors of one domain: specialise this to true and give the enum
// an ADL-found `constexpr error make_error(E) noexcept` (like std::is_error_code_enum).
template <class E>
struct is_error_enum : std::false_type {};
template <class E>
inline constexpr bool is_error_enum_v = is_error_enum<E>::value;

class error {
public:
    constexpr error() noexcept = default; // no error
    // A value of `domain`; 0 is "no error" in every domain.
    constexpr error(int value, const error_domain& domain) noexcept
        : value_(value), domain_(value == 0 ? nullptr : &domain) {}
    template <class E>
    requires is_error_enum_v<E>
    constexpr error(E e) noexcept : error(make_error(e)) {}

    // A value of 0 never has a domain (the constructor sees to it), so the value alone tells:
    // GCC does not take `&domain != nullptr` as a constant under -fsanitize.
    constexpr explicit operator bool() const noexcept { return value_ != 0; }
    constexpr int value() const noexcept { return value_; }
    // nullptr for no error.
    constexpr const error_domain* domain() const noexcept { return domain_; }
    constexpr const char* name() const noexcept { return value_ != 0 ? domain_->name : "none"; }
    constexpr const char* message() const noexcept {
        if (value_ == 0) return "no error";
#if defined(FERRULE_NO_ERROR_TEXTS)
        return domain_->name;
#else
        return domain_->message(value_);
#endif
    }
    // The full text into buf (the domain's formatter, or message()); returns its length.
    std::size_t format(char* buf, std::size_t size) const noexcept {
        if (size == 0) return 0;
        if (domain_ && domain_->format) return domain_->format(value_, buf, size);
        const char* text = message();
        std::size_t n = 0;
        for (; text[n] != '\0' && n + 1 < size; ++n) buf[n] = text[n];
        buf[n] = '\0';
        return n;
    }

    friend constexpr bool operator==(const error&, const error&) noexcept = default;

    // Host bridge: the same error as a std::error_code (category name = domain name, message
    // = the domain's full text).
    operator std::error_code() const noexcept;

private:
    int value_ = 0;
    const error_domain* domain_ = nullptr;
};

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

struct errc_domain_t {
    static constexpr const char* message(int ev) noexcept {
        switch (static_cast<errc>(ev)) {
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

inline constexpr error_domain errc_domain{"ferrule", &errc_domain_t::message};

constexpr error make_error(errc e) noexcept {
    return {static_cast<int>(e), errc_domain};
}
template <>
struct is_error_enum<errc> : std::true_type {};

namespace detail {

// Appends text and numbers to a char buffer, always NUL-terminated, cut at its end: the
// domains' formatters, without snprintf (which would pull printf into firmware).
class text_writer {
public:
    constexpr text_writer(char* buf, std::size_t size) noexcept : buf_(buf), size_(size) {
        buf_[0] = '\0';
    }
    constexpr text_writer& put(const char* s) noexcept {
        while (*s != '\0') put(*s++);
        return *this;
    }
    constexpr text_writer& put(char c) noexcept {
        if (n_ + 1 < size_) {
            buf_[n_++] = c;
            buf_[n_] = '\0';
        }
        return *this;
    }
    constexpr text_writer& put_decimal(unsigned v) noexcept {
        char digits[10];
        int k = 0;
        do {
            digits[k++] = static_cast<char>('0' + v % 10);
            v /= 10;
        } while (v != 0);
        while (k > 0) put(digits[--k]);
        return *this;
    }
    constexpr text_writer& put_hex(unsigned v, int digits) noexcept {
        for (int shift = 4 * (digits - 1); shift >= 0; shift -= 4)
            put("0123456789ABCDEF"[(v >> shift) & 0xFu]);
        return *this;
    }
    constexpr std::size_t size() const noexcept { return n_; }

private:
    char* buf_;
    std::size_t size_;
    std::size_t n_ = 0;
};

} // namespace detail

// ---------------------------------------------------------------------------------------------
// Host bridge to std::error_code. Used by host code, the CLI and the tests only; firmware never
// converts, so none of it (categories, std::string, the registry) ends up in an image.

// Errors of the operating system (errno values) that host byte streams report in io_result.
struct system_domain_t {
    static const char* message(int ev) noexcept { return std::strerror(ev); }
};
inline constexpr error_domain system_domain{"system", &system_domain_t::message};

namespace detail {

class domain_category final : public std::error_category {
public:
    explicit domain_category(const error_domain& d) noexcept : domain_(d) {}
    const char* name() const noexcept override { return domain_.name; }
    std::string message(int ev) const override {
        if (!domain_.format) return error(ev, domain_).message();
        char buf[256];
        const std::size_t n = domain_.format(ev, buf, sizeof buf);
        return std::string(buf, n);
    }
    const error_domain& domain() const noexcept { return domain_; }

private:
    const error_domain& domain_;
};

// One category per domain for the whole program, made on first use. Nodes are never freed:
// std::error_code keeps a pointer to its category.
class category_registry {
public:
    struct node {
        domain_category category;
        const node* next;
    };

    static const std::error_category& category_of(const error_domain& d) {
        if (const node* n = find(d)) return n->category;
        lock_guard hold;
        if (const node* n = find(d)) return n->category;
        const node* n = new node{domain_category(d), head().load(std::memory_order_relaxed)};
        head().store(n, std::memory_order_release);
        return n->category;
    }
    // The domain whose category `c` is, or nullptr.
    static const error_domain* domain_of(const std::error_category& c) noexcept {
        for (const node* n = head().load(std::memory_order_acquire); n; n = n->next)
            if (&n->category == &c) return &n->category.domain();
        return nullptr;
    }

private:
    static std::atomic<const node*>& head() noexcept {
        static std::atomic<const node*> first{nullptr};
        return first;
    }
    static const node* find(const error_domain& d) noexcept {
        for (const node* n = head().load(std::memory_order_acquire); n; n = n->next)
            if (&n->category.domain() == &d) return n;
        return nullptr;
    }
    struct lock_guard {
        static std::atomic_flag& flag() noexcept {
            static std::atomic_flag f = ATOMIC_FLAG_INIT;
            return f;
        }
        lock_guard() noexcept {
            while (flag().test_and_set(std::memory_order_acquire)) {
            }
        }
        ~lock_guard() { flag().clear(std::memory_order_release); }
    };
};

} // namespace detail

inline error::operator std::error_code() const noexcept {
    if (!domain_) return {};
    if (domain_ == &system_domain) return {value_, std::system_category()};
    return {value_, detail::category_registry::category_of(*domain_)};
}

// The std::error_category of a domain (host code: ec.category() == category_of(domain)).
inline const std::error_category& category_of(const error_domain& d) {
    if (&d == &system_domain) return std::system_category();
    return detail::category_registry::category_of(d);
}

// A std::error_code as a ferrule::error: back to its domain if it came from one, errno values
// (system and generic category) as system_domain, anything else as errc::transport.
inline error from_error_code(const std::error_code& ec) noexcept {
    if (!ec) return {};
    if (const error_domain* d = detail::category_registry::domain_of(ec.category()))
        return {ec.value(), *d};
    if (ec.category() == std::system_category() || ec.category() == std::generic_category())
        return {ec.value(), system_domain};
    return errc::transport;
}

inline const std::error_category& errc_category() {
    return category_of(errc_domain);
}
inline std::error_code make_error_code(errc e) noexcept {
    return error(e);
}

} // namespace ferrule

template <>
struct std::is_error_code_enum<ferrule::errc> : std::true_type {};
