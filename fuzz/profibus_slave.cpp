// libFuzzer target: the DP-V0 slave session (profibus::slave, address 8, ident 0x0815, cfg
// 0x11 0x21: 2 bytes in, 2 out) fed telegrams in virtual time.
//
// The input (read through FuzzedDataProvider) picks the baud rate, then a bounded number of
// steps, each one of: deliver a telegram built with encode() (DA 8, 127 or another; any SA;
// a request FC with FCB/FCV, sometimes any FC; a DP SAP or none; a data unit for the service,
// valid or not; maybe a flipped byte; in one or two chunks), deliver raw bytes, deliver the
// last SRD again, let time pass (a little, or beyond the watchdog), call next(now) (now or at
// the deadline it gave), or change the inputs and diagnosis. Then it is drained.
// Seeds: fuzz/corpus/profibus_slave/.
//
// A shadow fdl_decoder, fed the same bytes, says which telegrams the slave decodes; a
// reference model of §B.3 follows them (which request awaits a reply and when, FCB/FCV,
// min_TSDR and the lock of Set_Prm). Invariants (violation -> __builtin_trap):
//   * a reply only for a request to 8 (never to 127 or others), never for SDN; next() says
//     wait until end of request + min_TSDR bit times, then send
//   * every reply is one telegram fdl_decoder decodes whole: the short acknowledgement, or
//     to the request's SA from SA 8 with a response FC (bit 6 clear), SAPs swapped (§B.4)
//   * a repeated SRD (FCV = 1, same FCB, same SA) gets the previous SRD's reply byte for byte
//     and changes neither the outputs nor data_exchanges
//   * Wait_Cfg only after a Set_Prm with ident 0x0815, Data_Exchange only after a Chk_Cfg
//     with exactly the cfg bytes from Wait_Cfg; outputs are zero outside Data_Exchange
//   * a Slave_Diag reply's 6 standard bytes are slave.diagnosis() when it was asked
//   * with no input the session becomes idle within the watchdog time
#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "ferrule/profibus/slave.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::profibus;

constexpr std::uint8_t slave_address = 8;
constexpr std::uint16_t ident = 0x0815;
constexpr std::array<std::uint8_t, 2> cfg_bytes{0x11, 0x21};

// A decoded telegram, kept beyond the shadow decoder's next feed().
struct frame_copy {
    telegram t{};
    std::array<std::uint8_t, max_telegram> data{};
    std::size_t size = 0;

    explicit frame_copy(const telegram& from) : t(from), size(from.data.size()) {
        std::copy(from.data.begin(), from.data.end(), data.begin());
        t.data = {};
    }
    std::span<const std::uint8_t> du() const { return {data.data(), size}; }
};

struct harness {
    FuzzedDataProvider& in;
    slave_config cfg;
    slave s;
    time_point now{};
    fdl_decoder shadow{};

    // Reference model (§B.3).
    bool pending = false; // a reply is due
    time_point reply_at{};
    std::uint8_t reply_sa = 0;
    std::uint8_t reply_dsap = no_sap;
    std::uint8_t reply_ssap = no_sap;
    bool reply_repeat = false;
    bool reply_srd = false;
    bool reply_diag = false; // a Slave_Diag reply whose 6 bytes are known
    std::array<std::uint8_t, diag::standard_size> diag_bytes{};
    std::uint8_t min_tsdr = min_tsdr_bits;
    bool have_last = false;
    std::uint8_t last_sa = 0;
    bool last_fcb = false;
    std::array<std::uint8_t, max_telegram> last_reply{};
    std::size_t last_reply_size = 0;
    bool last_reply_known = false;
    bool have_wait = false;
    time_point wait_deadline{};

    // The last SRD delivered, for a retry.
    std::array<std::uint8_t, max_telegram> last_srd{};
    std::size_t last_srd_size = 0;

    harness(FuzzedDataProvider& p, const slave_config& c) : in(p), cfg(c), s(c) {}

    void check_outputs() {
        if (s.state() == slave_state::data_exchange) return;
        const auto out = s.outputs();
        FERRULE_CHECK(std::all_of(out.begin(), out.end(), [](std::uint8_t b) { return b == 0; }));
    }

    // ---- the model, one decoded telegram at a time -----------------------------------

    struct call_facts {
        bool good_prm = false;  // a Set_Prm the model accepts, ident 0x0815
        bool exact_cfg = false; // a Chk_Cfg with exactly the cfg bytes, after it or Wait_Cfg
        bool repeat = false;    // a repeated SRD
        bool ours = false;      // a request for 8 or 127
        bool diag_last = false; // the last telegram was a Slave_Diag, executed
    };

    void model(const frame_copy& f, time_point end, std::uint8_t& master, slave_state before,
               call_facts& facts) {
        const telegram& t = f.t;
        facts.diag_last = false;
        if (t.frame == frame::sd4 || t.frame == frame::short_ack || !t.is_request()) return;
        if (t.da != slave_address && t.da != broadcast_address) return;
        facts.ours = true;
        pending = false; // the master has moved on
        const auto fn = static_cast<request_fn>(t.function());
        if (fn == request_fn::sdn_high || fn == request_fn::sdn_low) return; // no reply
        if (t.da == broadcast_address) return; // only SDN is broadcast
        reply_sa = t.sa;
        reply_dsap = t.dsap;
        reply_ssap = t.ssap;
        reply_repeat = reply_srd = reply_diag = false;
        const bool srd = fn == request_fn::srd_high || fn == request_fn::srd_low;
        if (srd && t.fcv() && have_last && t.sa == last_sa && t.fcb() == last_fcb) {
            reply_repeat = facts.repeat = true;
        } else if (srd) {
            have_last = true;
            last_sa = t.sa;
            last_fcb = t.fcb();
            last_reply_known = false;
            reply_srd = true;
            if (t.dsap == static_cast<std::uint8_t>(sap::set_prm))
                set_prm(t, f.du(), master, facts);
            if (t.dsap == static_cast<std::uint8_t>(sap::chk_cfg) &&
                std::equal(f.du().begin(), f.du().end(), cfg_bytes.begin(), cfg_bytes.end()) &&
                (before == slave_state::wait_cfg || facts.good_prm))
                facts.exact_cfg = true;
            facts.diag_last = t.dsap == static_cast<std::uint8_t>(sap::slave_diag);
        }
        pending = true;
        reply_at = end + bit_times(cfg.baud, min_tsdr);
    }

    // Set_Prm as §B.5 and the Lock_Req / Unlock_Req table say: Unlock_Req releases the slave;
    // Lock_Req with the right ident and watchdog factors locks it and takes everything;
    // neither overwrites only min_TSDR (and the user parameters).
    void set_prm(const telegram& t, std::span<const std::uint8_t> du, std::uint8_t& master,
                 call_facts& facts) {
        if (master != diag::no_master && t.sa != master) return;
        const auto p = parse_prm(du);
        if (!p) return;
        if (p->station_status & prm::unlock_req) {
            master = diag::no_master;
            return;
        }
        if (p->user.size() > max_data) return;
        const bool lock = p->station_status & prm::lock_req;
        if (lock &&
            (p->ident != ident || (p->watchdog_on() && (p->wd_fact1 == 0 || p->wd_fact2 == 0))))
            return;
        if (p->min_tsdr != 0) min_tsdr = p->min_tsdr;
        if (!lock) return;
        facts.good_prm = true;
        master = t.sa;
    }

    // ---- delivery --------------------------------------------------------------------

    // Bytes that the slave gets in one on_receive(), ending at `end`, with the telegrams the
    // shadow found in them.
    void call(std::span<const std::uint8_t> bytes, time_point end,
              const std::vector<frame_copy>& frames) {
        const slave_state before = s.state();
        const std::uint32_t expiries = s.stats().watchdog_expiries;
        const std::uint32_t exchanges = s.stats().data_exchanges;
        std::array<std::uint8_t, slave::max_io> outputs{};
        std::copy(s.outputs().begin(), s.outputs().end(), outputs.begin());
        std::uint8_t master = s.master_address();
        s.on_receive(bytes, end);
        // A watchdog expiry happens before the first request of the call is handled.
        const bool expired = s.stats().watchdog_expiries != expiries;
        if (expired) master = diag::no_master;
        const slave_state from = expired ? slave_state::wait_prm : before;
        call_facts facts;
        for (const frame_copy& f : frames) model(f, end, master, from, facts);
        FERRULE_CHECK(s.master_address() == master);
        if (frames.empty() || !facts.ours) FERRULE_CHECK(s.state() == before);
        const slave_state after = s.state();
        if (after == slave_state::wait_cfg && before != slave_state::wait_cfg)
            FERRULE_CHECK(facts.good_prm);
        if (after == slave_state::data_exchange && before != slave_state::data_exchange)
            FERRULE_CHECK(facts.exact_cfg);
        if (frames.size() == 1 && facts.repeat) {
            FERRULE_CHECK(s.stats().data_exchanges == exchanges);
            if (!expired) {
                FERRULE_CHECK(after == before);
                FERRULE_CHECK(std::equal(s.outputs().begin(), s.outputs().end(), outputs.begin()));
            }
        }
        if (pending && facts.diag_last) {
            std::array<std::uint8_t, max_data> du{};
            const auto n = encode_slave_diag(s.diagnosis(), du);
            FERRULE_CHECK(n.has_value());
            std::copy_n(du.begin(), diag_bytes.size(), diag_bytes.begin());
            reply_diag = true;
        }
        have_wait = false;
        check_outputs();
    }

    // Splits `bytes` into the slave's on_receive() calls as the shadow decoder frames them:
    // a call ends where feeding its bytes would give need_more again.
    void deliver(std::span<const std::uint8_t> bytes) {
        const time_point start = now;
        std::vector<frame_copy> frames;
        std::size_t begin = 0;
        std::size_t pos = 0;
        auto rest = bytes;
        const auto flush = [&] {
            now = start + cfg_format().chars_time(pos);
            call(bytes.subspan(begin, pos - begin), now, frames);
            frames.clear();
            begin = pos;
        };
        for (;;) {
            const auto st = shadow.feed(rest);
            if (st.consumed > 0 && (pos > begin || !frames.empty())) flush();
            pos += st.consumed;
            rest = rest.subspan(st.consumed);
            if (st.what == fdl_decoder::status::frame) frames.emplace_back(shadow.telegram());
            if (st.what == fdl_decoder::status::need_more) break;
        }
        if (pos > begin || !frames.empty()) flush();
        now = start + cfg_format().chars_time(bytes.size());
    }

    serial_format cfg_format() const { return format(cfg.baud); }

    // ---- building telegrams ----------------------------------------------------------

    std::uint8_t pick_da() {
        switch (in.ConsumeIntegralInRange<unsigned>(0, 5)) {
        case 0: return broadcast_address;
        case 1: return in.ConsumeIntegralInRange<std::uint8_t>(0, 127);
        default: return slave_address;
        }
    }

    std::uint8_t pick_sa() {
        switch (in.ConsumeIntegralInRange<unsigned>(0, 3)) {
        case 0: return 3;
        case 1: return in.ConsumeIntegralInRange<std::uint8_t>(0, 127);
        default: return 2;
        }
    }

    std::uint8_t pick_fc(request_fn usual) {
        constexpr request_fn others[] = {
            request_fn::time_event, request_fn::sda_low,     request_fn::sdn_low,
            request_fn::sda_high,   request_fn::sdn_high,    request_fn::msrd,
            request_fn::fdl_status, request_fn::srd_low,     request_fn::srd_high,
            request_fn::ident,      request_fn::lsap_status,
        };
        const unsigned how = in.ConsumeIntegralInRange<unsigned>(0, 9);
        if (how == 0) return in.ConsumeIntegral<std::uint8_t>();
        const request_fn f =
            how == 1 ? others[in.ConsumeIntegralInRange<std::size_t>(0, 10)] : usual;
        const bool fcb = in.ConsumeBool();
        const bool fcv = in.ConsumeBool();
        return request_code(f, fcb, fcv);
    }

    std::uint8_t pick_sap(std::uint8_t usual) {
        switch (in.ConsumeIntegralInRange<unsigned>(0, 7)) {
        case 0: return no_sap;
        case 1: return in.ConsumeIntegralInRange<std::uint8_t>(55, 62);
        case 2: return in.ConsumeIntegralInRange<std::uint8_t>(0, 63);
        default: return usual;
        }
    }

    std::size_t random_bytes(std::span<std::uint8_t> out, std::size_t most) {
        const std::size_t n = in.ConsumeIntegralInRange<std::size_t>(0, most);
        for (std::size_t i = 0; i < n; ++i) out[i] = in.ConsumeIntegral<std::uint8_t>();
        return n;
    }

    std::size_t prm_bytes(std::span<std::uint8_t> out) {
        prm_data p;
        p.station_status =
            in.ConsumeIntegral<std::uint8_t>() &
            (prm::lock_req | prm::unlock_req | prm::sync_req | prm::freeze_req | prm::wd_on);
        p.wd_fact1 = in.ConsumeIntegralInRange<std::uint8_t>(0, 10);
        p.wd_fact2 = in.ConsumeIntegralInRange<std::uint8_t>(0, 10);
        constexpr std::uint8_t tsdrs[] = {0, 11, 20, 60};
        p.min_tsdr = in.ConsumeBool() ? tsdrs[in.ConsumeIntegralInRange<std::size_t>(0, 3)]
                                      : in.ConsumeIntegral<std::uint8_t>();
        p.ident = in.ConsumeIntegralInRange<unsigned>(0, 7) != 0
                      ? ident
                      : in.ConsumeIntegral<std::uint16_t>();
        p.group = in.ConsumeIntegral<std::uint8_t>();
        std::array<std::uint8_t, 4> user{};
        p.user = std::span<const std::uint8_t>(user.data(), random_bytes(user, user.size()));
        const auto n = encode_prm(p, out);
        FERRULE_CHECK(n.has_value());
        // Sometimes cut short: a malformed Set_Prm.
        return in.ConsumeIntegralInRange<unsigned>(0, 15) == 0
                   ? in.ConsumeIntegralInRange<std::size_t>(0, *n)
                   : *n;
    }

    void send_telegram() {
        telegram t;
        std::array<std::uint8_t, 32> du{};
        std::size_t n = 0;
        const auto service = in.ConsumeIntegralInRange<unsigned>(0, 9);
        t.da = pick_da();
        t.sa = pick_sa();
        t.ssap = master_sap;
        const auto sap_of = [](sap s) { return static_cast<std::uint8_t>(s); };
        switch (service) {
        case 0:
            t.fc = pick_fc(request_fn::fdl_status);
            t.ssap = no_sap;
            break;
        case 1:
            t.fc = pick_fc(request_fn::srd_high);
            t.dsap = sap_of(sap::slave_diag);
            break;
        case 2:
            t.fc = pick_fc(request_fn::srd_high);
            t.dsap = sap_of(sap::set_prm);
            n = prm_bytes(du);
            break;
        case 3:
            t.fc = pick_fc(request_fn::srd_high);
            t.dsap = sap_of(sap::chk_cfg);
            if (in.ConsumeIntegralInRange<unsigned>(0, 3) != 0) {
                std::copy(cfg_bytes.begin(), cfg_bytes.end(), du.begin());
                n = cfg_bytes.size();
            } else {
                n = random_bytes(du, 4);
            }
            break;
        case 4:
            t.fc = pick_fc(request_fn::sdn_high);
            t.dsap = sap_of(sap::global_control);
            du[0] = in.ConsumeIntegral<std::uint8_t>();
            du[1] = in.ConsumeBool() ? 0 : in.ConsumeIntegral<std::uint8_t>();
            n = in.ConsumeIntegralInRange<unsigned>(0, 7) != 0 ? 2 : random_bytes(du, 3);
            break;
        case 5:
            t.fc = pick_fc(request_fn::srd_high);
            t.dsap = pick_sap(sap_of(sap::get_cfg));
            break;
        case 6:
            t.fc = pick_fc(request_fn::srd_high);
            t.dsap =
                pick_sap(in.ConsumeBool() ? sap_of(sap::read_inputs) : sap_of(sap::read_outputs));
            break;
        default: // Data_Exchange: default SAPs, 2 output bytes
            t.fc = pick_fc(request_fn::srd_high);
            t.ssap = no_sap;
            if (in.ConsumeIntegralInRange<unsigned>(0, 5) != 0) {
                du[0] = in.ConsumeIntegral<std::uint8_t>();
                du[1] = in.ConsumeIntegral<std::uint8_t>();
                n = 2;
            } else {
                n = random_bytes(du, 9);
            }
            break;
        }
        if (in.ConsumeIntegralInRange<unsigned>(0, 7) == 0) t.dsap = pick_sap(t.dsap);
        if (in.ConsumeIntegralInRange<unsigned>(0, 7) == 0) t.ssap = pick_sap(t.ssap);
        t.data = std::span<const std::uint8_t>(du.data(), n);
        std::array<std::uint8_t, max_telegram> buf{};
        const auto size = encode(t, buf);
        FERRULE_CHECK(size.has_value());
        if (in.ConsumeIntegralInRange<unsigned>(0, 15) == 0) {
            const auto at = in.ConsumeIntegralInRange<std::size_t>(0, *size - 1);
            buf[at] ^= static_cast<std::uint8_t>(in.ConsumeIntegralInRange<unsigned>(1, 255));
        }
        const auto bytes = std::span<const std::uint8_t>(buf.data(), *size);
        if ((t.fc & fc_function_mask) == static_cast<std::uint8_t>(request_fn::srd_high) ||
            (t.fc & fc_function_mask) == static_cast<std::uint8_t>(request_fn::srd_low)) {
            std::copy(bytes.begin(), bytes.end(), last_srd.begin());
            last_srd_size = bytes.size();
        }
        const std::size_t split = in.ConsumeBool()
                                      ? in.ConsumeIntegralInRange<std::size_t>(0, bytes.size())
                                      : bytes.size();
        deliver(bytes.first(split));
        if (split < bytes.size()) {
            now += std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 300));
            deliver(bytes.subspan(split));
        }
    }

    void send_random() {
        std::array<std::uint8_t, 32> buf{};
        const std::size_t n = std::max<std::size_t>(1, random_bytes(buf, buf.size()));
        deliver(std::span<const std::uint8_t>(buf.data(), n));
    }

    // ---- next() ----------------------------------------------------------------------

    void on_send(std::span<const std::uint8_t> bytes) {
        FERRULE_CHECK(pending && now >= reply_at);
        pending = false;
        fdl_decoder d;
        const auto st = d.feed(bytes);
        FERRULE_CHECK(st.what == fdl_decoder::status::frame && st.consumed == bytes.size());
        FERRULE_CHECK(d.bytes().size() == bytes.size());
        const telegram& r = d.telegram();
        FERRULE_CHECK(r.frame != frame::sd4);
        if (r.frame != frame::short_ack) {
            FERRULE_CHECK(r.da == reply_sa && r.sa == slave_address && !r.is_request());
            FERRULE_CHECK((r.fc & 0x30) == station_slave);
            // A repeat carries the stored reply, whatever SAPs the retry names.
            if (!reply_repeat && (r.dsap != no_sap || r.ssap != no_sap))
                FERRULE_CHECK(r.dsap == reply_ssap && r.ssap == reply_dsap);
            if (reply_diag) {
                FERRULE_CHECK(r.data.size() >= diag::standard_size);
                FERRULE_CHECK(std::equal(diag_bytes.begin(), diag_bytes.end(), r.data.begin()));
            }
        }
        if (reply_repeat && last_reply_known)
            FERRULE_CHECK(std::equal(bytes.begin(), bytes.end(), last_reply.begin(),
                                     last_reply.begin() + static_cast<long>(last_reply_size)));
        if (reply_srd || reply_repeat) {
            std::copy(bytes.begin(), bytes.end(), last_reply.begin());
            last_reply_size = bytes.size();
            last_reply_known = true;
        }
    }

    session_action call_next() {
        const auto a = s.next(now);
        if (pending && now < reply_at)
            FERRULE_CHECK(a.what == session_action::kind::wait && a.deadline == reply_at);
        if (pending && now >= reply_at) FERRULE_CHECK(a.what == session_action::kind::send);
        switch (a.what) {
        case session_action::kind::send: on_send(a.bytes); break;
        case session_action::kind::wait:
            FERRULE_CHECK(a.deadline > now && a.deadline != never);
            have_wait = true;
            wait_deadline = a.deadline;
            break;
        case session_action::kind::idle: FERRULE_CHECK(!pending && s.wake_at() == never); break;
        case session_action::kind::done: FERRULE_CHECK(false); break;
        }
        check_outputs();
        return a;
    }

    void application() {
        switch (in.ConsumeIntegralInRange<unsigned>(0, 2)) {
        case 0: {
            const std::array<std::uint8_t, 2> v{in.ConsumeIntegral<std::uint8_t>(),
                                                in.ConsumeIntegral<std::uint8_t>()};
            s.set_inputs(v);
            break;
        }
        case 1: {
            std::array<std::uint8_t, 8> block{};
            const std::size_t n = random_bytes(block, block.size());
            s.set_ext_diag({block.data(), n}, in.ConsumeBool());
            break;
        }
        default: s.set_stat_diag(in.ConsumeBool()); break;
        }
    }

    void step() {
        switch (in.ConsumeIntegralInRange<unsigned>(0, 15)) {
        case 0:
        case 1:
        case 2:
        case 3:
        case 4:
        case 5: send_telegram(); break;
        case 6: send_random(); break;
        case 7:
            if (last_srd_size > 0) deliver({last_srd.data(), last_srd_size});
            break;
        case 8:
        case 9:
            now += std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 3000));
            break;
        case 10:
            now += std::chrono::milliseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 3000));
            break;
        case 11:
            if (have_wait && wait_deadline > now) now = wait_deadline;
            (void)call_next();
            break;
        case 12: application(); break;
        default: (void)call_next(); break;
        }
    }

    // No input: a due reply goes out, then the watchdog (at most 255 × 255 × 10 ms) ends.
    void drain() {
        const time_point limit = now + bit_times(cfg.baud, 255) + std::chrono::seconds(651);
        for (int i = 0; i < 6; ++i) {
            const auto a = call_next();
            if (a.what == session_action::kind::idle) return;
            if (a.what == session_action::kind::wait) now = a.deadline;
            FERRULE_CHECK(now <= limit);
        }
        FERRULE_CHECK(false);
    }
};

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    FuzzedDataProvider in(data, size);
    slave_config cfg;
    constexpr std::uint32_t bauds[] = {19'200, 9'600, 187'500, 1'500'000};
    cfg.baud = bauds[in.ConsumeIntegralInRange<std::size_t>(0, 3)];
    cfg.address = slave_address;
    cfg.ident = ident;
    cfg.cfg = cfg_bytes;
    cfg.sd2_for_8_bytes = in.ConsumeBool();

    harness h(in, cfg);
    for (int i = 0; i < 96 && in.remaining_bytes() > 0; ++i) h.step();
    h.drain();
    return 0;
}
