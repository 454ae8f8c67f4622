// Modbus RTU ADU (SL §2.4, §2.5.1): [address][PDU][CRC lo][CRC hi], at most 256 bytes.
// CRC-16/MODBUS over address and PDU, low byte first (SL §2.5.1.2, §6.2.2).
//
// rtu_decoder frames by the length the function code predicts (expected_response_length /
// expected_request_length), as libmodbus and tokio-modbus do: the 1.5 / 3.5 character
// timers do not survive USB adapters and ptys (protocols/modbus_profibus.md §A.3). After a
// CRC error, or bytes that start no frame, it drops one byte and tries again from the next,
// so a frame behind garbage is still found.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/checksum.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/frame_scanner.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/modbus/constants.hpp"
#include "ferrule/modbus/pdu.hpp"

namespace ferrule::modbus {

// Completes an ADU whose PDU of `pdu_size` bytes is already in place at adu[1]: writes the
// address and the CRC; returns the ADU's size. adu must hold pdu_size + 3 bytes.
inline std::size_t seal_rtu(std::uint8_t address, std::uint8_t* adu,
                            std::size_t pdu_size) noexcept {
    adu[0] = address;
    const std::size_t n = pdu_size + 1;
    const std::uint16_t crc = crc16_modbus({adu, n});
    adu[n] = static_cast<std::uint8_t>(crc);
    adu[n + 1] = static_cast<std::uint8_t>(crc >> 8);
    return n + 2;
}

inline result<std::size_t> encode_rtu(std::uint8_t address, std::span<const std::uint8_t> pdu,
                                      std::span<std::uint8_t> out) noexcept {
    if (pdu.empty() || pdu.size() > max_pdu) return errc::invalid_argument;
    if (out.size() < pdu.size() + 3) return errc::buffer_too_small;
    for (std::size_t i = 0; i < pdu.size(); ++i) out[1 + i] = pdu[i];
    return seal_rtu(address, out.data(), pdu.size());
}

enum class rtu_frames : std::uint8_t { responses, requests, either };

namespace detail {
// RTU framing by length, once for rtu_decoder and rtu_receiver. It looks at the bytes
// on.buffered() (the front of a receive buffer) and tells `on` what they start with, until it
// needs more bytes (true) or `on` says stop (false):
//     bool on.garbage()        the first byte starts no frame: drop it
//     bool on.bad_crc()        the first byte starts a frame whose CRC fails: drop it
//     bool on.frame(n)         the first n bytes are a frame
// each returning whether to go on. `length` is the PDU length the function code predicts
// (0: need more bytes; no_frame: the bytes start no frame).
template <class On, class Length>
constexpr bool scan_rtu(On& on, bool requests, Length length) noexcept {
    while (on.buffered().size() >= 2) {
        const std::size_t n = length(on.buffered().subspan(1));
        if (n == 0) return true;
        if (n == no_frame) {
            // A request of an unknown function code waits for the silence after it
            // (whole_at_silence()), as long as it can still fit an ADU.
            if (requests && on.buffered().size() < max_rtu_adu) return true;
            if (!on.garbage()) return false;
            continue;
        }
        if (on.buffered().size() < n + 3) return true;
        if (crc16_modbus(on.buffered().first(n + 3)) != 0) {
            if (!on.bad_crc()) return false;
            continue;
        }
        if (!on.frame(n + 3)) return false;
    }
    return true;
}

// At the silence after them (SL §2.5.1.1), all buffered bytes are one request when its
// function code cannot be framed by length and its CRC checks (the server answers it with
// exception 01).
template <class Length>
constexpr bool whole_at_silence(std::span<const std::uint8_t> buf, bool requests,
                                Length length) noexcept {
    return requests && buf.size() >= 4 && length(buf.subspan(1)) == no_frame &&
           crc16_modbus(buf) == 0;
}
} // namespace detail

// Splits a byte stream into RTU frames. Feed it with
//     do { s = d.feed(in); in = in.subspan(s.consumed); … } while (s.what != status::need_more);
// need_more means every byte given is used and no frame is complete; after an error the
// decoder may still hold bytes that form a frame, which the next feed() (an empty span is
// fine) yields. Each CRC error is reported (errc::bad_checksum); a run of bytes that start no
// frame once (errc::malformed). Addresses are not filtered.
//
// rtu_decoder frames requests or responses of every function code, as chosen when it is
// made (tools that read a whole bus). A client's decoder is basic_rtu_decoder<Fs,
// rtu_frames::responses>: it frames only responses, and only those of the functions in Fs
// (see function_set); a server's frames only requests. Firmware then carries no other.

template <function_set Fs = all_functions, rtu_frames Frames = rtu_frames::either>
class basic_rtu_decoder : public frame_scanner<basic_rtu_decoder<Fs, Frames>, max_rtu_adu> {
    using base = frame_scanner<basic_rtu_decoder<Fs, Frames>, max_rtu_adu>;
    friend base;
    using base::buf_;
    using base::drop_failed;
    using base::drop_garbage;
    using base::frame_size_;
    using base::size_;
    using base::view;
    using base::yield;

public:
    enum class accept : std::uint8_t { responses, requests };
    using typename base::status;
    using typename base::step;

    basic_rtu_decoder() noexcept = default; // rtu_frames::either: responses
    explicit basic_rtu_decoder(accept a) noexcept requires(Frames == rtu_frames::either)
        : accept_(a) {}

    // The line has been silent for t3.5 (SL §2.5.1.1): no byte will complete what is
    // buffered. Call it like feed(), until need_more: it drops bytes from the front (one
    // errc::malformed per run) until the rest holds a frame or nothing is left, so a frame
    // behind a broken one is still found. In requests mode, buffered bytes of a function
    // code that cannot be framed by length are a frame when their CRC checks (the server
    // can answer it with exception 01).
    step finish() noexcept { return base::drain(); }

    // The frame just yielded (valid until the next feed(), finish() or reset()).
    std::uint8_t address() const noexcept { return frame_size_ ? buf_[0] : std::uint8_t{0}; }
    std::span<const std::uint8_t> pdu() const noexcept {
        if (frame_size_ == 0) return {};
        return {buf_.data() + 1, frame_size_ - 3};
    }
    std::span<const std::uint8_t> adu() const noexcept { return {buf_.data(), frame_size_}; }

private:
    // At the silence, a request of a function code that cannot be framed by length.
    bool whole_at_silence() const noexcept {
        return detail::whole_at_silence(view(size_), requests(), length_of());
    }

    constexpr bool requests() const noexcept {
        if constexpr (Frames == rtu_frames::either)
            return accept_ == accept::requests;
        else
            return Frames == rtu_frames::requests;
    }

    // Looks at the buffered bytes until a frame, a reported error, or the need for more.
    step scan() noexcept {
        // Each event ends the scan with its step, but a run of garbage reported already.
        struct on_event {
            basic_rtu_decoder& d;
            step s{};
            std::span<const std::uint8_t> buffered() const noexcept { return d.view(d.size_); }
            bool garbage() noexcept {
                if (!d.drop_garbage()) return true;
                s = {status::error, 0, errc::malformed};
                return false;
            }
            bool bad_crc() noexcept {
                d.drop_failed();
                s = {status::error, 0, errc::bad_checksum};
                return false;
            }
            bool frame(std::size_t n) noexcept {
                s = d.yield(n);
                return false;
            }
        } on{*this};
        detail::scan_rtu(on, requests(), length_of());
        return on.s;
    }

    // The PDU length rule of this decoder's mode.
    auto length_of() const noexcept {
        return [requests = requests()](std::span<const std::uint8_t> pdu) {
            return requests ? expected_request_length(pdu) : response_length(pdu);
        };
    }

    // Responses of the public function codes outside `function` too: rtu_decoder, for tools
    // that read a whole bus. A client frames only the responses to what it can send.
    static constexpr bool others = Frames == rtu_frames::either && Fs.mask == all_functions.mask;
    static constexpr std::size_t response_length(std::span<const std::uint8_t> pdu) noexcept {
        return expected_response_length<Fs, others>(pdu);
    }

    accept accept_ = accept::responses;
};

using rtu_decoder = basic_rtu_decoder<>;

// The receive buffer of an RTU session: bytes are pushed one at a time and framed as
// basic_rtu_decoder frames them, but what they hold goes straight to the session `h` (no
// step protocol, so firmware carries less code):
//     bool h.on_frame(address, pdu)  a frame whose CRC checks; true: go on with the bytes
//                                    behind it, false: stop (the frame and the bytes behind
//                                    it stay until clear(); push no more before)
//     void h.on_garbage(errc)        a byte dropped from the front: errc::bad_checksum when
//                                    it began a frame whose CRC failed, errc::malformed when
//                                    it began none
// Frames: requests (a server: a request of an unknown function code waits for the silence
// after it, finish(), as long as it can still fit an ADU) or responses of the functions in Fs
// (a client).
template <rtu_frames Frames, function_set Fs = all_functions>
requires(Frames != rtu_frames::either) class rtu_receiver {
public:
    template <class H>
    void push(std::uint8_t b, H& h) noexcept {
        if (size_ == buf_.size()) drop(errc::malformed, h);
        buf_[size_++] = b;
        scan(h);
    }

    // The line has been silent for t3.5 (SL §2.5.1.1): no byte will complete what is
    // buffered. Bytes are dropped from the front until the rest holds a frame or nothing is
    // left; a request of a function code that cannot be framed by length is a frame when its
    // CRC checks (the server answers it with exception 01).
    template <class H>
    void finish(H& h) noexcept {
        while (size_ > 0) {
            if (detail::whole_at_silence(view(size_), requests, length)) {
                if (!frame(size_, h)) return;
                continue;
            }
            drop(errc::malformed, h);
            if (!scan(h)) return;
        }
    }

    bool empty() const noexcept { return size_ == 0; }
    void clear() noexcept { size_ = 0; }

private:
    static constexpr bool requests = Frames == rtu_frames::requests;

    std::span<const std::uint8_t> view(std::size_t n) const noexcept { return {buf_.data(), n}; }
    // The PDU's length from its first bytes: 0 = need more, no_frame = cannot be framed.
    // A lambda, not a function: its own type keeps each receiver's framing inline.
    static constexpr auto length = [](std::span<const std::uint8_t> pdu) noexcept {
        if constexpr (requests)
            return expected_request_length(pdu);
        else
            return expected_response_length<Fs, false>(pdu);
    };

    // False when the session stopped at a frame.
    template <class H>
    bool scan(H& h) noexcept {
        scan_with<H> on{*this, h};
        return detail::scan_rtu(on, requests, length);
    }

    // Each event goes to the session at once; only a frame it does not take stops the scan.
    template <class H>
    struct scan_with {
        rtu_receiver& r;
        H& h;
        std::span<const std::uint8_t> buffered() const noexcept { return r.view(r.size_); }
        bool garbage() noexcept {
            r.drop(errc::malformed, h);
            return true;
        }
        bool bad_crc() noexcept {
            r.drop(errc::bad_checksum, h);
            return true;
        }
        bool frame(std::size_t n) noexcept { return r.frame(n, h); }
    };

    template <class H>
    bool frame(std::size_t n, H& h) noexcept {
        if (!h.on_frame(buf_[0], view(n).subspan(1, n - 3))) return false;
        shift(n);
        return true;
    }

    template <class H>
    void drop(errc why, H& h) noexcept {
        shift(1);
        h.on_garbage(why);
    }

    void shift(std::size_t n) noexcept {
        for (std::size_t i = n; i < size_; ++i) buf_[i - n] = buf_[i];
        size_ -= n;
    }

    std::array<std::uint8_t, max_rtu_adu> buf_{};
    std::size_t size_ = 0;
};

} // namespace ferrule::modbus
