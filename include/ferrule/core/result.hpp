// result<T>: a value or a std::error_code, for code built without exceptions.
// Not constexpr where std::error_code is involved: it is no literal type before C++23.
#pragma once

#include <system_error>
#include <type_traits>
#include <utility>

#include "ferrule/core/error.hpp"

namespace ferrule {

template <class T>
class [[nodiscard]] result {
public:
    constexpr result(T value) noexcept(std::is_nothrow_move_constructible_v<T>)
        : value_(std::move(value)) {}
    result(std::error_code ec) noexcept : ec_(ec) {}
    template <class E>
    requires std::is_error_code_enum_v<E> result(E e)
    noexcept : ec_(e) {}

    constexpr bool has_value() const noexcept { return !ec_; }
    constexpr explicit operator bool() const noexcept { return !ec_; }
    std::error_code error() const noexcept { return ec_; }

    // Precondition: has_value(). Like std::optional::operator*, not checked.
    constexpr T& operator*() noexcept { return value_; }
    constexpr const T& operator*() const noexcept { return value_; }
    constexpr T* operator->() noexcept { return &value_; }
    constexpr const T* operator->() const noexcept { return &value_; }
    constexpr T value_or(T fallback) const noexcept { return ec_ ? fallback : value_; }

private:
    T value_{};
    stored_error ec_{};
};

} // namespace ferrule
