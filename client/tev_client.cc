#include "client/tev_client.h"

#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"

namespace caustica::client {
namespace {

// Packet types of tev's protocol.
constexpr uint8_t kCreateImage = 4;
constexpr uint8_t kUpdateImageV3 = 6;
// Tiles keep each packet small, as tev's own client does.
constexpr int kTile = 128;
constexpr const char* kChannels[4] = {"R", "G", "B", "A"};

template <typename T>
void put(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // little-endian hosts only, as the RAW frames
  out.append(bytes, sizeof(T));
}

void put_string(std::string& out, const std::string& text) {
  out.append(text);
  out.push_back('\0');
}

// Writes the packet's total length into its first four bytes.
std::string finish(std::string packet) {
  const uint32_t length = static_cast<uint32_t>(packet.size());
  std::memcpy(packet.data(), &length, sizeof(length));
  return packet;
}

}  // namespace

std::string tev_create_image_packet(const std::string& name, int width, int height) {
  std::string packet(4, '\0');
  put<uint8_t>(packet, kCreateImage);
  put<uint8_t>(packet, 1);  // grab focus
  put_string(packet, name);
  put<int32_t>(packet, width);
  put<int32_t>(packet, height);
  put<int32_t>(packet, 4);
  for (const char* channel : kChannels) put_string(packet, channel);
  return finish(std::move(packet));
}

std::string tev_update_image_packet(const std::string& name, int x, int y, int width, int height,
                                    int image_width, std::span<const float> rgba) {
  std::string packet(4, '\0');
  put<uint8_t>(packet, kUpdateImageV3);
  put<uint8_t>(packet, 0);  // grab focus
  put_string(packet, name);
  put<int32_t>(packet, 4);
  for (const char* channel : kChannels) put_string(packet, channel);
  put<int32_t>(packet, x);
  put<int32_t>(packet, y);
  put<int32_t>(packet, width);
  put<int32_t>(packet, height);
  for (int64_t c = 0; c < 4; ++c) put<int64_t>(packet, c);  // channel offsets in the tile
  for (int c = 0; c < 4; ++c) put<int64_t>(packet, 4);      // channel strides: interleaved
  const size_t header = packet.size();
  packet.resize(header + size_t(width) * height * 4 * sizeof(float));
  char* out = packet.data() + header;
  for (int row = 0; row < height; ++row) {
    const float* source = rgba.data() + (size_t(y + row) * image_width + x) * 4;
    const size_t bytes = size_t(width) * 4 * sizeof(float);
    std::memcpy(out, source, bytes);
    out += bytes;
  }
  return finish(std::move(packet));
}

absl::StatusOr<std::unique_ptr<TevClient>> TevClient::connect(const std::string& address) {
  const size_t colon = address.rfind(':');
  int port = 0;
  if (colon == std::string::npos || colon == 0 ||
      !absl::SimpleAtoi(address.substr(colon + 1), &port) || port <= 0 || port > 65535) {
    return absl::InvalidArgumentError(
        absl::StrCat("--tev: '", address, "' is not HOST:PORT (tev listens on 127.0.0.1:14158)"));
  }
  std::string host = address.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']')
    host = host.substr(1, host.size() - 2);
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  if (const int error =
          getaddrinfo(host.c_str(), address.substr(colon + 1).c_str(), &hints, &found);
      error != 0) {
    return absl::UnavailableError(
        absl::StrCat("--tev: cannot resolve '", host, "': ", gai_strerror(error)));
  }
  std::string why = "no address";
  for (addrinfo* a = found; a != nullptr; a = a->ai_next) {
    const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) continue;
    if (::connect(fd, a->ai_addr, a->ai_addrlen) == 0) {
      freeaddrinfo(found);
      return std::unique_ptr<TevClient>(new TevClient(fd, address));
    }
    why = std::strerror(errno);
    ::close(fd);
  }
  freeaddrinfo(found);
  return absl::UnavailableError(
      absl::StrCat("--tev: cannot connect to tev at ", address, ": ", why, " (is tev running?)"));
}

TevClient::~TevClient() { ::close(fd_); }

absl::Status TevClient::send(const std::string& packet) {
  size_t sent = 0;
  while (sent < packet.size()) {
    const ssize_t n = ::send(fd_, packet.data() + sent, packet.size() - sent, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      return absl::UnavailableError(absl::StrCat("--tev: lost the connection to tev at ", address_,
                                                 ": ", std::strerror(errno)));
    }
    sent += static_cast<size_t>(n);
  }
  return absl::OkStatus();
}

absl::Status TevClient::create_image(const std::string& name, int width, int height) {
  return send(tev_create_image_packet(name, width, height));
}

absl::Status TevClient::update_image(const std::string& name, int width, int height,
                                     std::span<const float> rgba) {
  if (rgba.size() != size_t(width) * height * 4) {
    return absl::InvalidArgumentError(
        absl::StrCat("--tev: ", rgba.size(), " values do not hold ", width, "x", height, " RGBA"));
  }
  for (int y = 0; y < height; y += kTile) {
    for (int x = 0; x < width; x += kTile) {
      const std::string packet = tev_update_image_packet(name, x, y, std::min(kTile, width - x),
                                                         std::min(kTile, height - y), width, rgba);
      if (absl::Status sent = send(packet); !sent.ok()) return sent;
    }
  }
  return absl::OkStatus();
}

}  // namespace caustica::client
