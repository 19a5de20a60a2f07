#include "burrbench/watch/feed.hpp"

namespace burrbench::watch {

void Feed::publish(std::string json) {
  {
    std::lock_guard lock(m_);
    messages_.push_back(std::move(json));
  }
  cv_.notify_all();
}

std::vector<std::string> Feed::since(std::size_t& next, std::chrono::milliseconds wait) {
  std::unique_lock lock(m_);
  cv_.wait_for(lock, wait, [&] { return next < messages_.size() || closed_; });
  std::vector<std::string> out;
  for (; next < messages_.size(); ++next) out.push_back(messages_[next]);
  return out;
}

void Feed::close() {
  {
    std::lock_guard lock(m_);
    closed_ = true;
  }
  cv_.notify_all();
}

bool Feed::closed() const {
  std::lock_guard lock(m_);
  return closed_;
}

std::size_t Feed::size() const {
  std::lock_guard lock(m_);
  return messages_.size();
}

}  // namespace burrbench::watch
