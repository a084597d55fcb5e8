// A UDP receiver on the loopback interface, for the tests of the network outputs (the TUIO sink
// and ss_track --tuio): datagrams sent to 127.0.0.1:port arrive here.
//
// LocalUdp(std::chrono::milliseconds timeout)
//   requires: timeout > 0 (inside a doctest test case: setup failures are REQUIREs).
//   ensures: a socket bound to 127.0.0.1 on an ephemeral port (`port`), with a 1 MiB receive
//     buffer (asked for; every datagram of a short run fits while the sender runs) and
//     receive() waiting at most `timeout`.
// std::optional<std::vector<std::uint8_t>> receive() const
//   ensures: the next datagram whole (up to 65536 bytes); nullopt when none arrived within the
//     timeout.
// The socket is closed by the destructor; LocalUdp is not copyable.
//
// Threading: one thread at a time.
#pragma once

#include <doctest/doctest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <optional>
#include <vector>

namespace tests {

class LocalUdp {
public:
  explicit LocalUdp(std::chrono::milliseconds timeout) {
    REQUIRE(timeout.count() > 0);
    fd_ = ::socket(AF_INET, SOCK_DGRAM, 0);
    REQUIRE(fd_ >= 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    REQUIRE(::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0);
    socklen_t len = sizeof a;
    REQUIRE(::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len) == 0);
    port = ntohs(a.sin_port);
    const int buffer = 1 << 20;
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &buffer, sizeof buffer);
    timeval tv{static_cast<time_t>(timeout.count() / 1000),
               static_cast<suseconds_t>(timeout.count() % 1000 * 1000)};
    REQUIRE(::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv) == 0);
  }
  LocalUdp(const LocalUdp&) = delete;
  LocalUdp& operator=(const LocalUdp&) = delete;
  ~LocalUdp() {
    if (fd_ >= 0) ::close(fd_);
  }

  std::optional<std::vector<std::uint8_t>> receive() const {
    std::vector<std::uint8_t> b(65536);
    const ssize_t n = ::recv(fd_, b.data(), b.size(), 0);
    if (n < 0) return std::nullopt;
    b.resize(static_cast<std::size_t>(n));
    return b;
  }

  std::uint16_t port = 0;

private:
  int fd_ = -1;
};

} // namespace tests
