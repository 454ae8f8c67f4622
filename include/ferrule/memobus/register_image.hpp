// The registers an MP controller serves over Extended MEMOBUS (protocols/memobus.md §3.4,
// "Address meaning on the controller"), in fixed arrays, no heap:
//
//   MW  hold registers     SFC 03 06 09 0B 0D 0E 10
//   IW  input registers    SFC 04 0A
//   MB  the bits of MW     SFC 01 05 0F: coil n is MW word n / 16, bit n % 16 (MBnnnnnb)
//   IB  the bits of IW     SFC 02: input relay n is IW word n / 16, bit n % 16
//
// MW00000…MW65534 and IW0000…IWFFFF at most (§3.4: hold registers 0–65534). What the
// registers mean is the application's: it reads and sets them between requests.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace ferrule::memobus {

// Bit n of a run of words: word n / 16, bit n % 16 (the MB / IB numbering).
constexpr bool bit_of(std::span<const std::uint16_t> words, std::size_t n) noexcept {
    return (words[n / 16] >> n % 16) & 1u;
}
constexpr void set_bit_of(std::span<std::uint16_t> words, std::size_t n, bool on) noexcept {
    const auto mask = static_cast<std::uint16_t>(1u << n % 16);
    words[n / 16] = static_cast<std::uint16_t>(on ? words[n / 16] | mask : words[n / 16] & ~mask);
}

template <std::size_t NMW, std::size_t NIW>
class register_image {
    static_assert(NMW <= 65535, "MW00000…MW65534 (§3.4)");
    static_assert(NIW <= 65536, "IW0000…IWFFFF");

public:
    static constexpr std::size_t mw_size = NMW;
    static constexpr std::size_t iw_size = NIW;

    std::span<std::uint16_t, NMW> mw() noexcept { return mw_; }
    std::span<const std::uint16_t, NMW> mw() const noexcept { return mw_; }
    std::span<std::uint16_t, NIW> iw() noexcept { return iw_; }
    std::span<const std::uint16_t, NIW> iw() const noexcept { return iw_; }

    // Precondition: n < mw_size (iw_size).
    std::uint16_t mw(std::size_t n) const noexcept { return mw_[n]; }
    void set_mw(std::size_t n, std::uint16_t v) noexcept { mw_[n] = v; }
    std::uint16_t iw(std::size_t n) const noexcept { return iw_[n]; }
    void set_iw(std::size_t n, std::uint16_t v) noexcept { iw_[n] = v; }

    // Precondition: n < 16 * mw_size (16 * iw_size).
    bool mb(std::size_t n) const noexcept { return bit_of(mw_, n); }
    void set_mb(std::size_t n, bool on) noexcept { set_bit_of(mw_, n, on); }
    bool ib(std::size_t n) const noexcept { return bit_of(iw_, n); }
    void set_ib(std::size_t n, bool on) noexcept { set_bit_of(iw_, n, on); }

private:
    std::array<std::uint16_t, NMW> mw_{};
    std::array<std::uint16_t, NIW> iw_{};
};

} // namespace ferrule::memobus
