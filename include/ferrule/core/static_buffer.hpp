// Fixed-capacity byte buffer: the storage for telegrams in sessions and streams.
// Never allocates; overflow is reported, not UB.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/time.hpp"

namespace ferrule {

template <std::size_t Capacity>
class static_buffer {
public:
    static constexpr std::size_t capacity() noexcept { return Capacity; }
    constexpr std::size_t size() const noexcept { return size_; }
    constexpr bool empty() const noexcept { return size_ == 0; }
    constexpr bool full() const noexcept { return size_ == Capacity; }
    constexpr void clear() noexcept { size_ = 0; }

    // Appends as many bytes as fit; returns how many did.
    constexpr std::size_t append(std::span<const std::uint8_t> in) noexcept {
        std::size_t n = 0;
        while (n < in.size() && size_ < Capacity) data_[size_++] = in[n++];
        return n;
    }
    constexpr bool push_back(std::uint8_t b) noexcept {
        if (size_ == Capacity) return false;
        data_[size_++] = b;
        return true;
    }
    // Drops the first n bytes (n > size() clears).
    constexpr void consume(std::size_t n) noexcept {
        if (n >= size_) {
            size_ = 0;
            return;
        }
        for (std::size_t i = n; i < size_; ++i) data_[i - n] = data_[i];
        size_ -= n;
    }
    // Writable tail after a direct write into it, commit how many bytes were filled.
    constexpr std::span<std::uint8_t> prepare() noexcept {
        return std::span<std::uint8_t>(data_).subspan(size_);
    }
    constexpr void commit(std::size_t n) noexcept {
        size_ = n > Capacity - size_ ? Capacity : size_ + n;
    }
    constexpr void resize(std::size_t n) noexcept { size_ = n > Capacity ? Capacity : n; }

    constexpr std::uint8_t& operator[](std::size_t i) noexcept { return data_[i]; }
    constexpr std::uint8_t operator[](std::size_t i) const noexcept { return data_[i]; }
    constexpr std::uint8_t* data() noexcept { return data_.data(); }
    constexpr const std::uint8_t* data() const noexcept { return data_.data(); }
    constexpr std::span<const std::uint8_t> view() const noexcept { return {data_.data(), size_}; }
    constexpr std::span<std::uint8_t> span() noexcept { return {data_.data(), size_}; }

private:
    std::array<std::uint8_t, Capacity> data_{};
    std::size_t size_ = 0;
};

// Bytes a station has heard behind a request it has not answered yet, kept with the time the
// last of them ended, to be framed once the request is done with.
template <std::size_t Capacity>
class held_bytes {
public:
    bool empty() const noexcept { return bytes_.empty(); }
    // When the last byte held ended.
    time_point end() const noexcept { return end_; }
    // Keeps `in`, which ended at `at`; returns how many bytes did not fit (and are lost).
    std::size_t hold(std::span<const std::uint8_t> in, time_point at) noexcept {
        end_ = at;
        return in.size() - bytes_.append(in);
    }
    // Hands every held byte to feed(bytes, end), which may hold some again.
    template <class Feed>
    void release(Feed&& feed) noexcept {
        const static_buffer<Capacity> rest = bytes_;
        bytes_.clear();
        feed(rest.view(), end_);
    }

private:
    static_buffer<Capacity> bytes_{};
    time_point end_{};
};

} // namespace ferrule
