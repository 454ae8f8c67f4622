// LECOM-A/B telegrams (S1 p.8-20…8-24, S2 §6):
//
//   RECEIVE (read)    EOT AD1 AD2 C1 C2 ENQ
//   SEND (write)      EOT AD1 AD2 STX C1 C2 V1…Vn ETX BCC
//   data reply        STX C1 C2 V1…Vn ETX BCC
//   fault reply       STX C1 C2 ? ETX BCC       checksum / parity fault seen by the drive
//   no-code reply     STX C1 C2 EOT             the code does not exist (no ETX, no BCC)
//   ACK / NAK         06 / 15                   answer to SEND
//   bare EOT / NAK    answer to RECEIVE of the 4900 drives (LECOM paper; lecom.md §1.4)
//
// C1 C2 is `!CCCCSS` with extended addressing. BCC = XOR of the bytes after STX up to and
// including ETX; exactly one byte follows ETX, whatever its value (S1 p.8-20, lecom.md §1.6).
//
// frame_decoder splits a byte stream into telegrams (framing only); parse_request() and
// parse_reply() read one telegram and check its BCC. encode() writes any telegram,
// encode_request() a request straight into a master's buffer.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/checksum.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/lecom/code.hpp"
#include "ferrule/lecom/constants.hpp"
#include "ferrule/lecom/value.hpp"

namespace ferrule::lecom {

// EOT AD1 AD2 STX !CCCCSS value ETX BCC
inline constexpr std::size_t max_request_length = 4 + extended_code_length + max_value_length + 2;
// STX !CCCCSS value ETX BCC
inline constexpr std::size_t max_reply_length = 1 + extended_code_length + max_value_length + 2;
inline constexpr std::size_t max_frame_length = max_request_length;

enum class frame_kind : std::uint8_t {
    receive, // EOT AD1 AD2 code ENQ
    send,    // EOT AD1 AD2 STX code value ETX BCC
    data,    // STX code value ETX BCC
    fault,   // STX code ? ETX BCC
    no_code, // STX code EOT
    ack,     // ACK
    nak,     // NAK
    eot,     // bare EOT
};

constexpr bool is_request(frame_kind k) noexcept {
    return k == frame_kind::receive || k == frame_kind::send;
}

struct frame {
    frame_kind kind = frame_kind::ack;
    std::uint8_t address = 0; // requests
    code_address code{};      // receive, send, data, fault, no_code
    lecom::value value{};     // send, data
};

namespace detail {
constexpr std::size_t put_address(std::uint8_t address, std::uint8_t* out) noexcept {
    out[0] = eot;
    out[1] = static_cast<std::uint8_t>('0' + address / 10);
    out[2] = static_cast<std::uint8_t>('0' + address % 10);
    return 3;
}

// STX code text ETX BCC from `out[0]`; the BCC covers code … ETX. 0 when `*v` cannot be
// encoded.
constexpr std::size_t put_text(const code_address& c, const value* v, bool fault,
                               std::uint8_t* out) noexcept {
    std::uint8_t* p = out;
    *p++ = stx;
    p += encode_code(c, p);
    if (fault) *p++ = fault_mark;
    if (v) {
        const std::size_t n = encode_value(*v, p);
        if (n == 0) return 0;
        p += n;
    }
    *p++ = etx;
    *p = xor_bcc({out + 1, p});
    return static_cast<std::size_t>(p + 1 - out);
}
} // namespace detail

// Can a RECEIVE (`v` null) or a SEND of `*v` go to `address` with code `c`? What encode()
// refuses of a request is refused here: an address beyond 99, a RECEIVE to a group address,
// a code that cannot be addressed, a value the factories of value.hpp would not have made.
constexpr bool is_valid_request(std::uint8_t address, const code_address& c,
                                const value* v) noexcept {
    return is_valid(c) &&
           (v ? is_valid_address(address) && detail::is_encodable(*v) : is_unit_address(address));
}

// Writes the RECEIVE (`v` null) or SEND of `*v` to `out` (max_request_length bytes) and
// returns its length; 0 when !is_valid_request(address, c, v), and `out` may then hold the
// start of a telegram.
constexpr std::size_t encode_request(std::uint8_t address, const code_address& c, const value* v,
                                     std::uint8_t* out) noexcept {
    // The value is checked as it is written.
    if (!is_valid(c) || !(v ? is_valid_address(address) : is_unit_address(address))) return 0;
    std::size_t n = detail::put_address(address, out);
    if (v) {
        const std::size_t text = detail::put_text(c, v, false, out + n);
        return text == 0 ? 0 : n + text;
    }
    n += encode_code(c, out + n);
    out[n] = enq;
    return n + 1;
}

// Writes a telegram (request or reply) to `out`. Checks what the protocol cannot express:
// an address beyond 99, a standard code beyond 6229 or with a subcode, a RECEIVE to a group
// address (nothing would answer it, S1 p.8-24), a value the factories of value.hpp would not
// have made.
inline result<std::size_t> encode(const frame& f, std::span<std::uint8_t> out) noexcept {
    std::array<std::uint8_t, max_frame_length> buf{};
    std::uint8_t* p = buf.data();
    if (is_request(f.kind)) {
        const std::size_t n =
            encode_request(f.address, f.code, f.kind == frame_kind::send ? &f.value : nullptr, p);
        if (n == 0) return errc::invalid_argument;
        p += n;
    } else {
        const bool has_code =
            f.kind != frame_kind::ack && f.kind != frame_kind::nak && f.kind != frame_kind::eot;
        if (has_code && !is_valid(f.code)) return errc::invalid_argument;
        if (f.kind == frame_kind::data && !detail::is_encodable(f.value))
            return errc::invalid_argument;
        switch (f.kind) {
        case frame_kind::data: p += detail::put_text(f.code, &f.value, false, p); break;
        case frame_kind::fault: p += detail::put_text(f.code, nullptr, true, p); break;
        case frame_kind::no_code:
            *p++ = stx;
            p += encode_code(f.code, p);
            *p++ = eot;
            break;
        case frame_kind::ack: *p++ = ack; break;
        case frame_kind::nak: *p++ = nak; break;
        default: *p++ = eot; break; // bare EOT (the requests are above)
        }
    }
    const auto n = static_cast<std::size_t>(p - buf.data());
    if (out.size() < n) return errc::buffer_too_small;
    for (std::size_t i = 0; i < n; ++i) out[i] = buf[i];
    return n;
}

inline frame read_request(std::uint8_t address, const code_address& c) noexcept {
    return {frame_kind::receive, address, c, {}};
}
inline frame write_request(std::uint8_t address, const code_address& c, const value& v) noexcept {
    return {frame_kind::send, address, c, v};
}

namespace detail {
// STX code text ETX BCC, exactly, into `f`: the code, and `?` (kind fault) or the value
// (kind left as it is). Checks the BCC; errc{} when it is such a block.
constexpr errc read_block(std::span<const std::uint8_t> in, frame& f) noexcept {
    const std::size_t n = in.size();
    if (n < 4 || in[0] != stx || in[n - 2] != etx) return errc::malformed;
    // The text between STX and ETX is 7-bit and printable (the BCC after ETX is not).
    for (std::size_t i = 1; i + 2 < n; ++i)
        if (in[i] < 0x20 || in[i] > 0x7F) return errc::malformed;
    if (xor_bcc(in.subspan(1, n - 2)) != in[n - 1]) return errc::bad_checksum;
    const auto text = in.subspan(1, n - 3);
    if (!read_code(text, f.code)) return errc::malformed;
    const auto rest = text.subspan(f.code.length());
    if (rest.size() == 1 && rest[0] == fault_mark) {
        f.kind = frame_kind::fault;
        return {};
    }
    return read_value(rest, f.value) ? errc{} : errc::malformed;
}

// A reply telegram into `f`, a default frame; errc{} when it is one, else what parse_reply()
// gives.
constexpr errc read_reply(std::span<const std::uint8_t> in, frame& f) noexcept {
    const std::size_t n = in.size();
    if (n == 1) {
        switch (in[0]) {
        case ack: f.kind = frame_kind::ack; return {};
        case nak: f.kind = frame_kind::nak; return {};
        case eot: f.kind = frame_kind::eot; return {};
        default: return errc::malformed;
        }
    }
    // STX code EOT; a data reply may end in a BCC of 04 too, but has ETX before it.
    if (n > 2 && in[0] == stx && in[n - 1] == eot && in[n - 2] != etx) {
        f.kind = frame_kind::no_code;
        return read_code(in.subspan(1, n - 2), f.code) && f.code.length() == n - 2
                   ? errc{}
                   : errc::malformed;
    }
    f.kind = frame_kind::data;
    return read_block(in, f);
}
} // namespace detail

// A reply telegram (as frame_decoder yields it): data, fault, no_code, ack, nak or eot.
inline result<frame> parse_reply(std::span<const std::uint8_t> in) noexcept {
    frame f;
    if (const errc e = detail::read_reply(in, f); e != errc{}) return e;
    return f;
}

// A request telegram: RECEIVE or SEND.
inline result<frame> parse_request(std::span<const std::uint8_t> in) noexcept {
    if (in.size() < 6 || in[0] != eot || in[1] < '0' || in[1] > '9' || in[2] < '0' || in[2] > '9')
        return errc::malformed;
    frame f;
    f.address = static_cast<std::uint8_t>((in[1] - '0') * 10 + (in[2] - '0'));
    if (in[3] == stx) {
        f.kind = frame_kind::send;
        if (const errc e = detail::read_block(in.subspan(3), f); e != errc{}) return e;
        if (f.kind != frame_kind::send) return errc::malformed; // `?` is no value
        return f;
    }
    f.kind = frame_kind::receive;
    if (in.back() != enq || !detail::read_code(in.subspan(3, in.size() - 4), f.code) ||
        f.code.length() != in.size() - 4)
        return errc::malformed;
    return f;
}

inline result<frame> parse_frame(std::span<const std::uint8_t> in) noexcept {
    return !in.empty() && in[0] == eot && in.size() > 1 ? parse_request(in) : parse_reply(in);
}

// Splits bytes into telegrams as they arrive. Which telegrams it expects decides what a
// lone EOT is: the 4900's "unknown code" reply (replies), the start of a request (requests),
// or, in both mode, whatever the next byte makes of it (two digits: a request).
//
// Bytes that cannot be a telegram are skipped; each run of them, and each telegram cut
// short by a control character or grown beyond max_frame_length, is reported once as
// errc::malformed. A control character that cuts a telegram short starts the next one.
class frame_decoder {
public:
    enum class accept : std::uint8_t { replies, requests, both };
    enum class status : std::uint8_t { need_more, frame, error };
    struct step {
        status what = status::need_more;
        std::size_t consumed = 0; // bytes of the input used; feed the rest again
        ferrule::error ec{};
    };

    explicit frame_decoder(accept a = accept::replies) noexcept : accept_(a) {}

    step feed(std::span<const std::uint8_t> in) noexcept {
        if (complete_) {
            size_ = 0;
            complete_ = false;
        }
        for (std::size_t i = 0; i < in.size(); ++i) {
            const std::uint8_t b = in[i];
            switch (state_) {
            case state::idle:
                if (start(b)) {
                    if (state_ == state::idle) return yield(i + 1); // ACK, NAK, reply EOT
                    continue;
                }
                ++skipped_;
                if (!garbage_) {
                    garbage_ = true;
                    return {status::error, i + 1, errc::malformed};
                }
                continue;
            case state::after_eot: // both mode: request or bare EOT?
                if (is_digit(b)) {
                    push(b);
                    state_ = state::request_address;
                    continue;
                }
                state_ = state::idle;
                return yield(i); // b is looked at again
            case state::request_address:
                if (!is_digit(b)) return cut(i);
                push(b);
                if (size_ == 3) state_ = state::request_body; // EOT AD1 AD2
                continue;
            case state::request_body:
                if (size_ == 3 && b == stx) {
                    push(b);
                    state_ = state::text;
                    continue;
                }
                if (size_ == buf_.size()) return cut(i); // no room left, not even for ENQ
                if (b == enq && size_ > 3) {
                    push(b);
                    state_ = state::idle;
                    return yield(i + 1);
                }
                if (!is_text(b)) return cut(i);
                push(b);
                continue;
            case state::text:
                if (b == etx) {
                    push(b);
                    state_ = state::bcc;
                    continue;
                }
                // STX code EOT: the code does not exist (only in a reply).
                if (b == eot && !request_ && size_ == 1 + code_length()) {
                    push(b);
                    state_ = state::idle;
                    return yield(i + 1);
                }
                if (!is_text(b) || size_ + 2 >= buf_.size()) return cut(i);
                push(b);
                continue;
            case state::bcc: // exactly one byte, whatever its value
                push(b);
                state_ = state::idle;
                return yield(i + 1);
            }
        }
        return {status::need_more, in.size(), {}};
    }

    // End of input (a capture's end, or a reply timeout): a pending lone EOT (both mode)
    // is a telegram of its own; an unfinished telegram is malformed.
    step finish() noexcept {
        if (complete_) {
            size_ = 0;
            complete_ = false;
        }
        if (state_ == state::after_eot) {
            state_ = state::idle;
            return yield(0);
        }
        if (state_ != state::idle) return cut(0);
        return {};
    }

    // The telegram just yielded (valid until the next feed()).
    std::span<const std::uint8_t> frame() const noexcept {
        return {buf_.data(), complete_ ? size_ : std::size_t{0}};
    }
    bool in_frame() const noexcept { return state_ != state::idle; }
    // Bytes dropped as garbage or as parts of broken telegrams.
    std::size_t skipped() const noexcept { return skipped_; }
    void reset() noexcept {
        state_ = state::idle;
        size_ = 0;
        complete_ = false;
        garbage_ = false;
    }

private:
    enum class state : std::uint8_t { idle, after_eot, request_address, request_body, text, bcc };

    static constexpr bool is_digit(std::uint8_t b) noexcept { return b >= '0' && b <= '9'; }
    // Characters of a code field or value: 7-bit, no control characters (C2 may be 0x7F).
    static constexpr bool is_text(std::uint8_t b) noexcept { return b >= 0x20 && b <= 0x7F; }

    std::size_t code_length() const noexcept {
        const std::size_t first = request_ ? 4 : 1; // after STX
        return size_ > first && buf_[first] == extended_mark ? extended_code_length
                                                             : standard_code_length;
    }

    // Idle and `b` arrives: does it start a telegram we accept?
    bool start(std::uint8_t b) noexcept {
        const bool replies = accept_ != accept::requests;
        if (b == ack || b == nak) {
            if (!replies) return false;
            push(b);
            return true;
        }
        if (b == stx && replies) {
            garbage_ = false;
            request_ = false;
            push(b);
            state_ = state::text;
            return true;
        }
        if (b == eot) {
            garbage_ = false;
            request_ = true;
            push(b);
            state_ = accept_ == accept::replies    ? state::idle
                     : accept_ == accept::requests ? state::request_address
                                                   : state::after_eot;
            return true;
        }
        return false;
    }

    void push(std::uint8_t b) noexcept { buf_[size_++] = b; }

    step yield(std::size_t consumed) noexcept {
        complete_ = true;
        garbage_ = false;
        return {status::frame, consumed, {}};
    }

    // The telegram so far is broken by in[i], which is looked at again if it can start one.
    step cut(std::size_t i) noexcept {
        skipped_ += size_;
        size_ = 0;
        state_ = state::idle;
        garbage_ = true; // reported: bytes skipped right after it belong to the same fault
        return {status::error, i, errc::malformed};
    }

    std::array<std::uint8_t, max_frame_length> buf_{};
    std::size_t size_ = 0;
    std::size_t skipped_ = 0;
    accept accept_;
    state state_ = state::idle;
    bool complete_ = false;
    bool garbage_ = false; // a run of skipped bytes has been reported
    bool request_ = false; // the telegram began with EOT
};

} // namespace ferrule::lecom
