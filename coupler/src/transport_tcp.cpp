// TCP transport: the only file besides transport_mpi.cpp that includes socket headers.
//
// Listener: binds bindAddress (loopback by default) on port 0, so the operating system picks a
// free port for every run; publishes "tqcp 1 tcp HOST PORT" through an address file written
// atomically (temporary file + rename). Connector: waits for that file, then connects, retrying
// while the listener is not up yet. Every send/receive waits with poll() against a deadline.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/types.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <thread>

#include "tq/coupler/errors.hpp"
#include "transport_detail.hpp"

namespace tq::coupler::detail {
namespace {

std::string errnoText(int e) { return std::string(std::strerror(e)); }

int pollMs(const Deadline& d) {
  const double r = d.remaining();
  if (r <= 0) return 0;
  return int(std::min(std::ceil(r * 1000.0), 1.0e9));
}

std::string peerName(const sockaddr_storage& a) {
  char host[INET6_ADDRSTRLEN] = "?";
  int port = 0;
  if (a.ss_family == AF_INET) {
    const auto* s = reinterpret_cast<const sockaddr_in*>(&a);
    inet_ntop(AF_INET, &s->sin_addr, host, sizeof host);
    port = ntohs(s->sin_port);
  } else if (a.ss_family == AF_INET6) {
    const auto* s = reinterpret_cast<const sockaddr_in6*>(&a);
    inet_ntop(AF_INET6, &s->sin6_addr, host, sizeof host);
    port = ntohs(s->sin6_port);
  }
  return std::string(host) + ":" + std::to_string(port);
}

void tune(int fd) {
  int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);  // latency over batching
  int flags = fcntl(fd, F_GETFL, 0);
  fcntl(fd, F_SETFL, flags | O_NONBLOCK);
}

class TcpChannel final : public Channel {
 public:
  TcpChannel(int fd, std::string desc) : fd_(fd), desc_(std::move(desc)) {}
  ~TcpChannel() override { close(); }

  void send(const std::uint8_t* p, std::size_t n, Deadline d) override {
    std::size_t done = 0;
    while (done < n) {
      const ssize_t k = ::send(fd_, p + done, n - done, MSG_NOSIGNAL);
      if (k > 0) {
        done += std::size_t(k);
        continue;
      }
      if (k < 0 && errno == EINTR) continue;
      if (k < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
        pollfd pf{fd_, POLLOUT, 0};
        const int r = ::poll(&pf, 1, pollMs(d));
        if (r == 0)
          throw TimeoutError("send stalled: the partner did not take the data (" + std::to_string(done) + " of " +
                             std::to_string(n) + " bytes sent) before the timeout");
        if (r < 0 && errno != EINTR) throw TransportError("poll failed: " + errnoText(errno));
        continue;
      }
      const int e = errno;
      if (e == EPIPE || e == ECONNRESET || e == ENOTCONN)
        throw PartnerLostError("connection closed by the partner (" + errnoText(e) + ") while sending");
      throw TransportError("send failed: " + errnoText(e));
    }
  }

  void receive(std::uint8_t* p, std::size_t n, Deadline d) override {
    std::size_t done = 0;
    while (done < n) {
      const ssize_t k = ::recv(fd_, p + done, n - done, 0);
      if (k > 0) {
        done += std::size_t(k);
        continue;
      }
      if (k == 0)
        throw PartnerLostError("the partner closed the connection (end of stream) after " + std::to_string(done) +
                               " of " + std::to_string(n) + " expected bytes");
      if (errno == EINTR) continue;
      if (errno == EAGAIN || errno == EWOULDBLOCK) {
        pollfd pf{fd_, POLLIN, 0};
        const int r = ::poll(&pf, 1, pollMs(d));
        if (r == 0)
          throw TimeoutError("nothing arrived (" + std::to_string(done) + " of " + std::to_string(n) +
                             " expected bytes received)");
        if (r < 0 && errno != EINTR) throw TransportError("poll failed: " + errnoText(errno));
        continue;
      }
      const int e = errno;
      if (e == ECONNRESET || e == ENOTCONN || e == EPIPE)
        throw PartnerLostError("connection reset by the partner (" + errnoText(e) + ")");
      throw TransportError("receive failed: " + errnoText(e));
    }
  }

  void close() noexcept override {
    if (fd_ >= 0) {
      ::close(fd_);
      fd_ = -1;
    }
  }
  std::string describe() const override { return desc_; }

 private:
  int fd_;
  std::string desc_;
};

addrinfo* resolve(const std::string& host, int port, bool passive) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = passive ? AI_PASSIVE : 0;
  addrinfo* res = nullptr;
  const int rc = getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &res);
  if (rc != 0) throw TransportError("cannot resolve address '" + host + "': " + gai_strerror(rc));
  return res;
}

class TcpListener final : public Listener {
 public:
  TcpListener(const TransportOptions& o, const std::string& me, const std::string& partner)
      : me_(me), partner_(partner) {
    addrinfo* res = resolve(o.bindAddress, o.port, true);
    int lastErr = 0;
    for (addrinfo* a = res; a; a = a->ai_next) {
      fd_ = ::socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
      if (fd_ < 0) {
        lastErr = errno;
        continue;
      }
      if (::bind(fd_, a->ai_addr, a->ai_addrlen) == 0 && ::listen(fd_, 8) == 0) break;
      lastErr = errno;
      ::close(fd_);
      fd_ = -1;
    }
    freeaddrinfo(res);
    if (fd_ < 0)
      throw TransportError("participant '" + me + "' cannot listen on " + o.bindAddress + ":" + std::to_string(o.port) +
                           ": " + errnoText(lastErr));
    int flags = fcntl(fd_, F_GETFL, 0);
    fcntl(fd_, F_SETFL, flags | O_NONBLOCK);
    sockaddr_storage sa{};
    socklen_t len = sizeof sa;
    getsockname(fd_, reinterpret_cast<sockaddr*>(&sa), &len);
    port_ = sa.ss_family == AF_INET6 ? ntohs(reinterpret_cast<sockaddr_in6*>(&sa)->sin6_port)
                                     : ntohs(reinterpret_cast<sockaddr_in*>(&sa)->sin_port);
    host_ = o.bindAddress;
    if (!o.addressFile.empty()) {
      const std::string tmp = o.addressFile + ".tmp." + std::to_string(::getpid());
      {
        std::ofstream f(tmp);
        f << tcpAddressLine(host_, port_);
        if (!f) {
          ::close(fd_);
          throw TransportError("participant '" + me + "' cannot write its address file '" + tmp + "'");
        }
      }
      if (std::rename(tmp.c_str(), o.addressFile.c_str()) != 0) {
        ::close(fd_);
        throw TransportError("participant '" + me + "' cannot publish its address file '" + o.addressFile +
                             "': " + errnoText(errno));
      }
      file_ = o.addressFile;
    }
  }
  ~TcpListener() override {
    if (fd_ >= 0) ::close(fd_);
    if (!file_.empty()) std::remove(file_.c_str());
  }

  std::unique_ptr<Channel> accept(Deadline d) override {
    for (;;) {
      sockaddr_storage peer{};
      socklen_t len = sizeof peer;
      const int c = ::accept4(fd_, reinterpret_cast<sockaddr*>(&peer), &len, SOCK_CLOEXEC);
      if (c >= 0) {
        tune(c);
        return std::make_unique<TcpChannel>(c, "tcp " + host_ + ":" + std::to_string(port_) + " <- " + peerName(peer));
      }
      if (errno == EINTR || errno == ECONNABORTED) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) throw TransportError("accept failed: " + errnoText(errno));
      pollfd pf{fd_, POLLIN, 0};
      const int r = ::poll(&pf, 1, pollMs(d));
      if (r == 0)
        throw TimeoutError("participant '" + me_ + "' listened on " + describe() + " but '" + partner_ +
                           "' did not connect in time");
    }
  }
  std::string describe() const override {
    return "tcp " + host_ + ":" + std::to_string(port_) + (file_.empty() ? "" : " (address file " + file_ + ")");
  }
  bool canAcceptAgain() const override { return true; }

 private:
  int fd_ = -1;
  int port_ = 0;
  std::string host_, file_, me_, partner_;
};

}  // namespace

std::unique_ptr<Listener> makeTcpListener(const TransportOptions& o, const std::string& me,
                                          const std::string& partner) {
  return std::make_unique<TcpListener>(o, me, partner);
}

std::unique_ptr<Channel> connectTcp(const TransportOptions& o, const std::string& me, const std::string& partner,
                                    Deadline d) {
  std::string host = o.connectHost;
  int port = o.connectPort;
  std::string lastProblem;
  const auto nap = [] { std::this_thread::sleep_for(std::chrono::milliseconds(20)); };
  for (;;) {
    if (o.connectPort <= 0) {
      if (o.addressFile.empty())
        throw ConfigError("participant '" + me + "' must connect to '" + partner +
                          "' but has neither an address file nor a port");
      std::ifstream f(o.addressFile);
      std::string line;
      if (f && std::getline(f, line)) line += "\n";
      if (!parseTcpAddressLine(line, host, port)) {
        lastProblem = "address file '" + o.addressFile + "' of '" + partner +
                      (f ? "' is not complete or not valid" : "' does not exist");
        if (d.remaining() <= 0) break;
        nap();
        continue;
      }
    }
    addrinfo* res = nullptr;
    try {
      res = resolve(host, port, false);
    } catch (const TransportError& e) {
      throw TransportError("participant '" + me + "': " + e.what());
    }
    for (addrinfo* a = res; a; a = a->ai_next) {
      const int s = ::socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
      if (s < 0) continue;
      tune(s);
      int rc = ::connect(s, a->ai_addr, a->ai_addrlen);
      if (rc < 0 && errno == EINPROGRESS) {
        pollfd pf{s, POLLOUT, 0};
        rc = ::poll(&pf, 1, std::max(1, std::min(pollMs(d), 1000)));
        int err = 0;
        socklen_t len = sizeof err;
        if (rc > 0) getsockopt(s, SOL_SOCKET, SO_ERROR, &err, &len);
        if (rc > 0 && err == 0)
          rc = 0;
        else {
          errno = rc == 0 ? ETIMEDOUT : err;
          rc = -1;
        }
      }
      if (rc == 0) {
        freeaddrinfo(res);
        return std::make_unique<TcpChannel>(s, "tcp -> " + host + ":" + std::to_string(port));
      }
      lastProblem = "connection to " + host + ":" + std::to_string(port) + " failed: " + errnoText(errno);
      ::close(s);
    }
    freeaddrinfo(res);
    if (d.remaining() <= 0) break;
    nap();
  }
  throw TimeoutError("participant '" + me + "' could not reach '" + partner +
                     "' before the connect timeout: " + lastProblem);
}

}  // namespace tq::coupler::detail
