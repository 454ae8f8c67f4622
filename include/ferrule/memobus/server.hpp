// The controller's side of one Extended MEMOBUS channel, sans-I/O: what an MP2000 / MP3000
// does with the requests a master sends over one connection (TCP) or from one peer (UDP),
// like the MSG-RCV function on one transmission buffer channel (protocols/memobus.md §6,
// seeds/004: one channel per master, each with its own offsets and write range).
//
//   * handle() is given one whole message (message_decoder over TCP, a datagram over UDP)
//     and writes the reply into `out`: type 0x19, the serial echoed, the channel bytes and
//     the CPU nibbles swapped (§2, §3.2, §10.4)
//   * SFC 01 02 03 04 05 06 08 09 0A 0B 0D 0E 0F 10 on a register_image (MB = bits of MW,
//     IB = bits of IW, §3.4)
//   * each address gets its area's offset, in words as MSG-RCV's PARAM08…11 are ([S3]
//     Table G.21: coil, input relay, input register, hold register offset)
//   * writes (05 06 0B 0E 0F 10) must fall in the write range, MW words write_low…write_high
//     after the offset; coils by the MW word that holds them (§3.4: "Coil/Hold Register Write
//     Range Low/High"; seeds/004 names it PARAM12 / PARAM13)
//   * error responses (§3.5): 01 an unknown SFC or MFC; 02 an address beyond the image;
//     03 a count out of the SFC's limits, a length that does not fit it, or a write outside
//     the write range (HSL's server answers 03 for write-disabled, §3.5; the manuals give no
//     code for it). A refused request writes nothing.
//   * not answered: general-purpose messages (type 0x12, §5), responses (type 0x19) and
//     anything that is not one whole message
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/bytes.hpp"
#include "ferrule/memobus/constants.hpp"
#include "ferrule/memobus/error.hpp"
#include "ferrule/memobus/header.hpp"
#include "ferrule/memobus/message.hpp"
#include "ferrule/memobus/register_image.hpp"

namespace ferrule::memobus {

struct channel_config {
    std::uint16_t mw_offset = 0; // PARAM11: SFC 03 06 09 0B 0D 0E 10
    std::uint16_t iw_offset = 0; // PARAM10: SFC 04 0A
    std::uint16_t mb_offset = 0; // PARAM08, in MW words (16 coils each): SFC 01 05 0F
    std::uint16_t ib_offset = 0; // PARAM09, in IW words: SFC 02
    std::uint16_t write_low = 0; // the MW words writes may touch, both included
    std::uint16_t write_high = 65534;
    data_order order = data_order::big_endian; // SFC 03 04 06 10 register data (§3.3, §11.1)
};

struct channel_stats {
    std::uint32_t requests = 0;       // commands (type 0x11)
    std::uint32_t responses = 0;      // of those: answered normally
    std::uint32_t sfc_errors = 0;     // answered with error 01
    std::uint32_t address_errors = 0; // 02
    std::uint32_t count_errors = 0;   // 03 (count, length or write range)
    std::uint32_t general = 0;        // type 0x12 messages, not answered (§5)
    std::uint32_t ignored = 0;        // responses (type 0x19) and broken messages
    std::uint32_t bytes_in = 0;       // of the messages handled
    std::uint32_t bytes_out = 0;      // of the replies
};

class server {
public:
    explicit server(const channel_config& cfg = {}) noexcept : cfg_(cfg) {}

    // One whole message; the reply goes to `out` (max_message bytes). Returns its size, 0 when
    // there is none (see above, or `out` too small: then nothing is executed).
    template <class Image>
    std::size_t handle(std::span<const std::uint8_t> message, Image& image,
                       std::span<std::uint8_t> out) noexcept {
        return handle(message, std::span<std::uint16_t>(image.mw()),
                      std::span<std::uint16_t>(image.iw()), out);
    }

    std::size_t handle(std::span<const std::uint8_t> message, std::span<std::uint16_t> mw,
                       std::span<std::uint16_t> iw, std::span<std::uint8_t> out) noexcept {
        const auto h = parse_message(message);
        if (!h || out.size() < max_message) {
            ++stats_.ignored;
            return 0;
        }
        stats_.bytes_in += static_cast<std::uint32_t>(message.size());
        if (h->type == command_type::general) {
            ++stats_.general;
            return 0;
        }
        if (h->type != command_type::command) {
            ++stats_.ignored;
            return 0;
        }
        ++stats_.requests;
        const auto body = message.subspan(header_size);
        const auto req = parse_request(body, cfg_.order);
        outcome o{0, req ? device_errc{} : static_cast<device_errc>(req.error().value())};
        if (req) o = execute(*h, *req, mw, iw, out);
        switch (o.error) {
        case device_errc::sfc_error: ++stats_.sfc_errors; break;
        case device_errc::address_error: ++stats_.address_errors; break;
        case device_errc::count_error: ++stats_.count_errors; break;
        default: ++stats_.responses; break;
        }
        if (o.error != device_errc{}) {
            // The SFC and CPU bytes as sent, when the message has them.
            const std::uint8_t f = body.size() > 3 ? body[3] : 0;
            const std::uint8_t cpu = body.size() > 4 ? body[4] : 0;
            o.size = encode_error(*h, f, cpu, o.error, out).value_or(0);
        }
        stats_.bytes_out += static_cast<std::uint32_t>(o.size);
        return o.size;
    }

    const channel_config& config() const noexcept { return cfg_; }
    void set_config(const channel_config& cfg) noexcept { cfg_ = cfg; }
    const channel_stats& stats() const noexcept { return stats_; }

private:
    struct outcome {
        std::size_t size = 0;
        device_errc error{};
    };
    static outcome fail(device_errc e) noexcept { return {0, e}; }

    bool writable(std::size_t first_word, std::size_t last_word) const noexcept {
        return first_word >= cfg_.write_low && last_word <= cfg_.write_high;
    }

    outcome respond(const header& h, const request& r, const response& rsp,
                    std::span<std::uint8_t> out) const noexcept {
        return {encode_response(h, r, rsp, out, cfg_.order).value_or(0), {}};
    }

    outcome execute(const header& h, const request& r, std::span<std::uint16_t> mw,
                    std::span<std::uint16_t> iw, std::span<std::uint8_t> out) const noexcept {
        const sfc f = r.function;
        response rsp;
        rsp.function = f;
        switch (f) {
        case sfc::read_coils:
        case sfc::read_input_relays: {
            const bool coils = f == sfc::read_coils;
            const auto words = coils ? mw : iw;
            const std::size_t first = 16u * (coils ? cfg_.mb_offset : cfg_.ib_offset) + r.address;
            if (first + r.count > 16u * words.size()) return fail(device_errc::address_error);
            std::array<std::uint8_t, packed_size(max_read_bits)> bits{};
            for (std::size_t i = 0; i < r.count; ++i)
                if (bit_of(words, first + i))
                    bits[i / 8] = static_cast<std::uint8_t>(bits[i / 8] | 1u << i % 8);
            rsp.bits = std::span<const std::uint8_t>(bits).first(packed_size(r.count));
            return respond(h, r, rsp, out);
        }
        case sfc::read_holding_registers:
        case sfc::read_input_registers:
        case sfc::read_holding_registers_ext:
        case sfc::read_input_registers_ext: {
            const bool hold =
                f == sfc::read_holding_registers || f == sfc::read_holding_registers_ext;
            const auto words = hold ? mw : iw;
            const std::size_t first =
                std::size_t{hold ? cfg_.mw_offset : cfg_.iw_offset} + r.address;
            if (first + r.count > words.size()) return fail(device_errc::address_error);
            rsp.words = words.subspan(first, r.count);
            return respond(h, r, rsp, out);
        }
        case sfc::write_coil:
        case sfc::write_coils: {
            const std::size_t first = 16u * cfg_.mb_offset + r.address;
            if (first + r.count > 16u * mw.size()) return fail(device_errc::address_error);
            if (!writable(first / 16, (first + r.count - 1) / 16))
                return fail(device_errc::count_error);
            for (std::size_t i = 0; i < r.count; ++i) {
                const bool on =
                    f == sfc::write_coil ? r.value == coil_on : (r.raw[i / 8] >> i % 8) & 1u;
                set_bit_of(mw, first + i, on);
            }
            return respond(h, r, rsp, out);
        }
        case sfc::write_holding_register:
        case sfc::write_holding_registers:
        case sfc::write_holding_registers_ext: {
            const std::size_t first = std::size_t{cfg_.mw_offset} + r.address;
            if (first + r.count > mw.size()) return fail(device_errc::address_error);
            if (!writable(first, first + r.count - 1)) return fail(device_errc::count_error);
            if (f == sfc::write_holding_register)
                mw[first] = r.value;
            else
                for (std::size_t i = 0; i < r.count; ++i)
                    mw[first + i] = word_at(f, r.raw, i, cfg_.order);
            return respond(h, r, rsp, out);
        }
        case sfc::loopback: return respond(h, r, rsp, out);
        case sfc::read_holding_registers_random: {
            for (std::size_t i = 0; i < r.count; ++i)
                if (cfg_.mw_offset + std::size_t{word_at(f, r.raw, i)} >= mw.size())
                    return fail(device_errc::address_error);
            return {random_read(h, r, mw, out), {}};
        }
        case sfc::write_holding_registers_random: {
            bool refused = false;
            for (std::size_t i = 0; i < r.count; ++i) {
                const std::size_t a = cfg_.mw_offset + std::size_t{word_at(f, r.raw, 2 * i)};
                if (a >= mw.size()) return fail(device_errc::address_error);
                refused = refused || !writable(a, a);
            }
            if (refused) return fail(device_errc::count_error);
            for (std::size_t i = 0; i < r.count; ++i)
                mw[cfg_.mw_offset + std::size_t{word_at(f, r.raw, 2 * i)}] =
                    word_at(f, r.raw, 2 * i + 1);
            return respond(h, r, rsp, out);
        }
        }
        return fail(device_errc::sfc_error);
    }

    // SFC 0D answers as 09 does (§3.4: spare, n, n registers), the registers gathered from MW
    // straight into `out`.
    std::size_t random_read(const header& h, const request& r, std::span<const std::uint16_t> mw,
                            std::span<std::uint8_t> out) const noexcept {
        constexpr std::size_t data_at = header_size + length_size + 6; // MFC SFC CPU spare n
        const std::size_t total = data_at + 2u * r.count;
        store_header({command_type::response, h.serial, h.source_channel, h.destination_channel,
                      static_cast<std::uint16_t>(total)},
                     out.data());
        store_le16(&out[header_size],
                   static_cast<std::uint16_t>(total - header_size - length_size));
        out[header_size + 2] = mfc_extended;
        out[header_size + 3] = static_cast<std::uint8_t>(r.function);
        out[header_size + 4] = swap_nibbles(r.cpu);
        out[header_size + 5] = 0; // spare
        store_le16(&out[header_size + 6], r.count);
        for (std::size_t i = 0; i < r.count; ++i)
            store_le16(&out[data_at + 2 * i],
                       mw[cfg_.mw_offset + std::size_t{word_at(r.function, r.raw, i)}]);
        return total;
    }

    channel_config cfg_;
    channel_stats stats_{};
};

} // namespace ferrule::memobus
