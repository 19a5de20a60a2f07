#include "burrbench/watch/feed.hpp"

#include "burrbench/data_schema/error.hpp"

namespace burrbench::watch {

void Feed::publish_first(std::string json) {
  {
    std::lock_guard lock(m_);
    BURRBENCH_CHECK(!first_ && messages_.empty() && dropped_ == 0, "the first message comes first");
    first_ = std::move(json);
  }
  cv_.notify_all();
}

void Feed::publish(std::string json) {
  {
    std::lock_guard lock(m_);
    bytes_ += json.size();
    messages_.push_back(std::move(json));
    while (bytes_ > budget_bytes_ && messages_.size() > 1) {
      bytes_ -= messages_.front().size();
      messages_.pop_front();
      ++dropped_;
    }
  }
  cv_.notify_all();
}

std::vector<std::string> Feed::since(std::size_t& next, std::chrono::milliseconds wait) {
  std::unique_lock lock(m_);
  const auto end = [&] { return dropped_ + messages_.size() + 1; };  // one past the newest position
  cv_.wait_for(lock, wait, [&] { return next < end() || closed_ || (next == 0 && first_); });
  std::vector<std::string> out;
  if (next == 0 && first_) out.push_back(*first_);
  next = std::max(next, dropped_ + 1);  // position 0 is the first message, then the others
  for (; next < end(); ++next) out.push_back(messages_[next - dropped_ - 1]);
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

std::size_t Feed::dropped() const {
  std::lock_guard lock(m_);
  return dropped_;
}

}  // namespace burrbench::watch
