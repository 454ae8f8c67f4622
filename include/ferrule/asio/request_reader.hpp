// request_reader: the read side of one connection of a server (Modbus TCP, Extended
// MEMOBUS), the counterpart of reply_writer. It holds what was read and not yet used, and
// reads again only when all of it is used and no read is under way, so a connection takes
// no more bytes than its session can hold.
#pragma once

#include <asio/buffer.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <system_error>

namespace ferrule::host {

template <class Socket, std::size_t Capacity = 512>
class request_reader {
public:
    explicit request_reader(Socket& socket) noexcept : socket_(socket) {}
    request_reader(const request_reader&) = delete;
    request_reader& operator=(const request_reader&) = delete;

    // The bytes read and not yet used; use(n) takes n of them off the front.
    std::span<const std::uint8_t> unused() const noexcept {
        return {buf_.data() + pos_, size_ - pos_};
    }
    void use(std::size_t n) noexcept { pos_ += n; }

    // Reads once all bytes are used and no read is under way: self->on_read(ec) is called
    // with new bytes in unused(), or with the error (end of file included) that ends the
    // connection. `self`, the connection's shared_ptr, keeps it alive meanwhile.
    template <class Owner>
    void read_more(std::shared_ptr<Owner> self) {
        if (reading_ || pos_ < size_) return;
        reading_ = true;
        socket_.async_read_some(::asio::buffer(buf_),
                                [this, self = std::move(self)](std::error_code ec, std::size_t n) {
                                    reading_ = false;
                                    pos_ = 0;
                                    size_ = ec ? 0 : n;
                                    self->on_read(ec);
                                });
    }

private:
    Socket& socket_;
    std::array<std::uint8_t, Capacity> buf_{};
    std::size_t pos_ = 0;
    std::size_t size_ = 0;
    bool reading_ = false;
};

} // namespace ferrule::host
