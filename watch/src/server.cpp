#include "burrbench/watch/server.hpp"

#include <fmt/format.h>
#include <httplib.h>

#include <atomic>
#include <random>
#include <thread>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::watch {

std::string random_token() {
  std::random_device rd;  // glibc: getrandom(2), the kernel's generator
  std::string out;
  for (int i = 0; i < 4; ++i) out += fmt::format("{:08x}", rd());
  return out;
}

bool is_loopback(const std::string& host) {
  return host == "localhost" || host == "::1" || host.rfind("127.", 0) == 0;
}

namespace {

// Compares without stopping at the first difference: the time taken tells nothing of
// how much of a guessed token was right.
bool same_token(const std::string& a, const std::string& b) {
  unsigned diff = a.size() == b.size() ? 0u : 1u;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) diff |= unsigned(a[i] ^ b[i]);
  return diff == 0 && !b.empty();
}

}  // namespace

struct WatchServer::Impl {
  Feed& feed;
  ServerOptions opt;
  httplib::Server server;
  std::thread thread;
  int port = 0;
  std::atomic<bool> stopping{false};
  Impl(Feed& f, ServerOptions o) : feed(f), opt(std::move(o)) {}
};

WatchServer::WatchServer(Feed& feed, ServerOptions options)
    : impl_(std::make_unique<Impl>(feed, std::move(options))) {
  Impl& s = *impl_;
  if (s.opt.token.empty()) s.opt.token = random_token();
  // Read-only and token-bound before any route: a request without the URL's token, or
  // one that is not a GET, is refused whatever it asks for.
  s.server.set_pre_routing_handler([&s](const httplib::Request& req, httplib::Response& res) {
    if (req.method != "GET" && req.method != "HEAD") {
      res.status = 405;
      res.set_content("read-only: GET only\n", "text/plain");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (!same_token(req.get_param_value("token"), s.opt.token)) {
      res.status = 403;
      res.set_content("forbidden: open the URL burrbench watch printed (its token)\n",
                      "text/plain");
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  s.server.Get("/", [&s](const httplib::Request&, httplib::Response& res) {
    res.set_header("Cache-Control", "no-store");
    res.set_content(s.opt.page_html, "text/html; charset=utf-8");
  });
  // Server-Sent Events: each feed message is one event; a comment line every half
  // second keeps proxies and the browser from timing the stream out.
  s.server.Get("/events", [&s](const httplib::Request&, httplib::Response& res) {
    res.set_header("Cache-Control", "no-store");
    res.set_chunked_content_provider(
        "text/event-stream",
        [&s, next = std::size_t(0)](std::size_t, httplib::DataSink& sink) mutable {
          if (s.stopping || !sink.is_writable()) return false;
          const auto messages = s.feed.since(next, std::chrono::milliseconds(500));
          std::string out;
          for (const auto& m : messages) out += "data: " + m + "\n\n";
          if (out.empty()) out = ": idle\n\n";
          if (!sink.write(out.data(), out.size())) return false;
          if (messages.empty() && s.feed.closed()) sink.done();
          return true;
        });
  });
  s.port = s.opt.port == 0 ? s.server.bind_to_any_port(s.opt.bind)
                           : (s.server.bind_to_port(s.opt.bind, s.opt.port) ? s.opt.port : -1);
  if (s.port <= 0)
    throw InputError("--bind/--port", fmt::format("{}:{}", s.opt.bind, s.opt.port),
                     "an address and port this host can listen on", "cannot bind");
  s.thread = std::thread([&s] { s.server.listen_after_bind(); });
}

WatchServer::~WatchServer() { stop(); }

int WatchServer::port() const { return impl_->port; }
const std::string& WatchServer::token() const { return impl_->opt.token; }

std::string WatchServer::url() const {
  const std::string host = impl_->opt.bind.find(':') != std::string::npos
                               ? "[" + impl_->opt.bind + "]"
                               : impl_->opt.bind;
  return fmt::format("http://{}:{}/?token={}", host == "0.0.0.0" ? "HOST" : host, impl_->port,
                     impl_->opt.token);
}

void WatchServer::stop() {
  if (!impl_ || impl_->stopping.exchange(true)) return;
  impl_->feed.close();
  impl_->server.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

}  // namespace burrbench::watch
