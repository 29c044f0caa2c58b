// The device queue: first come first served, a waiter that gives up leaves the line, and
// shutdown wakes every waiter.
#include "server/device_queue.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

namespace caustica::server {
namespace {

using namespace std::chrono_literals;

// Waits until `queue` has `n` waiters (they queue from other threads).
void wait_for_waiters(const DeviceQueue& queue, size_t n) {
  const auto give_up = std::chrono::steady_clock::now() + 10s;
  while (queue.waiting() < n && std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(1ms);
  }
  ASSERT_EQ(queue.waiting(), n);
}

TEST(DeviceQueue, ServesWaitersInArrivalOrder) {
  DeviceQueue queue;
  absl::StatusOr<DeviceQueue::Lease> first = queue.acquire();
  ASSERT_TRUE(first.ok());
  std::mutex mutex;
  std::vector<int> order;
  std::vector<std::thread> waiters;
  for (int i = 0; i < 4; ++i) {
    waiters.emplace_back([&, i] {
      absl::StatusOr<DeviceQueue::Lease> lease = queue.acquire();
      ASSERT_TRUE(lease.ok());
      std::lock_guard<std::mutex> lock(mutex);
      order.push_back(i);
    });
    wait_for_waiters(queue, i + 1);  // so arrival order is i
  }
  first->release();
  for (std::thread& t : waiters) t.join();
  EXPECT_EQ(order, (std::vector<int>{0, 1, 2, 3}));
}

TEST(DeviceQueue, JobsThatRequeueInterleave) {
  // Two jobs of three units each: holding the device for one unit at a time and queueing again
  // makes them alternate instead of one finishing before the other starts.
  DeviceQueue queue;
  absl::StatusOr<DeviceQueue::Lease> gate = queue.acquire();
  std::mutex mutex;
  std::string trace;
  auto job = [&](char name) {
    for (int unit = 0; unit < 3; ++unit) {
      absl::StatusOr<DeviceQueue::Lease> lease = queue.acquire();
      ASSERT_TRUE(lease.ok());
      std::lock_guard<std::mutex> lock(mutex);
      trace += name;
      // Let the other job reach the line before this one queues again.
      std::this_thread::sleep_for(5ms);
    }
  };
  std::thread a(job, 'a');
  wait_for_waiters(queue, 1);
  std::thread b(job, 'b');
  wait_for_waiters(queue, 2);
  gate->release();
  a.join();
  b.join();
  EXPECT_EQ(trace, "ababab");
}

TEST(DeviceQueue, StopCheckLeavesTheLine) {
  DeviceQueue queue;
  absl::StatusOr<DeviceQueue::Lease> holder = queue.acquire();
  std::atomic<bool> cancel{false};
  absl::Status result;
  std::thread waiter([&] {
    absl::StatusOr<DeviceQueue::Lease> lease = queue.acquire(
        [&] { return cancel ? absl::CancelledError("cancelled") : absl::OkStatus(); });
    result = lease.status();
  });
  wait_for_waiters(queue, 1);
  cancel = true;
  waiter.join();
  EXPECT_EQ(result.code(), absl::StatusCode::kCancelled);
  EXPECT_EQ(queue.waiting(), 0u);
  holder->release();
  EXPECT_TRUE(queue.acquire().ok()) << "the cancelled waiter must not block the line";
}

TEST(DeviceQueue, ShutdownWakesWaitersWithUnavailable) {
  DeviceQueue queue;
  absl::StatusOr<DeviceQueue::Lease> holder = queue.acquire();
  absl::Status result;
  std::thread waiter([&] { result = queue.acquire().status(); });
  wait_for_waiters(queue, 1);
  queue.shut_down();
  waiter.join();
  EXPECT_EQ(result.code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(queue.acquire().status().code(), absl::StatusCode::kUnavailable);
}

}  // namespace
}  // namespace caustica::server
