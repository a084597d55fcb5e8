// UdpSender: datagrams to one host:port over a POSIX UDP socket (IPv4 or IPv6).
//
// The one host:port parser of the project (the programs' --tuio is a thin use of it).
// try_parse_host_port(text, defaults, out) -> "" with out set, or the reason it failed
//   accepts:  "HOST:PORT", "[IPV6]:PORT", "HOST", "[IPV6]" and a bare IPv6 address ("::1",
//             taken whole, no port); an empty HOST takes defaults.host, a missing PORT
//             defaults.port; with neither default, that part is required. PORT a decimal
//             number 1..65535. out.host has no brackets.
//   ensures:  on failure out is untouched and the reason reads "<what> in '<text>'; expected
//             HOST[:PORT], e.g. 127.0.0.1:3333 or [::1]:3333, PORT in 1..65535" (HOST:PORT
//             when the port is required), <what> one of
//             "no ']' after the IPv6 address", "text after ']'", "no port after ':'", "no host",
//             "no port", "an IPv6 address needs brackets and a port", "bad port '<port>'".
//             Throws nothing but std::bad_alloc (callers pick their own error type).
// parse_host_port("HOST:PORT") -> HostPort
//   requires: "127.0.0.1:3333", "localhost:3333", "[::1]:3333" or ":3333" (host defaults to
//             127.0.0.1): try_parse_host_port with defaults {"127.0.0.1", no port}.
//   throws:   InvalidArgument "parse_host_port: <reason>".
// UdpSender(host, port)
//   ensures:  a socket for the first address `host` resolves to (getaddrinfo: a name lookup
//             may block; pass a numeric address on a robot without DNS).
//   throws:   InvalidArgument for port 0; IoError when the host does not resolve or the socket
//             cannot be created, naming host, port and the system's reason.
// send(bytes)
//   ensures:  one datagram with exactly these bytes was handed to the kernel. UDP gives no
//             delivery guarantee and no error when nobody listens.
//   throws:   IoError when the kernel refuses the datagram (too large, no route, ...).
// Threading: send() may be called from one thread at a time. Move-only; the socket is closed
// by the destructor.
#pragma once

#include <shadowsense/core/error.hpp>

#include <netdb.h>
#include <sys/socket.h>
#include <sys/types.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>

SHADOWSENSE_NAMESPACE_BEGIN

struct HostPort {
  std::string host = "127.0.0.1";
  std::uint16_t port = 3333;
};

// What the text may leave out: an empty host or no port makes that part required.
struct HostPortDefaults {
  std::string host;
  std::optional<std::uint16_t> port;
};

inline std::string try_parse_host_port(std::string_view text, const HostPortDefaults& defaults,
                                       HostPort& out) {
  const auto fail = [&](const std::string& what) {
    return what + " in '" + std::string(text) + "'; expected " +
           (defaults.port ? "HOST[:PORT]" : "HOST:PORT") +
           ", e.g. 127.0.0.1:3333 or [::1]:3333, PORT in 1..65535";
  };
  std::string_view host = text, port;
  if (text.starts_with('[')) {
    const std::size_t close = text.find(']');
    if (close == std::string_view::npos) return fail("no ']' after the IPv6 address");
    host = text.substr(1, close - 1);
    const std::string_view rest = text.substr(close + 1);
    if (!rest.empty()) {
      if (rest[0] != ':') return fail("text after ']'");
      port = rest.substr(1);
      if (port.empty()) return fail("no port after ':'");
    }
  } else if (const std::size_t colon = text.find(':');
             colon != std::string_view::npos &&
             text.find(':', colon + 1) == std::string_view::npos) {
    host = text.substr(0, colon);
    port = text.substr(colon + 1);
    if (port.empty()) return fail("no port after ':'");
  } // else no colon, or a bare IPv6 address: all of it is the host
  if (host.empty() && defaults.host.empty()) return fail("no host");
  HostPort hp{.host = host.empty() ? defaults.host : std::string(host), .port = 0};
  if (port.empty()) {
    if (!defaults.port)
      return fail(host.find(':') == std::string_view::npos
                      ? "no port"
                      : "an IPv6 address needs brackets and a port");
    hp.port = *defaults.port;
  } else {
    unsigned value = 0;
    const auto r = std::from_chars(port.data(), port.data() + port.size(), value);
    if (r.ec != std::errc() || r.ptr != port.data() + port.size() || value < 1 || value > 65535)
      return fail("bad port '" + std::string(port) + "'");
    hp.port = static_cast<std::uint16_t>(value);
  }
  out = std::move(hp);
  return {};
}

inline HostPort parse_host_port(std::string_view text) {
  HostPort hp;
  const std::string why = try_parse_host_port(text, {.host = "127.0.0.1", .port = {}}, hp);
  detail::require(why.empty(), "parse_host_port: " + why);
  return hp;
}

class UdpSender {
public:
  UdpSender(const std::string& host, std::uint16_t port) {
    detail::require(port != 0, "UdpSender: port 0; expected a port in 1..65535");
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_DGRAM;
    hints.ai_flags = AI_NUMERICSERV;
    addrinfo* found = nullptr;
    const std::string service = std::to_string(port);
    const int rc = ::getaddrinfo(host.c_str(), service.c_str(), &hints, &found);
    detail::require<IoError>(rc == 0 && found, "UdpSender: cannot resolve host '" + host +
                                                   "' (port " + service +
                                                   "): " + ::gai_strerror(rc));
    fd_ = ::socket(found->ai_family, found->ai_socktype | SOCK_CLOEXEC, found->ai_protocol);
    const int err = errno;
    if (fd_ >= 0) {
      std::memcpy(&addr_, found->ai_addr, found->ai_addrlen);
      addr_len_ = found->ai_addrlen;
    }
    ::freeaddrinfo(found);
    detail::require<IoError>(fd_ >= 0, "UdpSender: cannot create a UDP socket for " + host + ":" +
                                           service + ": " + std::strerror(err));
    destination_ = host + ":" + service;
  }
  UdpSender(const UdpSender&) = delete;
  UdpSender& operator=(const UdpSender&) = delete;
  UdpSender(UdpSender&& o) noexcept
      : fd_(std::exchange(o.fd_, -1)), addr_(o.addr_), addr_len_(o.addr_len_),
        destination_(std::move(o.destination_)) {}
  UdpSender& operator=(UdpSender&& o) noexcept {
    if (this != &o) {
      close();
      fd_ = std::exchange(o.fd_, -1);
      addr_ = o.addr_;
      addr_len_ = o.addr_len_;
      destination_ = std::move(o.destination_);
    }
    return *this;
  }
  ~UdpSender() { close(); }

  void send(std::span<const std::uint8_t> bytes) {
    detail::require<IoError>(fd_ >= 0, "UdpSender::send: the sender was moved from");
    ssize_t n;
    do {
      n = ::sendto(fd_, bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&addr_),
                   addr_len_);
    } while (n < 0 && errno == EINTR);
    const int err = errno;
    detail::require<IoError>(n == static_cast<ssize_t>(bytes.size()),
                             "UdpSender::send: sending " + std::to_string(bytes.size()) +
                                 " bytes to " + destination_ +
                                 " failed: " + (n < 0 ? std::strerror(err) : "short write"));
  }

  // "host:port" as given to the constructor.
  const std::string& destination() const { return destination_; }

private:
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

  int fd_ = -1;
  sockaddr_storage addr_{};
  socklen_t addr_len_ = 0;
  std::string destination_;
};

SHADOWSENSE_NAMESPACE_END
