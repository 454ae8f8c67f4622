// `ferrule decode`: what the per-protocol decoders share.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace ferrule::cli {

// --file: how many bytes in a row may hold no telegram before decoding stops. The least, 8 KiB,
// holds the longest telegram of any protocol (an Extended MEMOBUS message of 2044 words, 4108
// bytes) and about as many bytes of noise before it.
inline constexpr std::size_t min_max_junk = 8192;

struct decode_options {
    std::string protocol;
    std::vector<std::string> hex;
    std::string file;
    bool json = false;
    std::size_t max_junk = min_max_junk; // --max-junk
};

// Bytes that form no telegram, with the reason.
void print_skipped(const decode_options& o, std::size_t offset, std::span<const std::uint8_t> b,
                   const std::string& reason);

// One protocol's decoder of a capture that comes in pieces. decode() is given `bytes`, the
// capture from offset `offset` on: those it has not done with yet and those read since, and
// whether the capture ends with them. It prints the telegrams it can tell and the bytes
// between them, and returns the offset up to which it is done: the bytes before it are not
// given again. A telegram's bytes are given whole however the capture is cut, so the output
// does not depend on the pieces.
class capture_decoder {
public:
    virtual ~capture_decoder() = default;
    virtual std::size_t decode(std::span<const std::uint8_t> bytes, std::size_t offset,
                               bool end) = 0;
    // Every byte so far belonged to a good telegram.
    bool clean() const noexcept { return clean_; }

protected:
    bool clean_ = true;
};

// The bytes of `bytes` (the capture from `offset` on) from offset `from` to offset `to`.
inline std::span<const std::uint8_t> capture_span(std::span<const std::uint8_t> bytes,
                                                  std::size_t offset, std::size_t from,
                                                  std::size_t to) {
    return bytes.subspan(from - offset, to - from);
}

std::unique_ptr<capture_decoder> movilink_capture(const decode_options& o);
std::unique_ptr<capture_decoder> dimetix_capture(const decode_options& o);
std::unique_ptr<capture_decoder> lecom_capture(const decode_options& o);
std::unique_ptr<capture_decoder> modbus_rtu_capture(const decode_options& o);
std::unique_ptr<capture_decoder> modbus_tcp_capture(const decode_options& o);
std::unique_ptr<capture_decoder> profibus_capture(const decode_options& o);
std::unique_ptr<capture_decoder> memobus_capture(const decode_options& o);

} // namespace ferrule::cli
