// caustica stream --tev: the packets of tev's TCP protocol, read back by a parser written here
// from the protocol's description (tev's Python client), and a real stream into a listening socket
// standing in for tev, whose last image must equal the PFM frame written beside it.
#include "client/tev_client.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <thread>
#include <vector>

#include "tests/client/client_run.h"

namespace caustica::client {
namespace {

// Reads what tev reads: packets of (uint32 length, uint8 type, fields).
class PacketReader {
 public:
  explicit PacketReader(const std::string& bytes) : bytes_(bytes) {}
  template <typename T>
  T get() {
    T value{};
    EXPECT_LE(at_ + sizeof(T), bytes_.size());
    if (at_ + sizeof(T) <= bytes_.size()) std::memcpy(&value, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return value;
  }
  std::string string() {
    const size_t end = bytes_.find('\0', at_);
    EXPECT_NE(end, std::string::npos);
    std::string out = bytes_.substr(at_, end - at_);
    at_ = end + 1;
    return out;
  }
  size_t at() const { return at_; }
  bool done() const { return at_ >= bytes_.size(); }

 private:
  const std::string& bytes_;
  size_t at_ = 0;
};

// The images a stream of packets leaves in tev: name -> (width, height, RGBA).
struct TevImage {
  int width = 0, height = 0;
  std::vector<float> rgba;
  int updates = 0;
};

std::map<std::string, TevImage> replay(const std::string& stream) {
  std::map<std::string, TevImage> images;
  PacketReader in(stream);
  while (!in.done()) {
    const size_t start = in.at();
    const uint32_t length = in.get<uint32_t>();
    const uint8_t type = in.get<uint8_t>();
    in.get<uint8_t>();  // grab focus
    const std::string name = in.string();
    if (type == 4) {
      TevImage& image = images[name];
      image.width = in.get<int32_t>();
      image.height = in.get<int32_t>();
      EXPECT_EQ(in.get<int32_t>(), 4);
      for (const char* expected : {"R", "G", "B", "A"}) EXPECT_EQ(in.string(), expected);
      image.rgba.assign(size_t(image.width) * image.height * 4, 0.0f);
    } else {
      EXPECT_EQ(type, 6) << "only CreateImage and UpdateImage v3 are sent";
      TevImage& image = images.at(name);
      const int32_t channels = in.get<int32_t>();
      std::vector<std::string> names;
      for (int c = 0; c < channels; ++c) names.push_back(in.string());
      const int32_t x = in.get<int32_t>(), y = in.get<int32_t>();
      const int32_t w = in.get<int32_t>(), h = in.get<int32_t>();
      std::vector<int64_t> offsets(channels), strides(channels);
      for (int64_t& o : offsets) o = in.get<int64_t>();
      for (int64_t& s : strides) s = in.get<int64_t>();
      std::vector<float> tile(size_t(w) * h * channels);
      for (float& v : tile) v = in.get<float>();
      for (int row = 0; row < h; ++row) {
        for (int col = 0; col < w; ++col) {
          for (int c = 0; c < channels; ++c) {
            const int channel = static_cast<int>(std::string("RGBA").find(names[c]));
            const float value = tile[offsets[c] + (size_t(row) * w + col) * strides[c]];
            image.rgba[(size_t(y + row) * image.width + x + col) * 4 + channel] = value;
          }
        }
      }
      ++image.updates;
    }
    EXPECT_EQ(in.at() - start, length) << "packet length field";
  }
  return images;
}

TEST(TevClient, CreateImagePacketHasTheProtocolsLayout) {
  const std::string packet = tev_create_image_packet("a", 3, 2);
  const std::string expected(
      "\x1c\x00\x00\x00"  // 28 bytes in all
      "\x04\x01"          // CreateImage, grab focus
      "a\x00"
      "\x03\x00\x00\x00\x02\x00\x00\x00\x04\x00\x00\x00"
      "R\x00"
      "G\x00"
      "B\x00"
      "A\x00",
      28);
  EXPECT_EQ(packet, expected);
}

TEST(TevClient, UpdatesTileTheImageAndRebuildIt) {
  const int width = 130, height = 129;  // tiles of 128 with partial ones at the edges
  std::vector<float> rgba(size_t(width) * height * 4);
  for (size_t i = 0; i < rgba.size(); ++i) rgba[i] = 0.25f * float(i % 977) - 3.0f;
  std::string stream = tev_create_image_packet("img", width, height);
  for (int y = 0; y < height; y += 128)
    for (int x = 0; x < width; x += 128)
      stream += tev_update_image_packet("img", x, y, std::min(128, width - x),
                                        std::min(128, height - y), width, rgba);
  const auto images = replay(stream);
  ASSERT_EQ(images.size(), 1u);
  EXPECT_EQ(images.at("img").updates, 4);
  EXPECT_EQ(images.at("img").rgba, rgba);
}

// A listening socket that records everything one client sends, as tev would receive it.
class FakeTev {
 public:
  FakeTev() {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(::bind(fd_, reinterpret_cast<sockaddr*>(&address), sizeof(address)), 0);
    socklen_t size = sizeof(address);
    ::getsockname(fd_, reinterpret_cast<sockaddr*>(&address), &size);
    port_ = ntohs(address.sin_port);
    EXPECT_EQ(::listen(fd_, 1), 0);
    thread_ = std::thread([this] {
      const int client = ::accept(fd_, nullptr, nullptr);
      if (client < 0) return;
      char buffer[65536];
      for (ssize_t n; (n = ::recv(client, buffer, sizeof(buffer), 0)) > 0;)
        received_.append(buffer, n);
      ::close(client);
    });
  }
  ~FakeTev() {
    ::shutdown(fd_, SHUT_RDWR);
    if (thread_.joinable()) thread_.join();
    ::close(fd_);
  }
  int port() const { return port_; }
  // Waits for the client to close the connection.
  const std::string& received() {
    thread_.join();
    return received_;
  }

 private:
  int fd_ = -1;
  int port_ = 0;
  std::thread thread_;
  std::string received_;
};

using ::caustica::testing::CommandRun;
using ::caustica::testing::run_client;

// RGB floats of a PFM the CLI wrote, top row first, with alpha 1 added.
std::vector<float> read_pfm_rgba(const std::filesystem::path& path, int width, int height) {
  std::ifstream in(path, std::ios::binary);
  std::string magic, scale;
  int w = 0, h = 0;
  in >> magic >> w >> h >> scale;
  in.get();
  EXPECT_EQ(w, width);
  EXPECT_EQ(h, height);
  std::vector<float> rgb(size_t(w) * h * 3);
  in.read(reinterpret_cast<char*>(rgb.data()), rgb.size() * sizeof(float));
  std::vector<float> rgba(size_t(w) * h * 4);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 4; ++c)
        rgba[(size_t(y) * w + x) * 4 + c] =
            c == 3 ? 1.0f : rgb[(size_t(h - 1 - y) * w + x) * 3 + c];
  return rgba;
}

TEST(TevClient, StreamShowsEveryFrameInTev) {
  FakeTev tev;
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("caustica-tev-" + std::to_string(::getpid()));
  const CommandRun run = run_client(
      std::string("stream '") + CAUSTICA_SCENES_DIR + "/cornell-box/scene.json' --width 20 " +
      "--height 12 --photons 500 --passes 3 --every 1 --format pfm -o '" + dir.string() +
      "' --tev 127.0.0.1:" + std::to_string(tev.port()));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const auto images = replay(tev.received());
  ASSERT_EQ(images.size(), 1u);
  const TevImage& image = images.begin()->second;
  EXPECT_EQ(images.begin()->first.rfind("caustica ", 0), 0u) << images.begin()->first;
  EXPECT_EQ(image.width, 20);
  EXPECT_EQ(image.height, 12);
  EXPECT_EQ(image.updates, 3) << "one tile per frame, a frame per pass";
  const std::vector<float> last = read_pfm_rgba(dir / "frame_0002.pfm", 20, 12);
  EXPECT_EQ(image.rgba, last);
  std::filesystem::remove_all(dir);
}

TEST(TevClient, NoViewerIsAnErrorBeforeAnyUpload) {
  int port = 0;
  {
    FakeTev closed;  // a port nothing listens on once it is gone
    port = closed.port();
  }
  const CommandRun run =
      run_client(std::string("stream '") + CAUSTICA_SCENES_DIR +
                 "/cornell-box/scene.json' --tev 127.0.0.1:" + std::to_string(port));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("cannot connect to tev at 127.0.0.1:" + std::to_string(port)),
            std::string::npos)
      << run.output;
  const CommandRun png = run_client("stream s-1 -o out --format png --tev 127.0.0.1:1");
  EXPECT_NE(png.exit_code, 0);
  EXPECT_NE(png.output.find("--format exr or pfm"), std::string::npos) << png.output;
  const CommandRun neither = run_client("stream s-1");
  EXPECT_NE(neither.exit_code, 0);
  EXPECT_NE(neither.output.find("give -o DIR, --tev HOST:PORT or both"), std::string::npos)
      << neither.output;
}

}  // namespace
}  // namespace caustica::client
