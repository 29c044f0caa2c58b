// Closest hits for every pixel of an image whose rays share one origin, traced as square packets
// (packet_traversal.h): the launch both the renderer's primary stage and the benchmark use.
#pragma once

#include "renderer/accel/packet_traversal.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {

// `direction(pixel)` (a CAUSTICA_HD functor, pixel = y * width + x) gives each ray's direction
// from `origin`; hits[pixel] receives its closest hit.
template <typename Direction>
void trace_camera_tiles(Backend& backend, const TriangleBvhView& bvh, Vec3f origin, int width,
                        int height, Direction direction, Hit* hits) {
  const int tiles_x = (width + kPacketTile - 1) / kPacketTile;
  const int tiles_y = (height + kPacketTile - 1) / kPacketTile;
  parallel_for(backend, size_t(tiles_x) * tiles_y, [=] CAUSTICA_HD(size_t tile) {
    const int tx = int(tile % tiles_x) * kPacketTile, ty = int(tile / tiles_x) * kPacketTile;
    RayPacket packet;
    packet.origin = origin;
    size_t pixels[kPacketRays];
    for (int y = ty; y < ty + kPacketTile && y < height; ++y) {
      for (int x = tx; x < tx + kPacketTile && x < width; ++x) {
        const size_t pixel = size_t(y) * width + x;
        pixels[packet.count] = pixel;
        packet.direction[packet.count++] = direction(pixel);
      }
    }
    Hit packet_hits[kPacketRays];
    closest_hit_packet(bvh, packet, packet_hits);
    for (int i = 0; i < packet.count; ++i) hits[pixels[i]] = packet_hits[i];
  });
}

}  // namespace caustica
