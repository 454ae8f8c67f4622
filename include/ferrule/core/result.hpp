// result<T>: a value or a ferrule::error, for code built without exceptions.
#pragma once

#include <type_traits>
#include <utility>

#include "ferrule/core/error.hpp"

namespace ferrule {

template <class T>
class [[nodiscard]] result {
public:
    constexpr result(T value) noexcept(std::is_nothrow_move_constructible_v<T>)
        : value_(std::move(value)) {}
    constexpr result(ferrule::error e) noexcept : error_(e) {}
    template <class E>
    requires is_error_enum_v<E>
    constexpr result(E e) noexcept : error_(e) {}

    constexpr bool has_value() const noexcept { return !error_; }
    constexpr explicit operator bool() const noexcept { return !error_; }
    constexpr ferrule::error error() const noexcept { return error_; }

    // Precondition: has_value(). Like std::optional::operator*, not checked.
    constexpr T& operator*() noexcept { return value_; }
    constexpr const T& operator*() const noexcept { return value_; }
    constexpr T* operator->() noexcept { return &value_; }
    constexpr const T* operator->() const noexcept { return &value_; }
    constexpr T value_or(T fallback) const noexcept { return error_ ? fallback : value_; }

private:
    T value_{};
    ferrule::error error_{};
};

} // namespace ferrule
