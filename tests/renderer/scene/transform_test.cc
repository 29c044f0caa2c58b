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
