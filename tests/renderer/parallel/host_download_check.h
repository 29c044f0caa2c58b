// A check for either backend: a buffer downloaded into a HostBuffer holds what was uploaded, a
// smaller download reuses the same host memory, and a larger one grows it.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "renderer/parallel/buffer.h"

namespace caustica {

inline void expect_download_into_host_buffer(Backend& backend,
                                             const std::vector<uint32_t>& values) {
  Buffer<uint32_t> device(backend, values.size());
  device.upload(values);
  HostBuffer<uint32_t> host(backend);
  std::span<const uint32_t> got = device.download(host);
  EXPECT_TRUE(std::ranges::equal(got, values));
  if (values.empty()) return;

  const uint32_t* first = got.data();
  const std::vector<uint32_t> fewer(values.begin(), values.begin() + values.size() / 2);
  device.upload(fewer);
  got = device.download(host);
  EXPECT_EQ(got.data(), first) << "a smaller download reuses the host memory";
  EXPECT_TRUE(std::ranges::equal(got, fewer));

  std::vector<uint32_t> more(2 * values.size());
  for (size_t i = 0; i < more.size(); ++i) more[i] = uint32_t(i) * 2654435761u;
  device.upload(more);
  EXPECT_TRUE(std::ranges::equal(device.download(host), more));
}

}  // namespace caustica
