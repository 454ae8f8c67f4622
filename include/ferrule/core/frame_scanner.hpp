// frame_scanner: the buffer and the stepping that ferrule's length-framed decoders share
// (modbus::rtu_decoder and tcp_decoder, profibus::fdl_decoder, memobus::message_decoder).
// A decoder derives from frame_scanner<Decoder, Capacity> and gives it
//     step scan() noexcept                   look at the buffered bytes: a frame (yield()),
//                                            an error, or the need for more
// and, to take more than one byte before the next scan(), `static constexpr bool reads_ahead`
// with std::size_t wanted() const noexcept (how many). A decoder of a serial line, where
// silence ends what is buffered, calls drain() from its finish(), and may give it
//     bool whole_at_silence() const noexcept  all buffered bytes are one frame when the line
//                                             is silent (a frame its length rule cannot end)
// and reads its frame from the front of the buffer. Feed it with
//     do { s = d.feed(in); in = in.subspan(s.consumed); … } while (s.what != status::need_more);
// need_more means every byte given is used and no frame is complete; after an error the
// decoder may still hold bytes that form a frame, which the next feed() (an empty span is
// fine) yields.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/error.hpp"

namespace ferrule {

template <class Decoder, std::size_t Capacity>
class frame_scanner {
public:
    enum class status : std::uint8_t { need_more, frame, error };
    struct step {
        status what = status::need_more;
        std::size_t consumed = 0; // bytes of the input used; feed the rest again
        ferrule::error ec{};
    };

    step feed(std::span<const std::uint8_t> in) noexcept {
        take_frame();
        if (size_ > 0) {
            const step s = self().scan();
            if (s.what != status::need_more) return s;
        }
        if constexpr (requires { Decoder::reads_ahead; }) {
            // As many bytes at once as the decoder wants (a header, then the rest).
            std::size_t used = 0;
            while (used < in.size()) {
                const std::size_t n = std::min(in.size() - used, self().wanted());
                for (std::size_t i = 0; i < n; ++i) buf_[size_ + i] = in[used + i];
                size_ += n;
                used += n;
                step s = self().scan();
                if (s.what != status::need_more) {
                    s.consumed = used;
                    return s;
                }
            }
        } else {
            for (std::size_t i = 0; i < in.size(); ++i) {
                buf_[size_++] = in[i];
                step s = self().scan();
                if (s.what != status::need_more) {
                    s.consumed = i + 1;
                    return s;
                }
            }
        }
        return {status::need_more, in.size(), {}};
    }

    void reset() noexcept {
        size_ = frame_size_ = 0;
        garbage_ = false;
    }
    // Bytes are buffered that may become a frame.
    bool in_frame() const noexcept { return size_ > frame_size_; }
    // Bytes dropped: garbage, bytes of frames that failed their check.
    std::size_t skipped() const noexcept { return skipped_; }

protected:
    std::span<const std::uint8_t> view(std::size_t n) const noexcept { return {buf_.data(), n}; }

    // The line has been silent: no byte will complete what is buffered. Called like feed()
    // until need_more, it drops bytes from the front (one errc::malformed per run) until the
    // rest holds a frame or nothing is left, so a frame behind a broken one is still found.
    step drain() noexcept {
        take_frame();
        for (;;) {
            const step s = self().scan();
            if (s.what != status::need_more) return s;
            if (size_ == 0) break;
            if constexpr (requires(const Decoder& d) { d.whole_at_silence(); }) {
                if (self().whole_at_silence()) return yield(size_);
            }
            if (drop_garbage()) return {status::error, 0, errc::malformed};
        }
        garbage_ = false;
        return {};
    }

    // The previous frame's bytes leave the buffer; bytes behind it are looked at again.
    void take_frame() noexcept {
        if (frame_size_ == 0) return;
        for (std::size_t i = frame_size_; i < size_; ++i) buf_[i - frame_size_] = buf_[i];
        size_ -= frame_size_;
        frame_size_ = 0;
    }

    // Drops the first byte, which starts no frame, so the next scan() starts from the one
    // after it; true when this is to be reported: a run of such bytes is reported once.
    bool drop_garbage() noexcept {
        shift();
        const bool report = !garbage_;
        garbage_ = true;
        return report;
    }
    // Drops the first byte of a frame that failed its check (CRC, FCS): always reported.
    void drop_failed() noexcept {
        shift();
        garbage_ = false;
    }

    // The first n buffered bytes are a frame.
    step yield(std::size_t n) noexcept {
        frame_size_ = n;
        garbage_ = false;
        return {status::frame, 0, {}};
    }

    std::array<std::uint8_t, Capacity> buf_{};
    std::size_t size_ = 0;       // bytes buffered
    std::size_t frame_size_ = 0; // a frame was yielded: its bytes at the front
    std::size_t skipped_ = 0;
    bool garbage_ = false; // a run of dropped bytes has been reported

private:
    Decoder& self() noexcept { return static_cast<Decoder&>(*this); }

    void shift() noexcept {
        for (std::size_t i = 1; i < size_; ++i) buf_[i - 1] = buf_[i];
        --size_;
        ++skipped_;
    }
};

} // namespace ferrule
