// Modbus PDUs: every function code both ways, the spec's limits, exceptions, lengths.
#include <catch2/catch.hpp>

#include <array>
#include <string>
#include <vector>

#include "ferrule/modbus/constants.hpp"
#include "ferrule/modbus/error.hpp"
#include "ferrule/modbus/pdu.hpp"

using namespace std::chrono_literals;
using namespace ferrule::modbus;
using ferrule::errc;
using bytes = std::vector<std::uint8_t>;

namespace {

bytes encoded(const request& r) {
    bytes out(max_pdu);
    const auto n = encode_request(r, out);
    REQUIRE(n);
    out.resize(*n);
    return out;
}

std::error_code encode_error(const request& r) {
    std::array<std::uint8_t, max_pdu> out{};
    return encode_request(r, out).error();
}

request read_req(function fc, std::uint16_t address, std::uint16_t quantity) {
    request r;
    r.function = fc;
    r.address = address;
    r.quantity = quantity;
    return r;
}

} // namespace

TEST_CASE("modbus t1.5 and t3.5 follow the character time up to 19200 baud, then 750/1750 us",
          "[modbus][constants]") {
    const ferrule::serial_format b9600{9600, 8, ferrule::parity::even, 1};
    // 3.5 × 11 bits / 9600 = 4.0104166… ms, rounded up to the ns.
    CHECK(t35(b9600) == 4'010'417ns);
    CHECK(t15(b9600) == 1'718'750ns);
    const ferrule::serial_format b19200{19200, 8, ferrule::parity::none, 1};
    CHECK(t35(b19200) == 1'822'917ns); // 10-bit characters
    const ferrule::serial_format b38400{38400, 8, ferrule::parity::even, 1};
    CHECK(t35(b38400) == 1750us);
    CHECK(t15(b38400) == 750us);
    CHECK(t35({115200, 8, ferrule::parity::none, 2}) == 1750us);
    CHECK(default_format.baud == 19200);
    CHECK(default_format.parity == ferrule::parity::even);
}

TEST_CASE("modbus exception codes are device errors with the spec's meaning", "[modbus][error]") {
    const std::error_code ec = device_errc::illegal_data_address;
    CHECK(ec.category() == device_category());
    CHECK(ec.value() == 2);
    CHECK(std::string(ec.category().name()) == "modbus");
    CHECK(ec.message().find("illegal data address") != std::string::npos);
    CHECK(std::error_code(0x42, device_category()).message() == "unknown Modbus exception code");
    CHECK(ec != errc::malformed);
}

TEST_CASE("modbus read requests encode and parse back, FC 1 to 4", "[modbus][pdu]") {
    // Simply Modbus examples (modbus_profibus.md §A.2), without address and CRC.
    CHECK(encoded(read_req(function::read_coils, 0x13, 0x25)) ==
          bytes{0x01, 0x00, 0x13, 0x00, 0x25});
    CHECK(encoded(read_req(function::read_discrete_inputs, 0xC4, 0x16)) ==
          bytes{0x02, 0x00, 0xC4, 0x00, 0x16});
    CHECK(encoded(read_req(function::read_holding_registers, 0x6B, 3)) ==
          bytes{0x03, 0x00, 0x6B, 0x00, 0x03});
    CHECK(encoded(read_req(function::read_input_registers, 8, 1)) ==
          bytes{0x04, 0x00, 0x08, 0x00, 0x01});
    for (auto fc : {function::read_coils, function::read_discrete_inputs,
                    function::read_holding_registers, function::read_input_registers}) {
        const auto pdu = encoded(read_req(fc, 100, 10));
        const auto r = parse_request(pdu);
        REQUIRE(r);
        CHECK(r->function == fc);
        CHECK(r->address == 100);
        CHECK(r->quantity == 10);
        CHECK(request_exception(pdu) == 0);
        CHECK(expected_request_length(pdu) == 5);
    }
}

TEST_CASE("modbus read quantities are limited to 2000 bits and 125 registers", "[modbus][pdu]") {
    CHECK(encode_error(read_req(function::read_coils, 0, 2000)) == std::error_code{});
    CHECK(encode_error(read_req(function::read_coils, 0, 2001)) == errc::invalid_argument);
    CHECK(encode_error(read_req(function::read_discrete_inputs, 0, 0)) == errc::invalid_argument);
    CHECK(encode_error(read_req(function::read_holding_registers, 0, 125)) == std::error_code{});
    CHECK(encode_error(read_req(function::read_holding_registers, 0, 126)) ==
          errc::invalid_argument);
    CHECK(encode_error(read_req(function::read_input_registers, 0, 0)) == errc::invalid_argument);
    // Address + quantity must stay within 65536.
    CHECK(encode_error(read_req(function::read_holding_registers, 0xFFFF, 1)) == std::error_code{});
    CHECK(encode_error(read_req(function::read_holding_registers, 0xFFFF, 2)) ==
          errc::invalid_argument);
    // A server sees 03 for the quantity, 02 for the range (AP §6.3 state diagram).
    CHECK(request_exception(bytes{0x03, 0x00, 0x00, 0x00, 0x7E}) == 3);
    CHECK(request_exception(bytes{0x03, 0x00, 0x00, 0x00, 0x00}) == 3);
    CHECK(request_exception(bytes{0x01, 0x00, 0x00, 0x07, 0xD1}) == 3);
    CHECK(request_exception(bytes{0x03, 0xFF, 0xFF, 0x00, 0x02}) == 2);
    CHECK(request_exception(bytes{0x02, 0xFF, 0x00, 0x01, 0x01}) == 2);
    CHECK(parse_request(bytes{0x03, 0xFF, 0xFF, 0x00, 0x02}).error() == errc::malformed);
}

TEST_CASE("modbus single writes FC5 and FC6 and their echoes", "[modbus][pdu]") {
    request coil;
    coil.function = function::write_single_coil;
    coil.address = 0xAC;
    coil.value = coil_on;
    CHECK(encoded(coil) == bytes{0x05, 0x00, 0xAC, 0xFF, 0x00});
    coil.value = 0x0001;
    CHECK(encode_error(coil) == errc::invalid_argument);
    CHECK(request_exception(bytes{0x05, 0x00, 0xAC, 0x12, 0x34}) == 3);
    coil.value = coil_off;
    const auto off = encoded(coil);
    const auto parsed = parse_request(off);
    REQUIRE(parsed);
    CHECK(parsed->value == coil_off);
    CHECK(parsed->address == 0xAC);

    request reg;
    reg.function = function::write_single_register;
    reg.address = 1;
    reg.value = 3;
    const auto pdu = encoded(reg);
    CHECK(pdu == bytes{0x06, 0x00, 0x01, 0x00, 0x03});
    const auto echo = parse_response(reg, pdu);
    REQUIRE(echo);
    CHECK(echo->address == 1);
    CHECK(echo->value == 3);
    CHECK(parse_response(reg, bytes{0x06, 0x00, 0x01, 0x00, 0x04}).error() == errc::malformed);
    CHECK(parse_response(reg, bytes{0x06, 0x00, 0x02, 0x00, 0x03}).error() == errc::malformed);
    CHECK(parse_response(reg, bytes{0x06, 0x00, 0x01, 0x00}).error() == errc::malformed);
    CHECK(parse_response(coil, bytes{0x05, 0x00, 0xAC, 0x00, 0x00}));
    CHECK(parse_response(coil, bytes{0x05, 0x00, 0xAC, 0xFF, 0x00}).error() == errc::malformed);
    // A response is checked against the request as it encodes: one that cannot be sent has
    // no response.
    request never_sent = reg;
    never_sent.function = function::write_single_coil;
    never_sent.value = 3; // FC 5 takes FF00 or 0000 only
    CHECK(parse_response(never_sent, bytes{0x05, 0x00, 0x01, 0x00, 0x03}).error() ==
          errc::invalid_argument);
    CHECK(parse_response<functions<function::write_single_coil>>(reg, pdu).error() ==
          errc::invalid_argument);
}

TEST_CASE("modbus FC15 write multiple coils: byte count, limits, echo", "[modbus][pdu]") {
    const bytes packed{0xCD, 0x01};
    request r;
    r.function = function::write_multiple_coils;
    r.address = 0x13;
    r.quantity = 10;
    r.data = packed;
    const auto pdu = encoded(r);
    CHECK(pdu == bytes{0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD, 0x01});
    CHECK(expected_request_length(pdu) == pdu.size());
    const auto back = parse_request(pdu);
    REQUIRE(back);
    CHECK(back->quantity == 10);
    CHECK(bytes(back->data.begin(), back->data.end()) == packed);
    const auto rsp = parse_response(r, bytes{0x0F, 0x00, 0x13, 0x00, 0x0A});
    REQUIRE(rsp);
    CHECK(rsp->quantity == 10);
    CHECK(parse_response(r, bytes{0x0F, 0x00, 0x13, 0x00, 0x09}).error() == errc::malformed);

    r.quantity = 17; // needs 3 bytes
    CHECK(encode_error(r) == errc::invalid_argument);
    const bytes many(246, 0xFF);
    r.data = many;
    r.quantity = max_write_bits; // 1968 bits = 246 bytes
    CHECK(encoded(r).size() == 6 + 246);
    r.quantity = max_write_bits + 1;
    CHECK(encode_error(r) == errc::invalid_argument);
    // Byte count that does not match the quantity: 03.
    CHECK(request_exception(bytes{0x0F, 0x00, 0x13, 0x00, 0x0A, 0x01, 0xCD}) == 3);
    // PDU shorter than its byte count says.
    CHECK(request_exception(bytes{0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD}) == 3);
}

TEST_CASE("modbus FC16 write multiple registers: byte count, limits, echo", "[modbus][pdu]") {
    const bytes regs{0x00, 0x0A, 0x01, 0x02};
    request r;
    r.function = function::write_multiple_registers;
    r.address = 1;
    r.quantity = 2;
    r.data = regs;
    const auto pdu = encoded(r);
    CHECK(pdu == bytes{0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02});
    const auto back = parse_request(pdu);
    REQUIRE(back);
    CHECK(bytes(back->data.begin(), back->data.end()) == regs);
    CHECK(parse_response(r, bytes{0x10, 0x00, 0x01, 0x00, 0x02}));
    CHECK(parse_response(r, bytes{0x10, 0x00, 0x01, 0x00, 0x03}).error() == errc::malformed);
    r.quantity = 3;
    CHECK(encode_error(r) == errc::invalid_argument);
    const bytes max(2 * max_write_registers, 0);
    r.data = max;
    r.quantity = max_write_registers;
    CHECK(encoded(r).size() == 6 + 246);
    const bytes over(2 * (max_write_registers + 1), 0);
    r.data = over;
    r.quantity = max_write_registers + 1;
    CHECK(encode_error(r) == errc::invalid_argument);
    CHECK(request_exception(bytes{0x10, 0x00, 0x01, 0x00, 0x02, 0x03, 0x00, 0x0A, 0x01}) == 3);
}

TEST_CASE("modbus FC23 read/write multiple registers", "[modbus][pdu]") {
    const bytes wr{0x00, 0xFF, 0x00, 0xFF, 0x00, 0xFF};
    request r;
    r.function = function::read_write_multiple_registers;
    r.address = 3;
    r.quantity = 6;
    r.write_address = 14;
    r.write_quantity = 3;
    r.data = wr;
    // AP §6.17 example.
    const auto pdu = encoded(r);
    CHECK(pdu == bytes{0x17, 0x00, 0x03, 0x00, 0x06, 0x00, 0x0E, 0x00, 0x03, 0x06, 0x00, 0xFF, 0x00,
                       0xFF, 0x00, 0xFF});
    CHECK(expected_request_length(pdu) == pdu.size());
    const auto back = parse_request(pdu);
    REQUIRE(back);
    CHECK(back->write_address == 14);
    CHECK(back->write_quantity == 3);
    CHECK(back->quantity == 6);
    const bytes rsp{0x17, 0x0C, 0x00, 0xFE, 0x0A, 0xCD, 0x00,
                    0x01, 0x00, 0x03, 0x00, 0x0D, 0x00, 0xFF};
    CHECK(expected_response_length(rsp) == rsp.size());
    const auto p = parse_response(r, rsp);
    REQUIRE(p);
    CHECK(p->data.size() == 12);
    CHECK(parse_response(r, bytes{0x17, 0x02, 0x00, 0xFE}).error() == errc::malformed);
    r.write_quantity = max_rw_write_registers + 1;
    const bytes over(2 * r.write_quantity, 0);
    r.data = over;
    CHECK(encode_error(r) == errc::invalid_argument);
    r.write_quantity = max_rw_write_registers;
    r.data = std::span<const std::uint8_t>(over).first(2 * max_rw_write_registers);
    CHECK(encoded(r).size() == 10 + 242);
    r.quantity = 126;
    CHECK(encode_error(r) == errc::invalid_argument);
}

TEST_CASE("modbus FC8 diagnostics: sub-function and 2 data bytes, echo", "[modbus][pdu]") {
    const bytes query{0x12, 0x34};
    request r;
    r.function = function::diagnostics;
    r.value = static_cast<std::uint16_t>(diag_sub::return_query_data);
    r.data = query;
    const auto pdu = encoded(r);
    CHECK(pdu == bytes{0x08, 0x00, 0x00, 0x12, 0x34});
    const auto back = parse_request(pdu);
    REQUIRE(back);
    CHECK(back->value == 0);
    CHECK(bytes(back->data.begin(), back->data.end()) == query);
    CHECK(parse_response(r, pdu));
    CHECK(parse_response(r, bytes{0x08, 0x00, 0x00, 0x12, 0x35}).error() == errc::malformed);
    r.value = static_cast<std::uint16_t>(diag_sub::bus_message_count);
    const bytes zero{0, 0};
    r.data = zero;
    const bytes counted{0x08, 0x00, 0x0B, 0x01, 0x2C};
    const auto count = parse_response(r, counted);
    REQUIRE(count);
    CHECK(count->value == 11);
    CHECK(bytes(count->data.begin(), count->data.end()) == bytes{0x01, 0x2C});
    CHECK(parse_response(r, bytes{0x08, 0x00, 0x0C, 0x01, 0x2C}).error() == errc::malformed);
    const bytes three{1, 2, 3};
    r.data = three;
    CHECK(encode_error(r) == errc::invalid_argument);
}

TEST_CASE("modbus FC43/14 read device identification", "[modbus][pdu]") {
    request r;
    r.function = function::encapsulated_interface;
    r.read_device_id_code = 1;
    r.object_id = 0;
    const auto pdu = encoded(r);
    CHECK(pdu == bytes{0x2B, 0x0E, 0x01, 0x00});
    CHECK(expected_request_length(pdu) == 4);
    const auto back = parse_request(pdu);
    REQUIRE(back);
    CHECK(back->read_device_id_code == 1);
    // AP §6.21 example: basic identification, all in one response.
    const bytes rsp{0x2B, 0x0E, 0x01, 0x01, 0x00, 0x00, 0x03, 0x00, 0x03, 'A', 'B',
                    'C',  0x01, 0x02, 'P',  '1',  0x02, 0x04, 'V',  '2',  '.', '1'};
    CHECK(expected_response_length(rsp) == rsp.size());
    // Known once the last object's length byte (index 17) is there.
    for (std::size_t n = 0; n < rsp.size(); ++n)
        CHECK(expected_response_length(std::span(rsp).first(n)) == (n < 18 ? 0u : rsp.size()));
    const auto p = parse_response(r, rsp);
    REQUIRE(p);
    CHECK(p->conformity == 1);
    CHECK_FALSE(p->more_follows);
    CHECK(p->quantity == 3);
    std::span<const std::uint8_t> objects = p->data;
    device_id_object o;
    std::vector<std::string> texts;
    while (next_device_id_object(objects, o)) texts.emplace_back(o.value.begin(), o.value.end());
    CHECK(texts == std::vector<std::string>{"ABC", "P1", "V2.1"});
    // Object count that the list does not hold; more-follows other than 00/FF.
    bytes bad = rsp;
    bad[6] = 4;
    CHECK(parse_response(r, bad).error() == errc::malformed);
    bad = rsp;
    bad[4] = 0x01;
    CHECK(parse_response(r, bad).error() == errc::malformed);
    r.read_device_id_code = 5;
    CHECK(encode_error(r) == errc::invalid_argument);
    CHECK(request_exception(bytes{0x2B, 0x0E, 0x05, 0x00}) == 3);
    CHECK(request_exception(bytes{0x2B, 0x0D, 0x01, 0x00}) == 1); // another MEI type
}

TEST_CASE("modbus read responses check the byte count against the request", "[modbus][pdu]") {
    const auto coils = read_req(function::read_coils, 0x13, 0x25); // 37 bits: 5 bytes
    const bytes rsp{0x01, 0x05, 0xCD, 0x6B, 0xB2, 0x0E, 0x1B};
    CHECK(expected_response_length(rsp) == rsp.size());
    const auto p = parse_response(coils, rsp);
    REQUIRE(p);
    CHECK(p->data.size() == 5);
    CHECK(p->quantity == 0x25);
    CHECK(parse_response(coils, bytes{0x01, 0x04, 0xCD, 0x6B, 0xB2, 0x0E}).error() ==
          errc::malformed);
    const auto regs = read_req(function::read_holding_registers, 0x6B, 3);
    const bytes rr{0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64};
    REQUIRE(parse_response(regs, rr));
    CHECK(parse_response(regs, bytes{0x03, 0x06, 0x02, 0x2B}).error() == errc::malformed);
    CHECK(parse_response(regs, bytes{0x04, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64}).error() ==
          errc::unexpected_type);
    CHECK(parse_response(regs, bytes{}).error() == errc::malformed);
}

TEST_CASE("modbus exception responses become device errors", "[modbus][pdu]") {
    const auto regs = read_req(function::read_holding_registers, 0, 1);
    const bytes ex{0x83, 0x02};
    CHECK(expected_response_length(ex) == 2);
    const auto p = parse_response(regs, ex);
    CHECK(p.error() == device_errc::illegal_data_address);
    CHECK(std::error_code(p.error()).category() == device_category());
    CHECK(parse_response(regs, bytes{0x83, 0x00}).error() == errc::malformed);
    CHECK(parse_response(regs, bytes{0x83, 0x02, 0x00}).error() == errc::malformed);
    CHECK(parse_response(regs, bytes{0x84, 0x02}).error() == errc::unexpected_type);
    CHECK(parse_response(regs, bytes{0x83, 0x42}).error().value() == 0x42);

    std::array<std::uint8_t, 2> out{};
    const auto n = encode_exception(function::read_holding_registers,
                                    exception_code::illegal_data_address, out);
    REQUIRE(n);
    CHECK(*n == 2);
    CHECK(out == std::array<std::uint8_t, 2>{0x83, 0x02});
    std::array<std::uint8_t, 1> small{};
    CHECK(encode_exception(function::read_coils, exception_code::illegal_function, small).error() ==
          errc::buffer_too_small);
}

TEST_CASE("modbus unknown function codes deserve exception 01", "[modbus][pdu]") {
    CHECK(request_exception(bytes{0x07}) == 1);
    CHECK(request_exception(bytes{0x11}) == 1);
    CHECK(request_exception(bytes{0x64, 0x00}) == 1);
    CHECK(request_exception(bytes{0x83, 0x00}) == 1);
    CHECK(request_exception(bytes{}) == 0);
    CHECK(parse_request(bytes{}).error() == errc::malformed);
    request r;
    r.function = static_cast<function>(7);
    CHECK(encode_error(r) == errc::invalid_argument);
    // Lengths of the fixed-layout codes a server does not serve, so it can answer them.
    CHECK(expected_request_length(bytes{0x07}) == 1);
    CHECK(expected_request_length(bytes{0x11}) == 1);
    CHECK(expected_request_length(bytes{0x14}) == 0);
    CHECK(expected_request_length(bytes{0x14, 0x07}) == 9);
    CHECK(expected_request_length(bytes{0x16}) == 7);
    CHECK(expected_request_length(bytes{0x18}) == 3);
    CHECK(expected_request_length(bytes{0x64}) == no_frame);
    CHECK(expected_request_length(bytes{0x2B, 0x0D}) == no_frame);
    CHECK(expected_request_length(bytes{0x10, 0, 0, 0, 0, 0xFF}) == no_frame);
}

TEST_CASE("modbus expected lengths need just enough bytes", "[modbus][pdu]") {
    CHECK(expected_response_length(bytes{}) == 0);
    CHECK(expected_response_length(bytes{0x03}) == 0);
    CHECK(expected_response_length(bytes{0x03, 0x04}) == 6);
    CHECK(expected_response_length(bytes{0x05}) == 5);
    CHECK(expected_response_length(bytes{0x08}) == 5);
    CHECK(expected_response_length(bytes{0x0F}) == 5);
    CHECK(expected_response_length(bytes{0x10}) == 5);
    CHECK(expected_response_length(bytes{0x81}) == 2);
    CHECK(expected_response_length(bytes{0x80}) == no_frame);
    CHECK(expected_response_length(bytes{0x00}) == no_frame);
    CHECK(expected_response_length(bytes{0x2B, 0x0D}) == no_frame);
    CHECK(expected_response_length(bytes{0x18, 0x00}) == 0);
    CHECK(expected_response_length(bytes{0x18, 0x00, 0x06}) == 9);
    CHECK(expected_response_length(bytes{0x18, 0x01, 0x00}) == no_frame);
    CHECK(expected_request_length(bytes{0x10, 0, 1, 0, 2}) == 0);
    CHECK(expected_request_length(bytes{0x17, 0, 1, 0, 2, 0, 3, 0, 1}) == 0);
    // FC43 objects beyond 253 bytes cannot be framed.
    bytes big{0x2B, 0x0E, 0x01, 0x01, 0x00, 0x00, 0x02, 0x00, 0xF0};
    big.resize(9 + 0xF0, 'x');
    big.push_back(0x01);
    big.push_back(0x10);
    CHECK(expected_response_length(big) == no_frame);
}

// A client built for FC 3 and 6 (firmware that names its functions) refuses the others
// where the full set takes them, and frames no response of theirs.
TEST_CASE("modbus function sets: only the functions named are encoded, parsed and framed",
          "[modbus][pdu]") {
    constexpr auto fs =
        functions<function::read_holding_registers, function::write_single_register>;
    STATIC_REQUIRE(fs.has(function::read_holding_registers));
    STATIC_REQUIRE(fs.has(std::uint8_t{6}));
    STATIC_REQUIRE_FALSE(fs.has(function::read_coils));
    STATIC_REQUIRE_FALSE(fs.has(std::uint8_t{200}));
    STATIC_REQUIRE(all_functions.has(function::encapsulated_interface));

    std::array<std::uint8_t, max_pdu> out{};
    request read;
    read.quantity = 2;
    std::array<std::uint8_t, max_pdu> full{};
    REQUIRE(*encode_request(read, full) == 5u);
    REQUIRE(*encode_request<fs>(read, out) == 5u);
    CHECK(out == full);
    request coils;
    coils.function = function::read_coils;
    coils.quantity = 8;
    CHECK(encode_request(coils, out));
    CHECK(encode_request<fs>(coils, out).error() == errc::invalid_argument);

    const bytes two{0x03, 0x04, 0x00, 0x01, 0x00, 0x02};
    REQUIRE(parse_response<fs>(read, two));
    CHECK(parse_response<fs>(read, two)->data.size() == 4);
    CHECK(parse_response<fs>(read, bytes{0x83, 0x02}).error() == device_errc::illegal_data_address);
    CHECK(parse_response(coils, bytes{0x01, 0x01, 0x55}));
    CHECK(parse_response<fs>(coils, bytes{0x01, 0x01, 0x55}).error() == errc::invalid_argument);

    CHECK(expected_response_length<fs>(bytes{0x03, 0x04}) == 6);
    CHECK(expected_response_length<fs>(bytes{0x06}) == 5);
    CHECK(expected_response_length<fs>(bytes{0x83}) == 2);
    CHECK(expected_response_length(bytes{0x01, 0x01}) == 3);
    CHECK(expected_response_length<fs>(bytes{0x01, 0x01}) == no_frame);
    CHECK(expected_response_length(bytes{0x07}) == 2);
    CHECK(expected_response_length<fs>(bytes{0x07}) == no_frame);
    CHECK(expected_response_length<fs>(bytes{0x2B, 0x0E}) == no_frame);
}
