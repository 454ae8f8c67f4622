// reply_writer: the write side of one connection of a server (Modbus TCP, Extended
// MEMOBUS). A reply goes out with one non-blocking send() straight from the session's
// buffer; only what the socket does not take at once is copied, to be written
// asynchronously, and replies due meanwhile queue behind it so that the byte order stays.
// backlogged() tells the connection to stop reading from a peer that sends requests without
// reading the replies.
#pragma once

#include <asio/write.hpp>

#include <cstddef>
#include <cstdint>
#include <span>
#include <system_error>
#include <utility>
#include <vector>

namespace ferrule::host {

template <class Socket>
class reply_writer {
public:
    static constexpr std::size_t backlog_limit = 16 * 1024;

    explicit reply_writer(Socket& socket) noexcept : socket_(socket) {}
    reply_writer(const reply_writer&) = delete;
    reply_writer& operator=(const reply_writer&) = delete;

    // Sends `bytes` (the socket must be non-blocking). Returns the error that ends the
    // connection, else {}. When bytes had to wait, `keep_alive` (the connection's
    // shared_ptr) rides along the asynchronous write and `drained(ec)` is called when all
    // waiting bytes have gone, or with the error that stopped them.
    template <class KeepAlive, class Drained>
    std::error_code send(std::span<const std::uint8_t> bytes, KeepAlive keep_alive,
                         Drained drained) {
        if (!writing_.empty()) {
            queued_.insert(queued_.end(), bytes.begin(), bytes.end());
            return {};
        }
        std::error_code ec;
        const std::size_t n = socket_.send(::asio::buffer(bytes.data(), bytes.size()), 0, ec);
        if (ec && ec != ::asio::error::would_block) return ec;
        bytes = bytes.subspan(ec ? 0 : n);
        if (bytes.empty()) return {};
        writing_.assign(bytes.begin(), bytes.end());
        flush(std::move(keep_alive), std::move(drained));
        return {};
    }

    bool backlogged() const noexcept { return queued_.size() >= backlog_limit; }
    // Every reply has gone to the socket.
    bool idle() const noexcept { return writing_.empty(); }

private:
    template <class KeepAlive, class Drained>
    void flush(KeepAlive keep_alive, Drained drained) {
        ::asio::async_write(socket_, ::asio::buffer(writing_),
                            [this, keep_alive, drained](std::error_code ec, std::size_t) mutable {
                                if (ec) return drained(ec);
                                writing_.clear();
                                std::swap(writing_, queued_);
                                if (!writing_.empty())
                                    return flush(std::move(keep_alive), std::move(drained));
                                drained(std::error_code{});
                            });
    }

    Socket& socket_;
    std::vector<std::uint8_t> writing_;
    std::vector<std::uint8_t> queued_;
};

} // namespace ferrule::host
