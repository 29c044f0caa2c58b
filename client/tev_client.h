// Frames to the tev image viewer over its TCP protocol (the one tev's own Python client speaks):
// a CreateImage packet, then UpdateImage (v3) packets of 128x128 tiles of linear RGBA floats.
// Every packet is a little-endian uint32 length (of the whole packet), a type byte and fields;
// strings end with a zero byte.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "absl/status/statusor.h"

namespace caustica::client {

class TevClient {
 public:
  // Connects to "HOST:PORT" (tev listens on 127.0.0.1:14158 by default). UNAVAILABLE naming
  // the address when nothing listens there.
  static absl::StatusOr<std::unique_ptr<TevClient>> connect(const std::string& address);
  ~TevClient();
  TevClient(const TevClient&) = delete;
  TevClient& operator=(const TevClient&) = delete;

  // A black image `name` with channels R, G, B, A (tev replaces one of the same name).
  absl::Status create_image(const std::string& name, int width, int height);
  // The whole image's pixels: linear RGBA floats, top row first.
  absl::Status update_image(const std::string& name, int width, int height,
                            std::span<const float> rgba);

 private:
  TevClient(int fd, std::string address) : fd_(fd), address_(std::move(address)) {}
  absl::Status send(const std::string& packet);

  int fd_;
  std::string address_;
};

// The bytes of the packets themselves, for tests and for TevClient.
std::string tev_create_image_packet(const std::string& name, int width, int height);
std::string tev_update_image_packet(const std::string& name, int x, int y, int width, int height,
                                    int image_width, std::span<const float> rgba);

}  // namespace caustica::client
