// async_driver: runs one master session's transactions over one asio stream (a serial
// port, a TCP socket …) without blocking, for any protocol's master session.
//
//   * async_transact(start, harvest, token): start(session) begins a transaction; when the
//     session is done, harvest(session) makes the value handed to the caller. Completion
//     signature void(std::error_code, R); any completion token works: a callback,
//     asio::use_future, asio::use_awaitable.
//   * Transactions asked for by many callers are queued and run one after another in the
//     order asked, never interleaved on the bus.
//   * Optional reopen: after a transport error (the USB adapter was unplugged) the driver
//     calls the reopen function before the next transaction, retrying at an interval until
//     it succeeds; the transaction that met the error completes with it.
//
// The driver, its stream and its session belong to one executor: run the io_context on one
// thread, or give the stream a strand. async_transact may be called from any thread.
#pragma once

#include <termios.h>

#include <asio/associated_executor.hpp>
#include <asio/async_result.hpp>
#include <asio/buffer.hpp>
#include <asio/post.hpp>
#include <asio/serial_port.hpp>
#include <asio/steady_timer.hpp>
#include <asio/write.hpp>

#include <array>
#include <chrono>
#include <deque>
#include <functional>
#include <memory>
#include <system_error>
#include <type_traits>
#include <utility>

#include "ferrule/core/session.hpp"
#include "ferrule/host/serial_stream.hpp"

namespace ferrule::host {

template <class Stream, master_session Session>
class async_driver {
public:
    async_driver(Stream& stream, Session& session)
        : stream_(stream), session_(session), timer_(stream.get_executor()),
          retry_timer_(stream.get_executor()) {}
    async_driver(const async_driver&) = delete;
    async_driver& operator=(const async_driver&) = delete;

    // Called with the stream after a transport error, before the next transaction.
    void set_reopen(std::function<std::error_code(Stream&)> reopen, duration retry_interval) {
        reopen_ = std::move(reopen);
        retry_interval_ = retry_interval;
    }

    template <class Start, class Harvest, class CompletionToken>
    auto async_transact(Start start, Harvest harvest, CompletionToken&& token) {
        using value_type = std::invoke_result_t<Harvest&, Session&>;
        return ::asio::async_initiate<CompletionToken, void(std::error_code, value_type)>(
            [this](auto handler, Start start, Harvest harvest) {
                auto h = std::make_shared<decltype(handler)>(std::move(handler));
                ::asio::post(stream_.get_executor(), [this, h, start = std::move(start),
                                                      harvest = std::move(harvest)]() mutable {
                    queue_.push_back([this, h, start = std::move(start),
                                      harvest = std::move(harvest)]() mutable {
                        finish_ = [this, h,
                                   harvest = std::move(harvest)](std::error_code ec) mutable {
                            value_type v{};
                            if (!ec) v = harvest(session_);
                            auto ex = ::asio::get_associated_executor(*h, stream_.get_executor());
                            ::asio::post(ex, [h, ec, v = std::move(v)]() mutable {
                                (*h)(ec, std::move(v));
                            });
                        };
                        if (auto ec = start(session_))
                            complete(ec);
                        else
                            step();
                    });
                    if (!busy_) next();
                });
            },
            token, std::move(start), std::move(harvest));
    }

    std::size_t queued() const noexcept { return queue_.size(); }

private:
    void next() {
        if (queue_.empty()) {
            busy_ = false;
            return;
        }
        busy_ = true;
        if (needs_reopen_ && reopen_) {
            if (reopen_(stream_)) {
                retry_timer_.expires_after(retry_interval_);
                retry_timer_.async_wait([this](std::error_code) { next(); });
                return;
            }
            needs_reopen_ = false;
        }
        auto op = std::move(queue_.front());
        queue_.pop_front();
        op();
    }

    void complete(std::error_code ec) {
        auto finish = std::move(finish_);
        finish(ec);
        next();
    }

    void transport_failed(std::error_code ec) {
        session_.on_transport_error(from_error_code(ec));
        needs_reopen_ = true;
    }

    void step() {
        const session_action a = session_.next(steady_now());
        switch (a.what) {
        case session_action::kind::idle:
        case session_action::kind::done: complete(session_.error()); return;
        case session_action::kind::send:
            if constexpr (std::is_same_v<Stream, ::asio::serial_port>)
                if (a.discard_input) ::tcflush(stream_.native_handle(), TCIFLUSH);
            ::asio::async_write(stream_, ::asio::buffer(a.bytes.data(), a.bytes.size()),
                                [this](std::error_code ec, std::size_t) {
                                    if (ec) transport_failed(ec);
                                    step();
                                });
            return;
        case session_action::kind::wait:
            if (a.deadline != never) {
                timer_.expires_at(std::chrono::steady_clock::time_point(
                    std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                        a.deadline.time_since_epoch())));
                // The deadline passed first: stop the read; its handler asks the session again.
                timer_.async_wait([this](std::error_code ec) {
                    if (!ec) stream_.cancel();
                });
            }
            stream_.async_read_some(::asio::buffer(rx_), [this](std::error_code ec, std::size_t n) {
                timer_.cancel();
                if (n > 0)
                    session_.on_receive(std::span<const std::uint8_t>(rx_.data(), n), steady_now());
                else if (ec && ec != ::asio::error::operation_aborted)
                    transport_failed(ec);
                step();
            });
            return;
        }
    }

    Stream& stream_;
    Session& session_;
    ::asio::steady_timer timer_;
    ::asio::steady_timer retry_timer_;
    std::deque<std::function<void()>> queue_;
    std::function<void(std::error_code)> finish_;
    std::function<std::error_code(Stream&)> reopen_;
    duration retry_interval_{std::chrono::milliseconds(500)};
    std::array<std::uint8_t, 256> rx_{};
    bool busy_ = false;
    bool needs_reopen_ = false;
};

} // namespace ferrule::host
