#pragma once
// The page's server (cpp-httplib): GET only, every request carries the token of the URL
// it printed (else 403), bound to 127.0.0.1 unless the operator chose otherwise.
#include <memory>
#include <string>

#include "burrbench/watch/feed.hpp"

namespace burrbench::watch {

struct ServerOptions {
  std::string bind = "127.0.0.1";
  int port = 0;           // 0: a free port
  std::string token;      // empty: a random one (random_token())
  std::string page_html;  // served at /
};

// 128 random bits as 32 hex digits (std::random_device: the kernel's generator).
std::string random_token();
bool is_loopback(const std::string& host);

class WatchServer {
 public:
  // Binds and starts serving on a thread of its own; InputError when it cannot bind.
  WatchServer(Feed& feed, ServerOptions options);
  ~WatchServer();
  WatchServer(const WatchServer&) = delete;
  WatchServer& operator=(const WatchServer&) = delete;
  int port() const;
  const std::string& token() const;
  std::string url() const;  // http://HOST:PORT/?token=…
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace burrbench::watch
