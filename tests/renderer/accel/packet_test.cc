// Packet traversal against the single-ray closest hit it must reproduce.
#include <gtest/gtest.h>

#include "renderer/accel/packet_traversal.h"
#include "renderer/render/camera.h"
#include "renderer/scene/load_scene.h"
#include "tests/renderer/accel/triangle_soup.h"

namespace caustica {
namespace {

std::vector<TriangleVertices> triangles_of(const Scene& scene) {
  std::vector<TriangleVertices> tris;
  for (const Mesh& m : scene.meshes)
    for (size_t t = 0; t < m.triangle_count(); ++t)
      tris.push_back({m.positions[m.indices[3 * t]], m.positions[m.indices[3 * t + 1]],
                      m.positions[m.indices[3 * t + 2]]});
  return tris;
}

void check_packets(const std::vector<TriangleVertices>& tris, Camera cam) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  Buffer<TriangleVertices> input(*backend, tris.size());
  input.upload(tris);
  TriangleBvh bvh = build_triangle_bvh(*backend, input.data(), uint32_t(tris.size()));
  cam.width = 100;  // not a multiple of the tile: partial packets too
  cam.height = 70;
  PinholeCamera pc = PinholeCamera::from(cam);
  int hits = 0, rays = 0;
  for (int ty = 0; ty < cam.height; ty += kPacketTile) {
    for (int tx = 0; tx < cam.width; tx += kPacketTile) {
      RayPacket packet;
      packet.origin = pc.origin;
      int px[kPacketRays], py[kPacketRays];
      for (int y = ty; y < std::min(ty + kPacketTile, cam.height); ++y)
        for (int x = tx; x < std::min(tx + kPacketTile, cam.width); ++x) {
          px[packet.count] = x;
          py[packet.count] = y;
          packet.direction[packet.count++] = pc.ray_through(x + 0.5f, y + 0.5f).direction;
        }
      Hit got[kPacketRays];
      closest_hit_packet(bvh.view(), packet, got);
      for (int i = 0; i < packet.count; ++i) {
        Hit expected = closest_hit(bvh.view(), pc.ray_through(px[i] + 0.5f, py[i] + 0.5f));
        ++rays;
        ASSERT_EQ(got[i].valid(), expected.valid()) << px[i] << "," << py[i];
        if (!expected.valid()) continue;
        ++hits;
        ASSERT_EQ(got[i].t, expected.t) << px[i] << "," << py[i];
        if (got[i].triangle == expected.triangle) {
          ASSERT_EQ(got[i].u, expected.u);
          ASSERT_EQ(got[i].v, expected.v);
        }
      }
    }
  }
  EXPECT_EQ(rays, cam.width * cam.height);
  EXPECT_GT(hits, rays / 4);
}

void check_packets(const std::string& scene_name, const Camera* camera_override) {
  absl::StatusOr<Scene> scene =
      load_scene(std::string(CAUSTICA_SCENES_DIR) + "/" + scene_name + "/scene.json");
  ASSERT_TRUE(scene.ok()) << scene.status();
  check_packets(triangles_of(*scene), camera_override ? *camera_override : scene->camera);
}

TEST(PacketTraversal, MatchesSingleRaysFromTheSceneCameras) {
  for (const char* name : {"cornell-box", "cornell-caustics", "ring"}) {
    SCOPED_TRACE(name);
    check_packets(name, nullptr);
  }
}

// Many small triangles, so that most leaves hold several and packets meet leaves of every size.
TEST(PacketTraversal, MatchesSingleRaysOnADenseSoup) {
  Camera cam;
  cam.position = Vec3f(3, 4, -40);
  cam.look_at = Vec3f(0, 0, 0);
  cam.vertical_fov_deg = 40;
  check_packets(random_soup(30000, 11), cam);
}

TEST(PacketTraversal, MatchesSingleRaysWhenTilesStraddleAxisPlanes) {
  // Looking along +x from inside the box: directions change sign across the image centre lines,
  // so some packets take the per-ray fallback.
  Camera cam;
  cam.position = Vec3f(100, 274, 280);
  cam.look_at = Vec3f(500, 274, 280);
  cam.vertical_fov_deg = 100;
  check_packets("cornell-caustics", &cam);
}

}  // namespace
}  // namespace caustica
