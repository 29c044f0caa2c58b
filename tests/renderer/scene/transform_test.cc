#include "renderer/scene/transform.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/renderer/scene/scene_test_util.h"

namespace caustica {
namespace {

using ::caustica::testing::triangle_cross;
using ::caustica::testing::Vec3Near;

TEST(Transform, RotationsAreRightHanded) {
  EXPECT_THAT(rotation_x_deg(90).apply_to_point({0, 1, 0}), Vec3Near(Vec3f(0, 0, 1), 1e-6f));
  EXPECT_THAT(rotation_y_deg(90).apply_to_point({0, 0, 1}), Vec3Near(Vec3f(1, 0, 0), 1e-6f));
  EXPECT_THAT(rotation_z_deg(90).apply_to_point({1, 0, 0}), Vec3Near(Vec3f(0, 1, 0), 1e-6f));
}

TEST(Transform, QuaternionMatchesAxisRotation) {
  const double s = std::sqrt(0.5);
  const Vec3f p{0.3f, -0.7f, 1.1f};
  EXPECT_THAT(rotation_quaternion(0, s, 0, s).apply_to_point(p),
              Vec3Near(rotation_y_deg(90).apply_to_point(p), 1e-6f));
  // Quaternions that are unit only roughly are normalised first.
  EXPECT_THAT(rotation_quaternion(0, 2 * s, 0, 2 * s).apply_to_point(p),
              Vec3Near(rotation_y_deg(90).apply_to_point(p), 1e-6f));
}

TEST(Transform, ComposesRightToLeftAndKeepsTranslation) {
  const Affine t = translation({1, 2, 3}) * scaling({2, 2, 2});
  EXPECT_THAT(t.apply_to_point({1, 1, 1}), Vec3Near(Vec3f(3, 4, 5), 0));
  EXPECT_THAT(t.apply_to_vector({1, 1, 1}), Vec3Near(Vec3f(2, 2, 2), 0));
  const std::array<double, 16> columns = {2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 1, 2, 3, 1};
  EXPECT_THAT(from_column_major(columns).apply_to_point({1, 1, 1}), Vec3Near(Vec3f(3, 4, 5), 0));
}

TEST(Transform, NormalsUseTheInverseTranspose) {
  // Squashing a 45-degree slope in y makes it flatter, so its normal tilts towards +y.
  const Affine squash = scaling({1, 0.5f, 1});
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 1, 0}, {0, 0, 1}};
  mesh.normals.assign(3, normalize(Vec3f(-1, 1, 0)));
  mesh.indices = {0, 2, 1};
  transform_mesh(squash, &mesh);
  EXPECT_THAT(mesh.normals[0], Vec3Near(normalize(Vec3f(-0.5f, 1, 0)), 1e-6f));
  EXPECT_THAT(normalize(triangle_cross(mesh, 0)), Vec3Near(mesh.normals[0], 1e-6f));
}

TEST(Transform, TangentsTurnAsDirectionsAndMirrorsFlipTheirSign) {
  // A slope in the xy plane with its tangent along the slope and the bitangent along +z; moved
  // by a mirror in x with a stretch in y and a turn about y.
  const Affine transform = rotation_y_deg(30) * scaling({-1, 2, 1});
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 1, 0}, {0, 0, 1}};
  const Vec3f normal = normalize(Vec3f(-1, 1, 0));
  const Vec3f tangent = normalize(Vec3f(1, 1, 0));
  mesh.normals.assign(3, normal);
  mesh.tangents.assign(3, Vec4f{tangent.x, tangent.y, tangent.z, -1});
  mesh.indices = {0, 2, 1};
  const Vec3f bitangent = -1.0f * cross(normal, tangent);  // w * cross(n, t)
  transform_mesh(transform, &mesh);
  const Vec4f& t = mesh.tangents[0];
  EXPECT_THAT(Vec3f(t.x, t.y, t.z), Vec3Near(normalize(transform.apply_to_vector(tangent)), 1e-6f));
  EXPECT_EQ(t.w, 1.0f);  // the mirror turned the frame's handedness
  // The frame the new sign rebuilds points its bitangent where the transform took the old one.
  const Vec3f rebuilt = t.w * cross(mesh.normals[0], Vec3f(t.x, t.y, t.z));
  EXPECT_THAT(normalize(rebuilt), Vec3Near(normalize(transform.apply_to_vector(bitangent)), 1e-5f));
}

TEST(Transform, LightsMoveAndTurn) {
  Light light;
  light.position = {1, 0, 0};
  light.direction = {0, 0, -1};
  transform_light(translation({0, 5, 0}) * rotation_y_deg(90) * scaling({3, 3, 3}), &light);
  EXPECT_THAT(light.position, Vec3Near(Vec3f(0, 5, -3), 1e-5f));
  EXPECT_THAT(light.direction, Vec3Near(Vec3f(-1, 0, 0), 1e-6f));
}

}  // namespace
}  // namespace caustica
