// Modbus server session (the device's side of the line), sans-I/O, over RTU or TCP, serving a
// data model (data_model.hpp) that it owns.
//
// RTU (Modbus over Serial Line V1.02):
//   * requests are framed by the length their function code predicts (an rtu_receiver of
//     rtu_frames::requests); when the line has been silent for t3.5 the bytes buffered end
//     the frame (§2.5.1.1), so a request of an unknown function code is answered with
//     exception 01 too
//   * the server answers the unit ids of its set (one port may carry several, as a gateway or
//     a multi-drop simulator does); requests for other units are ignored (§2.2, §2.3)
//   * a broadcast (unit 0) is executed and never answered (§2.2), whatever its function
//   * a frame with a CRC error is counted and not answered (§2.6: not acted upon)
//   * the reply goes out t3.5 + processing_time after the request's last character; a
//     request seen before it has gone out means the client has moved on: the reply is dropped
//   * FC 8 Diagnostics (Application Protocol V1.1b3 §6.8.1): 00 return query data, 01 restart
//     communications (echo, then the counters are cleared), 10 clear counters, 11-18 the
//     counters, kept as Serial Line §6.1 (Appendix A) manages them: bus message, bus
//     communication error (CRC), bus exception, server message, server no response, NAK,
//     busy, character overrun. 04 force listen only mode: no reply, and from then on requests
//     are counted but neither executed nor answered, except 01 restart communications, which
//     ends the mode (unanswered too). Other sub-functions: exception 01.
//
// TCP (Modbus Messaging on TCP/IP Implementation Guide V1.0b), one session per connection:
//   * requests are framed by the MBAP header (tcp_decoder); the reply echoes the transaction
//     id and the unit id (§3.1.3); every unit id is answered, unit 0 too (§4.4.2: the unit id
//     is the gateway's business, a server addressed by its IP address ignores it)
//   * requests behind a pending one wait until its reply has gone out, so pipelined requests
//     are answered in order
//   * FC 8 is serial line only (AP §6.8): exception 01
//
// Both: FC 1-6, 15, 16, 23 and 43/14 (AP §6); exception 01 for an unknown function code, 03
// for a bad quantity, byte count, coil value or device id code, 02 for address + quantity
// beyond 65536, and whatever the data model returns (typically 02 for its address range, 04
// for a failure). FC 23 writes before it reads (§6.17) and checks the read range first, so a
// refused request writes nothing. FC 43/14 (§6.21): basic identification, objects 0-2 as
// stream (codes 1-3: a server answers at its own conformity level) and individual access
// (code 4: any object the model has, else exception 02).
//
// The session knows no clock and no port: it is told when the bytes it gets ended, and
// next(now) says when the reply is due and hands it out.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <span>
#include <string_view>
#include <utility>

#include "ferrule/core/bytes.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/serial_format.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/core/static_buffer.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/modbus/constants.hpp"
#include "ferrule/modbus/data_model.hpp"
#include "ferrule/modbus/pdu.hpp"
#include "ferrule/modbus/rtu.hpp"
#include "ferrule/modbus/tcp.hpp"

namespace ferrule::modbus {

// The unit ids an RTU server answers: 1…247 (Serial Line V1.02 §2.2; 0 is the broadcast,
// 248…255 are reserved).
class unit_set {
public:
    constexpr unit_set() noexcept = default;
    constexpr unit_set(std::initializer_list<std::uint8_t> units) noexcept {
        for (const std::uint8_t u : units) add(u);
    }
    // False for 0 and 248…255.
    constexpr bool add(std::uint8_t u) noexcept {
        if (u == broadcast_address || u > max_unit_address) return false;
        bits_[u / 8] = static_cast<std::uint8_t>(bits_[u / 8] | 1u << u % 8);
        return true;
    }
    constexpr void remove(std::uint8_t u) noexcept {
        bits_[u / 8] = static_cast<std::uint8_t>(bits_[u / 8] & ~(1u << u % 8));
    }
    constexpr bool contains(std::uint8_t u) const noexcept { return (bits_[u / 8] >> u % 8) & 1u; }

private:
    std::array<std::uint8_t, 32> bits_{};
};

enum class transport : std::uint8_t { rtu, tcp };

struct server_config {
    modbus::transport transport = modbus::transport::rtu;
    unit_set units{1};                     // RTU: the unit ids answered
    serial_format format = default_format; // RTU: t3.5 ends a frame and precedes the reply
    duration processing_time{};            // request end (+ t3.5 in RTU) -> reply
};

// The diagnostic counters of FC 8 (AP §6.8.1, SL §6.1), 16 bits as the response carries
// them; they wrap around. A server built without FC 8 (its function_set) keeps them zero.
struct diagnostic_counters {
    std::uint16_t bus_message = 0;        // 11: frames with a good CRC, any unit
    std::uint16_t bus_comm_error = 0;     // 12: frames with a CRC error, each once
    std::uint16_t bus_exception = 0;      // 13: exception responses sent
    std::uint16_t server_message = 0;     // 14: requests for this server or broadcast
    std::uint16_t server_no_response = 0; // 15: of those, not answered (broadcast, dropped,
                                          //     function code 0 or >= 128)
    std::uint16_t server_nak = 0;         // 16: exception 07 sent
    std::uint16_t server_busy = 0;        // 17: exception 06 sent
    std::uint16_t bus_char_overrun = 0;   // 18: see server::on_overrun()
};

struct server_stats {
    std::uint32_t requests = 0;   // requests handled (broadcasts included)
    std::uint32_t replies = 0;    // replies handed out by next()
    std::uint32_t exceptions = 0; // of those: exception responses
    std::uint32_t broadcasts = 0; // executed, not answered
    std::uint32_t abandoned = 0;  // RTU: replies dropped because a new request came first
    std::uint32_t other_unit = 0; // RTU: frames for other units
    std::uint32_t bad_crc = 0;    // RTU: frames with a CRC error
    std::uint32_t malformed = 0;  // bytes that form no frame (RTU garbage, a bad MBAP header)
    std::uint32_t overflowed = 0; // TCP: bytes lost behind a pending request
};

// Link: the transport chosen by server_config::transport at run time (any), or fixed at
// compile time, so RTU firmware does not carry the TCP framing and its held requests.
// Fs: the function codes served (function_set); the others get exception 01 like an unknown
// one, and their code is not compiled in.
template <data_model M, link_mode Link = link_mode::any, function_set Fs = all_functions>
class server {
public:
    // TCP: bytes behind a pending request that are kept for later (one full request).
    static constexpr std::size_t held_capacity = max_tcp_adu;

    constexpr explicit server(const server_config& cfg = {}, M model = M{}) noexcept
        : cfg_(cfg), t35_(modbus::t35(cfg.format)), model_(std::move(model)) {
        if constexpr (Link != link_mode::any)
            cfg_.transport = Link == link_mode::rtu ? transport::rtu : transport::tcp;
    }

    // A chunk of bytes from the line or connection whose last byte ended at `end`.
    void on_receive(std::span<const std::uint8_t> bytes, time_point end) noexcept {
        if (bytes.empty()) return;
        if (!rtu()) {
            // Requests held from before come first.
            if (state_ == state::listening && !held_.empty()) resume();
            if (state_ == state::reply_queued) {
                hold(bytes, end);
                return;
            }
            feed_tcp(bytes, end);
            return;
        }
        // RTU: a silence of t3.5 before these bytes ended the frame before them (SL
        // §2.5.1.1). Bytes take their wire time, so the chunk began that long before `end`.
        if (!rtu_.empty() && !before(end - cfg_.format.chars_time(bytes.size()), rx_end_ + t35()))
            finish_rtu();
        rx_end_ = end;
        feed_rtu(bytes);
    }

    // idle: nothing to do until bytes come; wait: call again at the deadline (a reply is due,
    // or the RTU frame in progress ends by silence); send: put these bytes on the line now.
    session_action next(time_point now) noexcept {
        if (!rtu() && state_ == state::listening && !held_.empty()) resume();
        if (state_ == state::listening && rtu() && !rtu_.empty()) {
            if (before(now, rx_end_ + t35())) return session_action::wait_until(rx_end_ + t35());
            finish_rtu();
        }
        if (state_ != state::reply_queued) return session_action::idle();
        if (before(now, reply_at_)) return session_action::wait_until(reply_at_);
        state_ = state::listening;
        ++stats_.replies;
        if (tx_exception_ != 0) {
            ++stats_.exceptions;
            count(&diagnostic_counters::bus_exception);
            if (tx_exception_ == code_of(exception_code::negative_acknowledge))
                count(&diagnostic_counters::server_nak);
            if (tx_exception_ == code_of(exception_code::server_device_busy))
                count(&diagnostic_counters::server_busy);
        }
        return session_action::send({tx_.data(), tx_size_}, false);
    }

    // When the queued reply is due; `never` when none is queued.
    time_point reply_at() const noexcept {
        return state_ == state::reply_queued ? scheduled(reply_at_) : never;
    }
    // When next() wants to be called: the reply, or the end of an RTU frame by silence.
    time_point wake_at() const noexcept {
        if (state_ == state::reply_queued) return scheduled(reply_at_);
        if (!rtu() && !held_.empty()) return scheduled(held_.end());
        if (rtu() && !rtu_.empty()) return scheduled(rx_end_ + t35());
        return never;
    }

    // A character overrun the driver's UART reported (AP §6.8.1 sub-function 18): the
    // session itself loses no characters.
    void on_overrun() noexcept { count(&diagnostic_counters::bus_char_overrun); }

    // Executes one request PDU and writes the response PDU to `out` (max_pdu bytes); returns
    // its size, 0 when there is no answer: an empty PDU, function code 0 or one with the
    // exception bit (AP §4.1: 0 is not valid, 128-255 are exception responses), FC 8
    // sub-function 04. Counters are not touched except by FC 8 itself.
    std::size_t execute(std::span<const std::uint8_t> pdu, std::span<std::uint8_t> out) noexcept {
        if (pdu.empty() || pdu[0] == 0 || pdu[0] >= exception_flag || out.size() < max_pdu)
            return 0;
        const auto fc = static_cast<function>(pdu[0]);
        request r;
        if (const std::uint8_t e = detail::decode_request<Fs>(pdu, r)) return exception(fc, e, out);
        using detail::one_of;
        const function f = r.function;
        if (one_of<Fs, function::read_coils, function::read_discrete_inputs>(f)) {
            const auto n = static_cast<std::uint8_t>(packed_size(r.quantity));
            std::fill_n(out.begin() + 2, n, std::uint8_t{0});
            const auto data = out.subspan(2, n);
            if (const auto e = model_.read_bits(fc, r.address, r.quantity, data))
                return exception(fc, e, out);
            return counted(fc, n, out);
        }
        if (one_of<Fs, function::read_holding_registers, function::read_input_registers>(f)) {
            const auto n = static_cast<std::uint8_t>(2 * r.quantity);
            if (const auto e = model_.read_registers(fc, r.address, r.quantity, out.subspan(2, n)))
                return exception(fc, e, out);
            return counted(fc, n, out);
        }
        if (one_of<Fs, function::write_single_coil>(f)) {
            const std::array<std::uint8_t, 1> bit{static_cast<std::uint8_t>(r.value == coil_on)};
            if (const auto e = model_.write_coils(r.address, 1, bit)) return exception(fc, e, out);
            return echo(pdu, out);
        }
        if (one_of<Fs, function::write_single_register>(f)) {
            if (const auto e = model_.write_registers(r.address, 1, pdu.subspan(3, 2)))
                return exception(fc, e, out);
            return echo(pdu, out);
        }
        if (one_of<Fs, function::write_multiple_coils, function::write_multiple_registers>(f)) {
            const bool coils = f == function::write_multiple_coils;
            const auto e = coils ? model_.write_coils(r.address, r.quantity, r.data)
                                 : model_.write_registers(r.address, r.quantity, r.data);
            if (e) return exception(fc, e, out);
            return echo(pdu.first(5), out);
        }
        if (one_of<Fs, function::read_write_multiple_registers>(f)) {
            const auto n = static_cast<std::uint8_t>(2 * r.quantity);
            const auto data = out.subspan(2, n);
            auto e = model_.read_registers(function::read_holding_registers, r.address, r.quantity,
                                           data);
            if (!e) e = model_.write_registers(r.write_address, r.write_quantity, r.data);
            if (!e)
                e = model_.read_registers(function::read_holding_registers, r.address, r.quantity,
                                          data);
            if (e) return exception(fc, e, out);
            return counted(fc, n, out);
        }
        if (one_of<Fs, function::diagnostics>(f)) return diagnostics(r, pdu, out);
        if (one_of<Fs, function::encapsulated_interface>(f)) return device_identification(r, out);
        return exception(fc, code_of(exception_code::illegal_function), out);
    }

    M& model() noexcept { return model_; }
    const M& model() const noexcept { return model_; }
    const diagnostic_counters& counters() const noexcept { return counters_; }
    void clear_counters() noexcept { counters_ = {}; }
    // RTU: FC 8 sub-function 04 has put the server in listen only mode (AP §6.8.1).
    bool listen_only() const noexcept { return diagnosed && listen_only_; }
    const server_stats& stats() const noexcept { return stats_; }
    const server_config& config() const noexcept { return cfg_; }
    // RTU: the unit ids answered; a change takes effect for the next frame.
    unit_set& units() noexcept { return cfg_.units; }

private:
    enum class state : std::uint8_t { listening, reply_queued };

    // Conformity level of FC 43/14 (AP §6.21): basic identification, stream and individual
    // access.
    static constexpr std::uint8_t conformity_basic = 0x81;
    static constexpr std::uint8_t basic_objects = 3; // 0 vendor, 1 product code, 2 revision
    static constexpr std::size_t device_id_header = 7;

    constexpr bool rtu() const noexcept {
        if constexpr (Link == link_mode::any)
            return cfg_.transport == transport::rtu;
        else
            return Link == link_mode::rtu;
    }
    static bool is_restart(std::span<const std::uint8_t> pdu) noexcept {
        return pdu.size() == 5 && pdu[0] == static_cast<std::uint8_t>(function::diagnostics) &&
               load_be16(&pdu[1]) == static_cast<std::uint16_t>(diag_sub::restart_comm);
    }
    duration t35() const noexcept { return t35_; }

    // FC 8 is served: its counters and listen only mode are kept (else they stay zero).
    static constexpr bool diagnosed = Fs.has(function::diagnostics);
    void count(std::uint16_t diagnostic_counters::*counter) noexcept {
        if constexpr (diagnosed) ++(counters_.*counter);
    }

    // --- RTU -------------------------------------------------------------------------------
    // What the RTU receive buffer finds: every frame is handled, in order.
    struct events {
        server& s;
        bool on_frame(std::uint8_t unit, std::span<const std::uint8_t> pdu) noexcept {
            s.handle_rtu(unit, pdu);
            return true;
        }
        void on_garbage(errc why) noexcept { s.garbage(why); }
    };

    void feed_rtu(std::span<const std::uint8_t> in) noexcept {
        events e{*this};
        for (const std::uint8_t b : in) rtu_.push(b, e);
    }

    // The silence ends what is buffered: frames in it, then garbage, until nothing is left.
    void finish_rtu() noexcept {
        events e{*this};
        rtu_.finish(e);
        garbled_ = false;
    }

    // Bytes dropped while framing (the buffer resynchronises byte by byte, so one damaged
    // frame may give several): counted once, by the first.
    void garbage(errc why) noexcept {
        if (garbled_) return;
        garbled_ = true;
        if (why == errc::bad_checksum) {
            ++stats_.bad_crc;
            count(&diagnostic_counters::bus_comm_error);
        } else {
            ++stats_.malformed;
        }
    }

    // A frame, ended by the chunk that ended at rx_end_ or by the silence after it.
    void handle_rtu(std::uint8_t unit, std::span<const std::uint8_t> pdu) noexcept {
        garbled_ = false;
        // Any frame on the line before the reply went out: the client has moved on.
        if (state_ == state::reply_queued) {
            state_ = state::listening;
            ++stats_.abandoned;
            count(&diagnostic_counters::server_no_response);
        }
        count(&diagnostic_counters::bus_message);
        if (unit != broadcast_address && !cfg_.units.contains(unit)) {
            ++stats_.other_unit;
            return;
        }
        count(&diagnostic_counters::server_message);
        // Listen only mode (AP §6.8.1 sub-function 04): only a restart is acted upon.
        const bool listening_only = listen_only();
        if (listening_only && !is_restart(pdu)) {
            count(&diagnostic_counters::server_no_response);
            return;
        }
        ++stats_.requests;
        // The reply is built in place, behind its address.
        std::size_t n = execute(pdu, {tx_.data() + 1, max_pdu});
        if (listening_only) n = 0; // the restart that ends the mode is not answered either
        if (unit == broadcast_address || n == 0) {
            if (unit == broadcast_address) ++stats_.broadcasts;
            count(&diagnostic_counters::server_no_response);
            return;
        }
        queue(seal_rtu(unit, tx_.data(), n), rx_end_ + t35());
    }

    // --- TCP -------------------------------------------------------------------------------
    void feed_tcp(std::span<const std::uint8_t> in, time_point end) noexcept {
        while (state_ != state::reply_queued) {
            const auto s = tcp_.feed(in);
            in = in.subspan(s.consumed);
            if (s.what == tcp_decoder::status::error) ++stats_.malformed;
            if (s.what == tcp_decoder::status::frame) {
                count(&diagnostic_counters::bus_message);
                count(&diagnostic_counters::server_message);
                ++stats_.requests;
                // The reply is built in place, behind its MBAP header.
                const std::size_t n = execute(tcp_.pdu(), {tx_.data() + mbap_size, max_pdu});
                if (n > 0) queue(seal_tcp(tcp_.transaction(), tcp_.unit(), tx_.data(), n), end);
            }
            if (s.what == tcp_decoder::status::need_more) return;
        }
        if (!in.empty()) hold(in, end);
    }

    // Keeps bytes for after the pending reply (their end time is the latest chunk's).
    void hold(std::span<const std::uint8_t> in, time_point end) noexcept {
        stats_.overflowed += static_cast<std::uint32_t>(held_.hold(in, end));
    }

    void resume() noexcept {
        held_.release(
            [this](std::span<const std::uint8_t> in, time_point end) { feed_tcp(in, end); });
    }

    // --- both ------------------------------------------------------------------------------
    // The reply of `adu_size` bytes in tx_, ready at `ready` + the processing time.
    void queue(std::size_t adu_size, time_point ready) noexcept {
        const std::uint8_t* const pdu = tx_.data() + (rtu() ? 1 : mbap_size);
        tx_size_ = adu_size;
        tx_exception_ = pdu[0] & exception_flag ? pdu[1] : std::uint8_t{0};
        reply_at_ = ready + cfg_.processing_time;
        state_ = state::reply_queued;
    }

    static std::size_t exception(function fc, std::uint8_t code,
                                 std::span<std::uint8_t> out) noexcept {
        return detail::write_exception(fc, code, out.data());
    }
    // [FC][byte count][n bytes already in place]
    static std::size_t counted(function fc, std::uint8_t n, std::span<std::uint8_t> out) noexcept {
        out[0] = static_cast<std::uint8_t>(fc);
        out[1] = n;
        return 2u + n;
    }
    static std::size_t echo(std::span<const std::uint8_t> pdu,
                            std::span<std::uint8_t> out) noexcept {
        std::copy(pdu.begin(), pdu.end(), out.begin());
        return pdu.size();
    }

    // FC 8 (AP §6.8.1), serial line only.
    std::size_t diagnostics(const request& r, std::span<const std::uint8_t> pdu,
                            std::span<std::uint8_t> out) noexcept {
        const auto fc = function::diagnostics;
        const auto illegal_function = code_of(exception_code::illegal_function);
        if (!rtu()) return exception(fc, illegal_function, out);
        const std::uint16_t data = load_be16(r.data.data());
        const auto sub = static_cast<diag_sub>(r.value);
        if (sub == diag_sub::return_query_data) return echo(pdu, out);
        if (sub == diag_sub::restart_comm) {
            // Data FF00 also clears the communications event log, which this server has not.
            if (data != 0x0000 && data != 0xFF00)
                return exception(fc, code_of(exception_code::illegal_data_value), out);
            counters_ = {};
            listen_only_ = false;
            return echo(pdu, out);
        }
        if (sub == diag_sub::force_listen_only) {
            if (data != 0x0000)
                return exception(fc, code_of(exception_code::illegal_data_value), out);
            listen_only_ = true;
            return 0; // never answered
        }
        const std::uint16_t* counter = nullptr;
        switch (sub) {
        case diag_sub::clear_counters: break;
        case diag_sub::bus_message_count: counter = &counters_.bus_message; break;
        case diag_sub::bus_comm_error_count: counter = &counters_.bus_comm_error; break;
        case diag_sub::bus_exception_count: counter = &counters_.bus_exception; break;
        case diag_sub::server_message_count: counter = &counters_.server_message; break;
        case diag_sub::server_no_response_count: counter = &counters_.server_no_response; break;
        case diag_sub::server_nak_count: counter = &counters_.server_nak; break;
        case diag_sub::server_busy_count: counter = &counters_.server_busy; break;
        case diag_sub::bus_char_overrun_count: counter = &counters_.bus_char_overrun; break;
        default: return exception(fc, illegal_function, out);
        }
        if (data != 0x0000) return exception(fc, code_of(exception_code::illegal_data_value), out);
        echo(pdu, out);
        if (counter)
            store_be16(&out[3], *counter);
        else
            counters_ = {};
        return 5;
    }

    // FC 43 / MEI 14 (AP §6.21).
    std::size_t device_identification(const request& r, std::span<std::uint8_t> out) noexcept {
        const auto fc = function::encapsulated_interface;
        const bool individual = r.read_device_id_code == 4;
        std::uint8_t id = r.object_id;
        if (individual) {
            if (model_.device_id(id).empty())
                return exception(fc, code_of(exception_code::illegal_data_address), out);
        } else if (id >= basic_objects) {
            id = 0; // an unknown object in a stream: start from the first (§6.21)
        }
        out[0] = static_cast<std::uint8_t>(fc);
        out[1] = mei_read_device_id;
        out[2] = r.read_device_id_code;
        out[3] = conformity_basic;
        out[4] = 0; // more follows
        out[5] = 0; // next object id
        std::uint8_t count = 0;
        std::size_t pos = device_id_header;
        const std::uint8_t last = individual ? id : basic_objects - 1;
        for (;; ++id) {
            const std::string_view v = model_.device_id(id);
            if (!v.empty()) {
                // An object that does not fit waits for the next request, unless it is the
                // first: then it is cut to what fits (a PDU has 253 bytes).
                const std::size_t room = max_pdu - pos - 2;
                if (v.size() > room && count > 0) {
                    out[4] = 0xFF;
                    out[5] = id;
                    break;
                }
                const auto len = static_cast<std::uint8_t>(std::min(v.size(), room));
                out[pos] = id;
                out[pos + 1] = len;
                std::copy_n(v.begin(), len, out.begin() + static_cast<std::ptrdiff_t>(pos) + 2);
                pos += 2u + len;
                ++count;
            }
            if (id == last) break;
        }
        out[6] = count;
        return pos;
    }

    server_config cfg_;
    duration t35_; // of cfg_.format
    M model_;
    diagnostic_counters counters_{};
    server_stats stats_{};
    state state_ = state::listening;
    rtu_receiver<rtu_frames::requests> rtu_{};
    tcp_decoder tcp_{};
    time_point rx_end_{};
    bool garbled_ = false; // errors since the last frame or silence
    bool listen_only_ = false;
    time_point reply_at_{};
    std::array<std::uint8_t, max_tcp_adu> tx_{};
    std::size_t tx_size_ = 0;
    std::uint8_t tx_exception_ = 0;
    held_bytes<Link == link_mode::rtu ? 0 : held_capacity> held_{}; // TCP only
};

} // namespace ferrule::modbus
