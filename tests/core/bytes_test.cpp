#include <catch2/catch.hpp>

#include <array>

#include "ferrule/core/bytes.hpp"
#include "ferrule/core/static_buffer.hpp"

TEST_CASE("big- and little-endian load/store round-trip", "[core][bytes]") {
    std::array<std::uint8_t, 4> b{};
    ferrule::store_be16(b.data(), 0x1234);
    CHECK(b[0] == 0x12);
    CHECK(b[1] == 0x34);
    CHECK(ferrule::load_be16(b.data()) == 0x1234);
    ferrule::store_le16(b.data(), 0x1234);
    CHECK(b[0] == 0x34);
    CHECK(ferrule::load_le16(b.data()) == 0x1234);
    ferrule::store_be32(b.data(), 0xFFFDD000u);
    CHECK(b == std::array<std::uint8_t, 4>{0xFF, 0xFD, 0xD0, 0x00});
    CHECK(ferrule::load_be32(b.data()) == 0xFFFDD000u);
    ferrule::store_le32(b.data(), 0x01020304u);
    CHECK(b == std::array<std::uint8_t, 4>{0x04, 0x03, 0x02, 0x01});
    CHECK(ferrule::load_le32(b.data()) == 0x01020304u);
}

TEST_CASE("static_buffer reports overflow instead of writing past its end", "[core][buffer]") {
    ferrule::static_buffer<4> buf;
    const std::array<std::uint8_t, 6> in{1, 2, 3, 4, 5, 6};
    CHECK(buf.append(in) == 4);
    CHECK(buf.full());
    CHECK_FALSE(buf.push_back(7));
    buf.consume(1);
    CHECK(buf.size() == 3);
    CHECK(buf[0] == 2);
    CHECK(buf.push_back(9));
    CHECK(buf.view().back() == 9);
    buf.consume(10);
    CHECK(buf.empty());
    auto tail = buf.prepare();
    REQUIRE(tail.size() == 4);
    tail[0] = 0xAA;
    buf.commit(1);
    CHECK(buf.size() == 1);
    CHECK(buf[0] == 0xAA);
}
