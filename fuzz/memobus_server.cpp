// libFuzzer target: memobus::server, one controller channel, on a small register_image.
//
// The input (read through FuzzedDataProvider) picks the channel_config (area offsets, the
// write range, the data order) and the image's contents, then up to 64 messages, each one
// of: a command built with encode_command() from fields of the input (every SFC, in the
// channel's data order or now and then the other), maybe with its type byte changed or one
// byte flipped; a command with a well-formed header around a MEMOBUS part of random bytes
// (unknown MFC / SFC, counts and lengths out of their limits); random bytes. Now and then
// the reply buffer is too small. Seeds: fuzz/corpus/memobus_server/.
//
// Invariants (violation -> __builtin_trap):
//   * a reply comes for every whole command message (type 0x11, parse_message() accepts it)
//     when the reply buffer holds max_message bytes, and for nothing else
//   * the reply is one whole message of type 0x19 with the command's serial, its channel
//     bytes swapped and its CPU nibbles swapped
//   * an error reply is 18 bytes, the SFC sent | 0x80, code 01 / 02 / 03; the code is the one
//     parse_request() gives, else 02 for an address beyond the image (after the offset)
//     and 03 for a write outside the write range; the image is then unchanged
//   * a normal reply is accepted by parse_response() for the request as parsed; reads give
//     the image's words and bits (padding bits 0); writes land exactly at the request's
//     addresses plus the offset, inside the write range, and nowhere else: the image equals
//     a reference copy this target updates itself after every message
#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/bytes.hpp"
#include "ferrule/memobus/header.hpp"
#include "ferrule/memobus/message.hpp"
#include "ferrule/memobus/register_image.hpp"
#include "ferrule/memobus/server.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::memobus;

using image_type = register_image<48, 24>;

constexpr std::uint8_t functions[] = {0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x08,
                                      0x09, 0x0A, 0x0B, 0x0D, 0x0E, 0x0F, 0x10};

struct harness {
    FuzzedDataProvider& in;
    channel_config cfg;
    server s;
    image_type image;
    image_type ref; // what the image must hold

    harness(FuzzedDataProvider& p, const channel_config& c) : in(p), cfg(c), s(c) {
        for (std::size_t i = 0; i < image.mw_size; ++i)
            image.set_mw(i, in.ConsumeIntegral<std::uint16_t>());
        for (std::size_t i = 0; i < image.iw_size; ++i)
            image.set_iw(i, in.ConsumeIntegral<std::uint16_t>());
        ref = image;
    }

    std::uint16_t small_or_any(std::uint16_t small) {
        return in.ConsumeBool() ? in.ConsumeIntegralInRange<std::uint16_t>(0, small)
                                : in.ConsumeIntegral<std::uint16_t>();
    }

    // A command from encode_command(); 0 when the fields do not make one.
    std::size_t encoded(std::span<std::uint8_t> out, std::uint8_t serial, std::uint8_t dst,
                        std::uint8_t src) {
        request r;
        r.function = static_cast<sfc>(functions[in.ConsumeIntegralInRange<std::size_t>(0, 13)]);
        r.cpu = in.ConsumeIntegral<std::uint8_t>();
        r.address = small_or_any(60);
        r.count = in.ConsumeBool() ? in.ConsumeIntegralInRange<std::uint16_t>(1, 40)
                                   : in.ConsumeIntegral<std::uint16_t>();
        r.value = in.ConsumeBool()   ? coil_on
                  : in.ConsumeBool() ? std::uint16_t{0}
                                     : in.ConsumeIntegral<std::uint16_t>();
        const bool random_access = r.function == sfc::read_holding_registers_random ||
                                   r.function == sfc::write_holding_registers_random;
        std::size_t n_words = r.count;
        if (r.function == sfc::write_holding_registers_random) n_words = 2u * r.count;
        std::array<std::uint16_t, 80> words{};
        n_words = std::min(n_words, words.size());
        // 0D / 0E addresses mostly inside the image.
        for (std::size_t i = 0; i < n_words; ++i)
            words[i] =
                random_access && (r.function == sfc::read_holding_registers_random || i % 2 == 0)
                    ? small_or_any(60)
                    : in.ConsumeIntegral<std::uint16_t>();
        std::array<std::uint8_t, 8> bits{};
        const std::size_t n_bits = std::min(packed_size(r.count), bits.size());
        for (std::size_t i = 0; i < n_bits; ++i) bits[i] = in.ConsumeIntegral<std::uint8_t>();
        r.words = std::span<const std::uint16_t>(words).first(n_words);
        r.bits = std::span<const std::uint8_t>(bits).first(n_bits);
        const data_order order =
            in.ConsumeIntegral<std::uint8_t>() < 32
                ? (cfg.order == data_order::big_endian ? data_order::little_endian
                                                       : data_order::big_endian)
                : cfg.order;
        return encode_command(r, serial, out, order, dst, src).value_or(0);
    }

    // A well-formed header and MEMOBUS length around random bytes.
    std::size_t framed_random(std::span<std::uint8_t> out, std::uint8_t serial, std::uint8_t dst,
                              std::uint8_t src) {
        const std::size_t n = in.ConsumeIntegralInRange<std::size_t>(1, 40);
        std::size_t i = header_size + length_size;
        if (in.ConsumeBool()) out[i++] = mfc_extended;
        if (in.ConsumeBool()) out[i++] = functions[in.ConsumeIntegralInRange<std::size_t>(0, 13)];
        for (std::size_t k = 0; k < n; ++k) out[i++] = in.ConsumeIntegral<std::uint8_t>();
        store_header({command_type::command, serial, dst, src, static_cast<std::uint16_t>(i)},
                     out.data());
        store_le16(&out[header_size], static_cast<std::uint16_t>(i - header_size - length_size));
        return i;
    }

    std::size_t build(std::span<std::uint8_t> out) {
        const auto serial = in.ConsumeIntegral<std::uint8_t>();
        const auto dst = in.ConsumeIntegral<std::uint8_t>();
        const auto src = in.ConsumeIntegral<std::uint8_t>();
        std::size_t n = 0;
        switch (in.ConsumeIntegralInRange<unsigned>(0, 9)) {
        case 0: n = framed_random(out, serial, dst, src); break;
        case 1:
            n = in.ConsumeIntegralInRange<std::size_t>(0, 40);
            for (std::size_t i = 0; i < n; ++i) out[i] = in.ConsumeIntegral<std::uint8_t>();
            break;
        default: n = encoded(out, serial, dst, src); break;
        }
        if (n == 0) n = framed_random(out, serial, dst, src);
        const auto change = in.ConsumeIntegral<std::uint8_t>();
        if (change < 16) {
            constexpr std::uint8_t types[] = {0x12, 0x19, 0x00, 0x11};
            out[0] = types[change % 4];
        } else if (change < 32) {
            const auto at = in.ConsumeIntegralInRange<std::size_t>(0, n - 1);
            out[at] ^= static_cast<std::uint8_t>(in.ConsumeIntegralInRange<unsigned>(1, 255));
        }
        return n;
    }

    bool writable(std::size_t word) const {
        return word >= cfg.write_low && word <= cfg.write_high;
    }

    // The error code the server must answer `r` with, 0 if none; a normal answer is applied to
    // `ref`.
    device_errc model(const request& r) {
        const sfc f = r.function;
        const auto mw = ref.mw();
        switch (f) {
        case sfc::read_coils:
        case sfc::read_input_relays: {
            const std::size_t words = f == sfc::read_coils ? ref.mw_size : ref.iw_size;
            const std::size_t first =
                16u * (f == sfc::read_coils ? cfg.mb_offset : cfg.ib_offset) + r.address;
            return first + r.count > 16u * words ? device_errc::address_error : device_errc{};
        }
        case sfc::read_holding_registers:
        case sfc::read_holding_registers_ext:
            return cfg.mw_offset + std::size_t{r.address} + r.count > ref.mw_size
                       ? device_errc::address_error
                       : device_errc{};
        case sfc::read_input_registers:
        case sfc::read_input_registers_ext:
            return cfg.iw_offset + std::size_t{r.address} + r.count > ref.iw_size
                       ? device_errc::address_error
                       : device_errc{};
        case sfc::write_coil:
        case sfc::write_coils: {
            const std::size_t first = 16u * cfg.mb_offset + r.address;
            if (first + r.count > 16u * ref.mw_size) return device_errc::address_error;
            for (std::size_t i = 0; i < r.count; ++i)
                if (!writable((first + i) / 16)) return device_errc::count_error;
            for (std::size_t i = 0; i < r.count; ++i)
                ref.set_mb(first + i,
                           f == sfc::write_coil ? r.value == coil_on : (r.raw[i / 8] >> i % 8) & 1);
            return {};
        }
        case sfc::write_holding_register:
        case sfc::write_holding_registers:
        case sfc::write_holding_registers_ext: {
            const std::size_t first = cfg.mw_offset + std::size_t{r.address};
            if (first + r.count > ref.mw_size) return device_errc::address_error;
            for (std::size_t i = 0; i < r.count; ++i)
                if (!writable(first + i)) return device_errc::count_error;
            for (std::size_t i = 0; i < r.count; ++i)
                mw[first + i] =
                    f == sfc::write_holding_register ? r.value : word_at(f, r.raw, i, cfg.order);
            return {};
        }
        case sfc::loopback: return {};
        case sfc::read_holding_registers_random:
            for (std::size_t i = 0; i < r.count; ++i)
                if (cfg.mw_offset + std::size_t{word_at(f, r.raw, i)} >= ref.mw_size)
                    return device_errc::address_error;
            return {};
        case sfc::write_holding_registers_random: {
            for (std::size_t i = 0; i < r.count; ++i)
                if (cfg.mw_offset + std::size_t{word_at(f, r.raw, 2 * i)} >= ref.mw_size)
                    return device_errc::address_error;
            for (std::size_t i = 0; i < r.count; ++i)
                if (!writable(cfg.mw_offset + std::size_t{word_at(f, r.raw, 2 * i)}))
                    return device_errc::count_error;
            for (std::size_t i = 0; i < r.count; ++i)
                mw[cfg.mw_offset + std::size_t{word_at(f, r.raw, 2 * i)}] =
                    word_at(f, r.raw, 2 * i + 1);
            return {};
        }
        }
        return device_errc::sfc_error;
    }

    // The data of a normal reply to the read `r`: the image's words and bits.
    void check_read(const request& r, const response& rsp) const {
        const sfc f = r.function;
        switch (f) {
        case sfc::read_coils:
        case sfc::read_input_relays: {
            const bool coils = f == sfc::read_coils;
            const std::size_t first = 16u * (coils ? cfg.mb_offset : cfg.ib_offset) + r.address;
            for (std::size_t i = 0; i < 8 * rsp.raw.size(); ++i) {
                const bool got = (rsp.raw[i / 8] >> i % 8) & 1;
                const bool want = i < r.count && (coils ? ref.mb(first + i) : ref.ib(first + i));
                FERRULE_CHECK(got == want);
            }
            break;
        }
        case sfc::read_holding_registers:
        case sfc::read_holding_registers_ext:
        case sfc::read_input_registers:
        case sfc::read_input_registers_ext: {
            const bool hold =
                f == sfc::read_holding_registers || f == sfc::read_holding_registers_ext;
            const std::size_t first =
                (hold ? cfg.mw_offset : cfg.iw_offset) + std::size_t{r.address};
            for (std::size_t i = 0; i < r.count; ++i)
                FERRULE_CHECK(word_at(f, rsp.raw, i, cfg.order) ==
                              (hold ? ref.mw(first + i) : ref.iw(first + i)));
            break;
        }
        case sfc::read_holding_registers_random:
            for (std::size_t i = 0; i < r.count; ++i)
                FERRULE_CHECK(word_at(f, rsp.raw, i) ==
                              ref.mw(cfg.mw_offset + std::size_t{word_at(f, r.raw, i)}));
            break;
        default: break;
        }
    }

    bool image_is_ref() const {
        return std::equal(image.mw().begin(), image.mw().end(), ref.mw().begin()) &&
               std::equal(image.iw().begin(), image.iw().end(), ref.iw().begin());
    }

    void step() {
        std::array<std::uint8_t, max_message> msg{};
        const std::size_t n = build(msg);
        const auto message = std::span<const std::uint8_t>(msg.data(), n);
        std::array<std::uint8_t, max_message> out{};
        const std::size_t room =
            in.ConsumeIntegral<std::uint8_t>() < 8 ? max_message - 1 : max_message;
        const std::size_t size = s.handle(message, image, std::span<std::uint8_t>(out).first(room));

        const auto h = parse_message(message);
        const bool command = h && h->type == command_type::command && room == max_message;
        FERRULE_CHECK((size > 0) == command);
        if (!command) {
            FERRULE_CHECK(image_is_ref());
            return;
        }
        const auto reply = std::span<const std::uint8_t>(out.data(), size);
        const auto rh = parse_message(reply);
        FERRULE_CHECK(rh.has_value());
        FERRULE_CHECK(rh->type == command_type::response && rh->serial == h->serial);
        FERRULE_CHECK(rh->destination_channel == h->source_channel &&
                      rh->source_channel == h->destination_channel);
        const auto body = message.subspan(header_size);
        const auto rbody = reply.subspan(header_size);
        FERRULE_CHECK(rbody.size() >= length_size + 3 && rbody[2] == mfc_extended);
        FERRULE_CHECK(rbody[4] == swap_nibbles(body.size() > 4 ? body[4] : 0));

        const auto req = parse_request(body, cfg.order);
        const device_errc expected =
            req ? model(*req) : static_cast<device_errc>(req.error().value());
        if (rbody[3] & error_flag) {
            FERRULE_CHECK(size == 18);
            FERRULE_CHECK(rbody[3] == ((body.size() > 3 ? body[3] : 0) | error_flag));
            FERRULE_CHECK(rbody[5] >= 1 && rbody[5] <= 3);
            FERRULE_CHECK(static_cast<device_errc>(rbody[5]) == expected);
            FERRULE_CHECK(image_is_ref());
            return;
        }
        FERRULE_CHECK(req.has_value() && expected == device_errc{});
        const auto rsp = parse_response(*req, rbody, cfg.order);
        FERRULE_CHECK(rsp.has_value());
        FERRULE_CHECK(image_is_ref());
        check_read(*req, *rsp);
    }
};

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    FuzzedDataProvider in(data, size);
    channel_config cfg;
    cfg.mw_offset = in.ConsumeIntegralInRange<std::uint16_t>(0, 50);
    cfg.iw_offset = in.ConsumeIntegralInRange<std::uint16_t>(0, 30);
    cfg.mb_offset = in.ConsumeIntegralInRange<std::uint16_t>(0, 50);
    cfg.ib_offset = in.ConsumeIntegralInRange<std::uint16_t>(0, 30);
    if (in.ConsumeBool()) {
        cfg.write_low = in.ConsumeIntegralInRange<std::uint16_t>(0, 50);
        cfg.write_high = in.ConsumeIntegralInRange<std::uint16_t>(0, 50);
    }
    cfg.order = in.ConsumeBool() ? data_order::little_endian : data_order::big_endian;
    harness h(in, cfg);
    for (int i = 0; i < 64 && in.remaining_bytes() > 0; ++i) h.step();
    return 0;
}
