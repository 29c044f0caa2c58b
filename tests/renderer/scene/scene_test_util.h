// Helpers shared by the scene module's tests.
#pragma once

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "absl/status/status.h"
#include "renderer/base/vec.h"
#include "renderer/scene/scene.h"

namespace caustica::testing {

inline std::filesystem::path scene_data(const std::string& relative) {
  return std::filesystem::path(CAUSTICA_TEST_DATA) / "scene" / relative;
}

// absl::string_view is not std::string_view in Debian's abseil, so matchers get a std::string.
inline std::string message_of(const absl::Status& status) { return std::string(status.message()); }

// (v1 - v0) x (v2 - v0) of triangle t: its geometric normal, scaled by twice its area.
inline Vec3f triangle_cross(const Mesh& mesh, size_t t) {
  const Vec3f a = mesh.positions[mesh.indices[3 * t]];
  const Vec3f b = mesh.positions[mesh.indices[3 * t + 1]];
  const Vec3f c = mesh.positions[mesh.indices[3 * t + 2]];
  return cross(b - a, c - a);
}

MATCHER_P2(Vec3Near, expected, tolerance, "") {
  const Vec3f d = arg - expected;
  *result_listener << "(" << arg.x << ", " << arg.y << ", " << arg.z << ")";
  return std::fabs(d.x) <= tolerance && std::fabs(d.y) <= tolerance && std::fabs(d.z) <= tolerance;
}

// The same vertices, normals, texture coordinates, triangles and materials, exactly.
inline void expect_same_mesh(const Mesh& a, const Mesh& b) {
  ASSERT_EQ(a.positions.size(), b.positions.size());
  for (size_t i = 0; i < a.positions.size(); ++i) {
    EXPECT_EQ(a.positions[i], b.positions[i]) << "vertex " << i;
  }
  ASSERT_EQ(a.normals.size(), b.normals.size());
  for (size_t i = 0; i < a.normals.size(); ++i) EXPECT_EQ(a.normals[i], b.normals[i]);
  ASSERT_EQ(a.uvs.size(), b.uvs.size());
  for (size_t i = 0; i < a.uvs.size(); ++i) {
    EXPECT_EQ(a.uvs[i].x, b.uvs[i].x);
    EXPECT_EQ(a.uvs[i].y, b.uvs[i].y);
  }
  EXPECT_EQ(a.indices, b.indices);
  EXPECT_EQ(a.material_ids, b.material_ids);
}

inline const Mesh* find_mesh(const Scene& scene, const std::string& name_part) {
  for (const Mesh& mesh : scene.meshes) {
    if (mesh.name.find(name_part) != std::string::npos) return &mesh;
  }
  return nullptr;
}

inline const Material* find_material(const Scene& scene, const std::string& name) {
  for (const Material& material : scene.materials) {
    if (material.name == name) return &material;
  }
  return nullptr;
}

}  // namespace caustica::testing
