// `ferrule demo`: simulated devices on pseudo-terminals, and a short session against them
// through the real serial driver, as it would run against hardware on /dev/ttyUSB0; and a
// simulated MP2310 that two PCs reach over TCP at once.
#include <asio/post.hpp>

#include <atomic>
#include <chrono>
#include <memory>
#include <thread>

#include "commands.hpp"
#include "common.hpp"
#include "ferrule/dimetix/access.hpp"
#include "ferrule/dimetix/sim/sensor.hpp"
#include "ferrule/host/memobus_server.hpp"
#include "ferrule/host/pty_server.hpp"
#include "ferrule/host/serve.hpp"
#include "ferrule/lecom/access.hpp"
#include "ferrule/lecom/poller.hpp"
#include "ferrule/lecom/sim/station.hpp"
#include "ferrule/memobus/access.hpp"
#include "ferrule/memobus/register_image.hpp"
#include "ferrule/modbus/access.hpp"
#include "ferrule/modbus/sim/station.hpp"
#include "ferrule/movilink/access.hpp"
#include "ferrule/movilink/process_data.hpp"
#include "ferrule/movilink/sim/station.hpp"
#include "lecom_text.hpp"
#include "modbus_text.hpp"

namespace ferrule::cli {
namespace {

namespace ml = ferrule::movilink;
namespace dx = ferrule::dimetix;
namespace lc = ferrule::lecom;
namespace mb = ferrule::modbus;
namespace mm = ferrule::memobus;
using namespace std::chrono_literals;

// A pty_server on its own thread; pause() stops it so the demo can change a device.
template <class Station>
class background_server {
public:
    explicit background_server(host::pty_server<Station>& server) : server_(server) { resume(); }
    ~background_server() { pause(); }
    void pause() {
        stop_ = true;
        if (thread_.joinable()) thread_.join();
    }
    void resume() {
        stop_ = false;
        thread_ = std::thread([this] { server_.run(stop_); });
    }

private:
    host::pty_server<Station>& server_;
    std::atomic<bool> stop_{false};
    std::thread thread_;
};

struct demo_options {
    bool trace = false;
};

int fail(const char* what, std::error_code ec) {
    fmt::print("  {} failed: {}\n", what, ec.message());
    const bool device =
        ec.category() == ml::device_category() || ec.category() == dx::device_category() ||
        ec.category() == lc::device_category() || ec.category() == mb::device_category() ||
        ec.category() == mm::device_category();
    return device ? exit_device_error : exit_transport;
}

// A D-Series sensor on its own pty: connect, measure ten times, and a measurement error.
int sensor_part(const demo_options& d) {
    dx::sim::d_series_config cfg;
    cfg.id = 0; // the factory ID
    cfg.shape = dx::sim::profile::ramp;
    cfg.distance = 12'345; // 1234.5 mm, moving away at 20 mm/s, +-0.3 mm noise
    cfg.slope = 200;
    cfg.noise = 3;
    cfg.measurement_time = 60ms;
    dx::sim::d_series sensor(cfg);
    host::pty_server<dx::sim::d_series> line;
    if (auto ec = line.open()) return fail("openpty", ec);
    line.add(sensor);
    sensor.power_on(host::steady_now());
    background_server<dx::sim::d_series> server(line);

    fmt::print("\n5. A simulated Dimetix D-Series laser distance sensor (ID 0, 19200 7E1) on {}\n",
               line.path());
    common_options o;
    o.port = line.path();
    o.trace = d.trace;
    const auto port = port_session::open(o, dx::default_format);
    if (!port) return exit_transport;
    auto& stream = port->stream();
    dx::sensor s;
    if (auto ec = dx::connect(stream, s, 0)) return fail("connect (sNc until g0?)", ec);
    fmt::print("  connected: sNc answered with g0? (the paper's start-up)\n");
    for (int i = 1; i <= 10; ++i) {
        const auto m = dx::measure(stream, s, 0);
        if (!m) return fail("measure", m.error());
        fmt::print("  measurement {:2}: {:8.1f} mm\n", i, m->distance / 10.0);
    }
    const auto t = dx::temperature(stream, s, 0);
    if (!t) return fail("temperature", t.error());
    fmt::print("  sensor temperature {:.1f} degC\n", *t / 10.0);
    server.pause();
    sensor.inject_error(255); // the target leaves the beam
    server.resume();
    const auto lost = dx::measure(stream, s, 0);
    fmt::print("  with the target gone: {}\n",
               lost ? "unexpectedly measured" : std::error_code(lost.error()).message());
    const auto again = dx::measure(stream, s, 0);
    if (!again) return fail("measure", again.error());
    fmt::print("  and back: {:.1f} mm\n", again->distance / 10.0);
    return exit_ok;
}

// Six Lenze 4900 DC drives on one LECOM-B line, as in the LECOM paper: parameters, a poll
// of all six while they ramp, a broadcast stop, and the drives' error answers.
int lecom_part(const demo_options& d) {
    std::array<lc::sim::station, 6> drives;
    host::pty_server<lc::sim::station> bus;
    if (auto ec = bus.open()) return fail("openpty", ec);
    for (std::size_t i = 0; i < drives.size(); ++i) {
        lc::slave_config cfg;
        cfg.address = static_cast<std::uint8_t>(i + 1);
        drives[i] = lc::sim::station(cfg);
        bus.add(drives[i]);
    }
    background_server<lc::sim::station> server(bus);

    fmt::print("\n6. Six simulated Lenze 4900 DC drives (LECOM-B addresses 1-6, profile {}: "
               "9600 8E1) on {}\n",
               lc::lenze_4900.name, bus.path());
    common_options o;
    o.port = bus.path();
    o.trace = d.trace;
    const auto port = port_session::open(o, lc::lenze_4900.format);
    if (!port) return exit_transport;
    auto& line = port->stream();
    lc::master m;

    const auto id = lc::read(line, m, 1, lc::code(200));
    if (!id) return fail("read C0200", id.error());
    fmt::print("  drive 1 C0200 software id = {}\n", value_text(*id));
    for (std::uint8_t a = 1; a <= 6; ++a) {
        // A short ramp (C0012, seconds) so the demo shows it, then speed setpoints (C0046).
        if (auto ec = lc::write(line, m, a, lc::code(12), *lc::decimal(1)))
            return fail("write C0012", ec);
        if (auto ec = lc::write(line, m, a, lc::code(46), *lc::decimal(250 * a)))
            return fail("write C0046", ec);
    }
    fmt::print("  wrote C0012 = 1 s and C0046 = 250, 500, ... 1500 rpm to drives 1-6 (ACK each)\n");

    lc::poller<6> p;
    for (std::uint8_t a = 1; a <= 6; ++a) (void)p.add({a, lc::code(50)});
    const auto show = [&] {
        std::string row = "  C0050 actual speed [rpm]:";
        for (std::size_t i = 0; i < 6; ++i)
            row += p.state(i).valid ? fmt::format(" {:7.0f}", p.state(i).last.fixed / 1e4)
                                    : "       -";
        fmt::print("{}   (poll cycle {:.1f} ms on the pty)\n", row,
                   std::chrono::duration<double, std::milli>(p.last_cycle_time()).count());
    };
    const auto until = line.now() + 1200ms;
    if (auto ec = host::serve_while(line, p, 200ms, [&] {
            if (p.cycles() > 0) show();
            return line.now() < until;
        }))
        return fail("poll", ec);

    fmt::print("  broadcast C0040 = 0 (controller inhibit) to address 00: no reply by design\n");
    if (auto ec = lc::write(line, m, lc::broadcast_address, lc::code(40), *lc::decimal(0)))
        return fail("broadcast", ec);
    const auto stopped = p.cycles() + 2;
    if (auto ec = host::serve_while(line, p, 50ms, [&] { return p.cycles() < stopped; }))
        return fail("poll", ec);
    show();

    fmt::print("  faults:\n");
    const auto missing = lc::read(line, m, 1, lc::code(999));
    fmt::print("    read C0999 on drive 1: {}\n",
               missing ? "unexpectedly answered" : std::error_code(missing.error()).message());
    const auto refused = lc::write(line, m, 1, lc::code(50), *lc::decimal(100));
    fmt::print("    write read-only C0050 on drive 1: {}\n", refused ? refused.message() : "ACK");
    server.pause();
    drives[3].drive.trip(11);
    server.resume();
    const auto trip = lc::read(line, m, 4, lc::code(67));
    if (!trip) return fail("read C0067", trip.error());
    fmt::print("    drive 4 tripped: C0067 trip number = {}\n", value_text(*trip));
    lc::master_config quick;
    quick.response_timeout = 50ms;
    lc::master short_wait(quick);
    const auto absent = lc::read(line, short_wait, 7, lc::code(50));
    fmt::print("    read from address 7, where no drive is: {} after {} requests\n",
               absent ? "unexpectedly answered" : std::error_code(absent.error()).message(),
               short_wait.attempts());
    return exit_ok;
}

// The gateway paper's VFD on Modbus RTU: its status, the paper's start command, the ramp,
// a stop, an exception and a unit that is not there.
int modbus_part(const demo_options& d) {
    namespace reg = mb::sim::vfd_register;
    mb::server_config cfg;
    cfg.units = {1};
    cfg.format = {host::pty_line_baud, 8, parity::even, 1}; // frames end after 1.75 ms
    mb::sim::station vfd(cfg);
    host::pty_server<mb::sim::station> line;
    if (auto ec = line.open()) return fail("openpty", ec);
    line.add(vfd);
    background_server<mb::sim::station> server(line);

    fmt::print("\n7. A simulated VFD (Modbus RTU unit 1, 19200 8E1) on {}\n", line.path());
    common_options o;
    o.port = line.path();
    o.trace = d.trace;
    const auto port = port_session::open(o, mb::default_format);
    if (!port) return exit_transport;
    auto& stream = port->stream();
    mb::client c;
    std::array<std::uint16_t, 2> live{}; // status word, output frequency
    const auto read_live = [&] {
        return mb::read_holding_registers(stream, c, 1, reg::status_word, live);
    };
    if (auto ec = read_live()) return fail("read 0xC802", ec);
    fmt::print("  status word 0xC802 = 0x{:04X}, output frequency 0xC803 = {:.2f} Hz\n", live[0],
               live[1] / 100.0);
    const std::array<std::uint16_t, 2> ramps{10, 10}; // 1.0 s from 0 to 50 Hz and back
    if (auto ec = mb::write_registers(stream, c, 1, reg::acceleration_time, ramps))
        return fail("write 0xC901", ec);
    if (auto ec = mb::write_register(stream, c, 1, reg::frequency_setpoint, 2500))
        return fail("write 0xC801", ec);
    fmt::print(
        "  wrote ramps 0xC901-0xC902 = 1.0 s (FC 16) and setpoint 0xC801 = 25.00 Hz (FC 6)\n");
    if (auto ec = mb::write_register(stream, c, 1, reg::control_word, mb::sim::control::start))
        return fail("start", ec);
    fmt::print("  start, the paper's frame: {} -> echoed: write single register 0xC800 = 0x0025\n",
               hex(c.request_bytes()));
    const auto show_ramp = [&](std::uint16_t until_hz) -> std::error_code {
        const auto t0 = std::chrono::steady_clock::now();
        for (;;) {
            std::this_thread::sleep_for(100ms);
            if (auto ec = read_live()) return ec;
            const double t =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            fmt::print("  t={:4.2f} s  status 0x{:04X}  output frequency {:5.2f} Hz\n", t, live[0],
                       live[1] / 100.0);
            if (live[1] == until_hz) return {};
            if (t > 5) return ferrule::error(errc::timeout);
        }
    };
    if (auto ec = show_ramp(2500)) return fail("ramp", ec);
    if (auto ec = mb::write_register(stream, c, 1, reg::control_word,
                                     mb::sim::control::enable | mb::sim::control::setpoint_enable))
        return fail("stop", ec);
    fmt::print("  stop with the ramp: 0xC800 = 0x0024 (run bit off)\n");
    if (auto ec = show_ramp(0)) return fail("ramp down", ec);
    std::array<std::uint16_t, 1> one{};
    const auto unmapped = mb::read_holding_registers(stream, c, 1, 0x0000, one);
    fmt::print("  read register 0x0000, which the drive does not have: {}\n",
               unmapped ? error_text(unmapped) : "unexpectedly answered");
    mb::client_config quick;
    quick.response_timeout = 50ms;
    quick.retries = 2;
    mb::client short_wait(quick);
    const auto absent = mb::read_holding_registers(stream, short_wait, 7, reg::status_word, one);
    fmt::print("  read from unit 7, where no drive is: {} after {} requests\n",
               absent ? error_text(absent) : "unexpectedly answered", short_wait.attempts());
    return exit_ok;
}

// Two PCs on two channels of one MP2310 at once, as in seeds/004: the controller's Extended
// MEMOBUS server on an io_context thread, two TCP connections held open together, and each
// PC on its own thread writing and reading back its own MW block.
int memobus_part(const demo_options& d) {
    using image_type = mm::register_image<4096, 64>;
    asio::io_context server_ctx;
    const auto image = std::make_unique<image_type>();
    host::memobus_server<image_type> controller(server_ctx.get_executor(), *image);
    if (auto ec = controller.listen({asio::ip::make_address("127.0.0.1"), 0}))
        return fail("listen", ec);
    std::thread server_thread([&] { server_ctx.run(); });
    const auto stop_server = [&] {
        asio::post(server_ctx, [&] { controller.close(); });
        server_ctx.stop();
        server_thread.join();
    };

    fmt::print("\n8. A simulated Yaskawa MP2310 (Extended MEMOBUS, 218IFA: {} channels) on "
               "127.0.0.1:{}\n",
               controller.max_channels(), controller.port());
    struct pc {
        asio::io_context ctx;
        asio::ip::tcp::socket socket{ctx};
        host::tcp_stream line{ctx, socket};
        mm::master master;
        std::uint16_t first = 0;
        std::array<std::uint16_t, 10> written{};
        std::array<std::uint16_t, 10> read{};
        std::error_code ec;
    };
    std::array<pc, 2> pcs;
    for (std::size_t i = 0; i < pcs.size(); ++i) {
        auto& p = pcs[i];
        p.socket.connect({asio::ip::make_address("127.0.0.1"), controller.port()}, p.ec);
        if (p.ec) {
            stop_server();
            return fail("connect", p.ec);
        }
        if (d.trace) p.line.set_tap(trace_tap(host::steady_now()));
        p.first = static_cast<std::uint16_t>(1000 * (i + 1));
        for (std::size_t k = 0; k < p.written.size(); ++k)
            p.written[k] = static_cast<std::uint16_t>(p.first + 100 * i + k);
    }
    const auto work = [](pc& p) {
        for (int round = 0; round < 20 && !p.ec; ++round) {
            p.ec = mm::write_words(p.line, p.master, mm::mw(p.first), p.written);
            if (!p.ec) p.ec = mm::read_words(p.line, p.master, mm::mw(p.first), p.read);
            if (!p.ec && p.read != p.written) p.ec = ferrule::error(errc::malformed);
        }
    };
    std::thread second([&] { work(pcs[1]); });
    work(pcs[0]);
    second.join();
    for (std::size_t i = 0; i < pcs.size(); ++i) {
        const auto& p = pcs[i];
        if (p.ec) {
            stop_server();
            return fail("write and read back", p.ec);
        }
        fmt::print("  PC {} wrote MW{:05}-MW{:05} = {}..{} (SFC 0B) and read them back (SFC 09) "
                   "20 times: ok\n",
                   i + 1, p.first, p.first + 9, p.written.front(), p.written.back());
    }
    for (std::size_t i = 0; i < pcs.size(); ++i) {
        const auto c = controller.channel_stats(i);
        fmt::print("  controller channel {}: {} requests, {} answered\n", i + 1, c.requests,
                   c.responses);
    }
    std::array<std::uint16_t, 2> beyond{};
    const auto refused = mm::read_words(pcs[0].line, pcs[0].master, mm::mw(4095), beyond);
    fmt::print("  PC 1 reads MW04095-MW04096, beyond the image: {}\n",
               refused ? refused.message() : "unexpectedly answered");
    stop_server();
    return exit_ok;
}

int run_demo(const demo_options& d) {
    ml::slave_config on_pty;
    on_pty.format.baud = host::pty_line_baud;
    on_pty.address = 1;
    ml::sim::station drive1(on_pty);
    on_pty.address = 2;
    ml::sim::station drive2(on_pty);
    host::pty_server<ml::sim::station> bus;
    if (auto ec = bus.open()) return fail("openpty", ec);
    bus.add(drive1);
    bus.add(drive2);
    background_server<ml::sim::station> server(bus);

    fmt::print("ferrule demo\n"
               "Two simulated SEW MOVITRAC B drives (RS-485 addresses 1 and 2) are on {}.\n"
               "This session reaches them through ferrule's serial driver, as it would reach a\n"
               "real RS-485 line on /dev/ttyUSB0 (a pty ignores baud rate and parity).\n\n",
               bus.path());

    common_options o;
    o.port = bus.path();
    o.trace = d.trace;
    const auto port = port_session::open(o, ml::default_format);
    if (!port) return exit_transport;
    auto& line = port->stream();
    ml::master m; // the manual's timing: 3.44 ms start pause, 50 ms timeout, 4 resends

    fmt::print("1. Drive parameters (MOVILINK parameter channel, acyclic PARAM)\n");
    struct named {
        const char* text;
        std::uint8_t address;
        std::uint16_t index;
    };
    for (const named p :
         {named{"drive 1 P070 unit type", 1, ml::parameter_index::p070_unit_type},
          named{"drive 1 P014 heat sink temperature [degC]", 1,
                ml::parameter_index::p014_heat_sink_temperature},
          named{"drive 2 P810 RS-485 address", 2, ml::parameter_index::p810_rs485_address}}) {
        const auto v = ml::read_parameter(line, m, p.address, p.index);
        if (!v) return fail(p.text, v.error());
        fmt::print("  {:<44} = {} (0x{:08X})\n", p.text, static_cast<std::int32_t>(*v), *v);
    }

    fmt::print("\n2. Run drive 1 to 1500 rpm (cyclic 3PD: control word enable, speed, ramp 1 s)\n");
    std::array<std::uint16_t, 3> po{ml::control_word::enable().value, ml::rpm_to_digits(1500),
                                    ml::ramp_to_digits(1000ms)};
    const auto show_until = [&](std::uint16_t speed_digits) -> std::error_code {
        const auto start = std::chrono::steady_clock::now();
        auto last = start - 1h;
        for (;;) {
            const auto pi = ml::exchange(line, m, 1, po);
            if (!pi) return pi.error();
            const auto now = std::chrono::steady_clock::now();
            const bool reached = pi->words[1] == speed_digits;
            if (reached || now - last >= 150ms) {
                const ml::status_word sw{pi->words[0]};
                fmt::print(
                    "  t={:5.2f} s  status 0x{:04X} (ready {}, output stage {})  speed {:7.1f} rpm"
                    "  current {:5.1f} % I_N\n",
                    std::chrono::duration<double>(now - start).count(), sw.value,
                    sw.ready() ? 1 : 0, sw.output_stage_enabled() ? 1 : 0,
                    ml::digits_to_rpm(pi->words[1]), ml::digits_to_current(pi->words[2]));
                last = now;
            }
            if (reached) return {};
            if (now - start > 10s) return ferrule::error(errc::timeout);
        }
    };
    if (auto ec = show_until(po[1])) return fail("run", ec);

    fmt::print("\n3. Stop with the ramp (control word 0x0002)\n");
    po[0] = ml::control_word::stop().value;
    if (auto ec = show_until(0)) return fail("stop", ec);

    fmt::print("\n4. Faults and how ferrule reports them\n");
    const auto bad = ml::read_parameter(line, m, 1, 0x1234);
    fmt::print("  read index 0x1234 on drive 1: {}\n",
               bad ? "unexpectedly answered" : std::error_code(bad.error()).message());
    m.reset_fault();
    server.pause();
    drive1.drive.inject_fault(43); // as if the drive's own RS-485 timeout (F43) had tripped
    server.resume();
    auto pi = ml::exchange(line, m, 1, po);
    if (!pi) return fail("exchange", pi.error());
    ml::status_word sw{pi->words[0]};
    fmt::print("  drive 1 status word 0x{:04X}: fault bit {}, fault number {}\n", sw.value,
               sw.fault() ? 1 : 0, sw.fault_number());
    po[0] = ml::control_word::stop().with_reset().value;
    pi = ml::exchange(line, m, 1, po);
    if (!pi) return fail("reset", pi.error());
    sw = ml::status_word{pi->words[0]};
    fmt::print(
        "  after the reset bit (control word 0x{:04X}): status word 0x{:04X}, fault bit {}\n",
        po[0], sw.value, sw.fault() ? 1 : 0);
    const auto silent = ml::read_parameter(line, m, 7, ml::parameter_index::p000_speed);
    fmt::print("  read from address 7, where no drive is: {} after {} requests\n",
               silent ? "unexpectedly answered" : std::error_code(silent.error()).message(),
               m.attempts());

    const auto& s = m.stats();
    fmt::print("  MOVILINK master: {} transactions, {} succeeded, {} failed, {} resends\n",
               s.transactions, s.succeeded, s.failed, s.resends);
    if (const int rc = sensor_part(d)) return rc;
    if (const int rc = lecom_part(d)) return rc;
    if (const int rc = modbus_part(d)) return rc;
    return memobus_part(d);
}

} // namespace

void add_demo(CLI::App& app, int& exit_status) {
    auto* sub = app.add_subcommand(
        "demo", "simulated devices on pseudo-terminals and a session against them");
    auto o = std::make_shared<demo_options>();
    sub->add_flag("--trace", o->trace, "print every frame as hex with direction and time (stderr)");
    sub->callback([o, &exit_status] { exit_status = run_demo(*o); });
}

} // namespace ferrule::cli
