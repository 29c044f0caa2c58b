// Closest hits for every pixel of an image whose rays share one origin: the launch both the
// renderer's primary stage and the benchmark use. On the CPU, square packets (packet_traversal.h)
// share each node test across 16 rays; on a GPU the warp already is the packet.
#pragma once

#include <type_traits>

#include "renderer/accel/packet_traversal.h"
#include "renderer/accel/ray_queries.h"
#include "renderer/accel/traversal.h"
#include "renderer/base/pixel_blocks.h"
#include "renderer/parallel/buffer.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {

// The CPU's way for the 4-wide BVH: square packets of kPacketRays rays share each node test.
template <typename Direction>
void trace_camera_packets(Backend& backend, const TriangleBvhView& bvh, Vec3f origin, int width,
                          int height, Direction direction, Hit* hits) {
  const int tiles_x = (width + kPacketTile - 1) / kPacketTile;
  const int tiles_y = (height + kPacketTile - 1) / kPacketTile;
  parallel_for(backend, "camera_packets", size_t(tiles_x) * tiles_y, [=] CAUSTICA_HD(size_t tile) {
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

// The way for a view that answers batches only (BatchStructureView): every pixel's ray in one
// queue, traced by one trace_closest.
template <typename Structure, typename Direction>
void trace_camera_batch(Backend& backend, const Structure& structure, Vec3f origin, int width,
                        int height, Direction direction, Hit* hits) {
  const size_t pixels = size_t(width) * height;
  Buffer<Ray> rays(backend, pixels);
  Ray* ray = rays.data();
  parallel_for(backend, "camera_ray_queue", pixels,
               [=] CAUSTICA_HD(size_t pixel) { ray[pixel] = Ray{origin, direction(pixel)}; });
  trace_closest(backend, structure, rays.data(), pixels, hits);
}

// The per-ray views' way (trace_camera_tiles).
template <typename Structure, typename Direction>
void trace_camera_per_ray(Backend& backend, const Structure& structure, Vec3f origin, int width,
                          int height, Direction direction, Hit* hits) {
  if constexpr (std::is_same_v<Structure, TriangleBvhView>) {
    if (backend.kind() != DeviceKind::kCuda) {
      trace_camera_packets(backend, structure, origin, width, height, direction, hits);
      return;
    }
  }
  const PixelBlocks blocks(width, height);
  parallel_for(backend, "camera_rays", blocks.thread_count(), [=] CAUSTICA_HD(size_t thread) {
    size_t pixel;
    if (!blocks.pixel_of(thread, pixel)) return;
    hits[pixel] = closest_hit(structure, Ray{origin, direction(pixel)});
  });
}

// `direction(pixel)` (a CAUSTICA_HD functor, pixel = y * width + x) gives each ray's direction
// from `origin`; hits[pixel] receives its closest hit in `structure` (any BatchStructureView,
// ray_queries.h). On the CPU the 4-wide BVH traces packets; other per-ray views one ray per
// thread, each GPU warp covering an 8x4 block of pixels so that its rays stay coherent (a
// thread-private packet of 16 rays would only cost registers there); batch-only views one queue.
template <typename Structure, typename Direction>
void trace_camera_tiles(Backend& backend, const Structure& structure, Vec3f origin, int width,
                        int height, Direction direction, Hit* hits) {
  if constexpr (!StructureView<Structure>) {
    trace_camera_batch(backend, structure, origin, width, height, direction, hits);
  } else {
    trace_camera_per_ray(backend, structure, origin, width, height, direction, hits);
  }
}

}  // namespace caustica
