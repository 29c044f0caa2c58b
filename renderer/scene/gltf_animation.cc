#include "renderer/scene/gltf_animation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <utility>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "renderer/scene/gltf_model.h"
#include "renderer/scene/scene_json.h"
#include "renderer/scene/status_util.h"

namespace caustica {

enum class Interpolation { kStep, kLinear, kCubicSpline };
enum class ChannelPath { kTranslation, kRotation, kScale, kWeights };

// One channel: the keys of one property of one node.
struct Channel {
  int node = 0;
  ChannelPath path = ChannelPath::kTranslation;
  Interpolation interpolation = Interpolation::kLinear;
  std::vector<double> times;
  // `width` numbers a key (three groups of them for CUBICSPLINE: in-tangent, value, out-tangent).
  std::vector<double> values;
  size_t width = 0;
};

// A node's translation, rotation (x, y, z, w) and scale, and its morph target weights.
struct NodePose {
  std::array<double, 3> t{0, 0, 0};
  std::array<double, 4> r{0, 0, 0, 1};
  std::array<double, 3> s{1, 1, 1};
  std::vector<double> weights;
};

struct Skin {
  std::vector<int> joints;
  std::vector<Affine> inverse_bind;
};

struct Influence {
  uint32_t joint = 0;
  double weight = 0;
};

// One mesh the loader made of a (node, primitive) pair, with what reshaping it needs.
struct AnimatedMesh {
  std::string name;
  int node = 0;
  int skin = -1;
  bool morphed = false;
  std::vector<Vec3f> positions, normals;  // the primitive's own, before any transform
  std::vector<std::vector<Vec3f>> target_positions, target_normals;
  size_t influences_per_vertex = 0;
  std::vector<Influence> influences;
};

struct GltfAnimation::Data {
  std::string name;
  double duration = 0;
  std::vector<int> parent;  // -1 for a root
  std::vector<int> order;   // the default scene's nodes, every parent before its children
  std::vector<NodePose> rest;
  std::vector<std::optional<Affine>> matrix;  // nodes placed by a matrix, which is not animated
  std::vector<Affine> rest_world;
  std::vector<Channel> channels;
  std::vector<Skin> skins;
  std::vector<AnimatedMesh> meshes;
};

namespace {

using Data = GltfAnimation::Data;

Affine trs(const NodePose& pose) {
  const auto& [x, y, z, w] = pose.r;
  const double n = std::sqrt(x * x + y * y + z * z + w * w);
  Affine a = n > 0 ? rotation_quaternion(x / n, y / n, z / n, w / n) : Affine();
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) a.m[row][col] *= pose.s[col];
    a.m[row][3] = pose.t[row];
  }
  return a;
}

// The world maps of every node in `data.order` for `poses`.
std::vector<Affine> world_maps(const Data& data, const std::vector<NodePose>& poses) {
  std::vector<Affine> world(poses.size());
  for (const int node : data.order) {
    const Affine local = data.matrix[node] ? *data.matrix[node] : trs(poses[node]);
    const int parent = data.parent[node];
    world[node] = parent >= 0 ? world[parent] * local : local;
  }
  return world;
}

// The channel's value at `seconds`, `width` numbers.
std::vector<double> sample(const Channel& c, double seconds) {
  const size_t keys = c.times.size(), w = c.width;
  const bool cubic = c.interpolation == Interpolation::kCubicSpline;
  // Key k's value (the middle of the three groups of a cubic spline key).
  const auto value = [&](size_t k, size_t j) { return c.values[(cubic ? 3 * k + 1 : k) * w + j]; };
  std::vector<double> out(w);
  const auto hold = [&](size_t k) {
    for (size_t j = 0; j < w; ++j) out[j] = value(k, j);
    return out;
  };
  if (keys == 1 || seconds <= c.times.front()) return hold(0);
  if (seconds >= c.times.back()) return hold(keys - 1);
  const size_t k =
      size_t(std::upper_bound(c.times.begin(), c.times.end(), seconds) - c.times.begin()) - 1;
  const double dt = c.times[k + 1] - c.times[k];
  const double s = dt > 0 ? (seconds - c.times[k]) / dt : 0;
  switch (c.interpolation) {
    case Interpolation::kStep:
      return hold(k);
    case Interpolation::kLinear:
      if (c.path == ChannelPath::kRotation) {
        // Spherical, along the shorter arc.
        std::array<double, 4> a, b;
        double dot = 0;
        for (size_t j = 0; j < 4; ++j) {
          a[j] = value(k, j);
          b[j] = value(k + 1, j);
          dot += a[j] * b[j];
        }
        if (dot < 0) {
          for (double& x : b) x = -x;
          dot = -dot;
        }
        double wa = 1 - s, wb = s;
        if (dot < 0.9995) {
          const double theta = std::acos(std::min(dot, 1.0));
          wa = std::sin((1 - s) * theta) / std::sin(theta);
          wb = std::sin(s * theta) / std::sin(theta);
        }
        for (size_t j = 0; j < 4; ++j) out[j] = wa * a[j] + wb * b[j];
        return out;
      }
      for (size_t j = 0; j < w; ++j) out[j] = (1 - s) * value(k, j) + s * value(k + 1, j);
      return out;
    case Interpolation::kCubicSpline: {
      // glTF 2.0, Appendix C: Hermite with the out-tangent of key k and the in-tangent of k + 1,
      // both scaled by the keys' distance in time.
      const double s2 = s * s, s3 = s2 * s;
      const double h00 = 2 * s3 - 3 * s2 + 1, h10 = s3 - 2 * s2 + s, h01 = -2 * s3 + 3 * s2,
                   h11 = s3 - s2;
      for (size_t j = 0; j < w; ++j) {
        const double out_tangent = c.values[(3 * k + 2) * w + j];
        const double in_tangent = c.values[(3 * (k + 1)) * w + j];
        out[j] = h00 * value(k, j) + h10 * dt * out_tangent + h01 * value(k + 1, j) +
                 h11 * dt * in_tangent;
      }
      return out;
    }
  }
  return out;
}

// Reads a glTF's animation into `data`; errors name the part of the file, not the file.
class AnimationReader {
 public:
  AnimationReader(const tinygltf::Model& model, std::string file_name)
      : model_(model), file_name_(std::move(file_name)) {}

  absl::Status read(const std::string& wanted, Data& data) {
    SCENE_ASSIGN_OR_RETURN(const size_t index, choose(wanted));
    const tinygltf::Animation& animation = model_.animations[index];
    data.name = animation.name.empty() ? absl::StrCat(index) : animation.name;
    SCENE_RETURN_IF_ERROR(read_nodes(data));
    const std::string where = absl::StrCat("animations[", index, "]");
    for (size_t c = 0; c < animation.channels.size(); ++c) {
      SCENE_RETURN_IF_ERROR(
          read_channel(animation, c, absl::StrCat(where, ".channels[", c, "]"), data));
    }
    SCENE_RETURN_IF_ERROR(read_meshes(data));
    return absl::OkStatus();
  }

 private:
  absl::StatusOr<size_t> choose(const std::string& wanted) const {
    const auto& animations = model_.animations;
    if (animations.empty()) return absl::InvalidArgumentError("the file has no animations");
    if (wanted.empty()) return 0;
    for (size_t i = 0; i < animations.size(); ++i) {
      if (animations[i].name == wanted) return i;
    }
    size_t number = 0;
    if (absl::SimpleAtoi(wanted, &number) && number < animations.size()) return number;
    std::vector<std::string> names;
    for (size_t i = 0; i < animations.size(); ++i) {
      names.push_back(animations[i].name.empty() ? absl::StrCat(i)
                                                 : absl::StrCat("'", animations[i].name, "'"));
    }
    return absl::NotFoundError(absl::StrCat("no animation named '", wanted, "' (the file has ",
                                            absl::StrJoin(names, ", "), ")"));
  }

  absl::Status read_nodes(Data& data) const {
    const size_t n = model_.nodes.size();
    data.parent.assign(n, -1);
    data.rest.resize(n);
    data.matrix.resize(n);
    for (size_t i = 0; i < n; ++i) {
      const tinygltf::Node& node = model_.nodes[i];
      for (const int child : node.children) {
        if (child < 0 || size_t(child) >= n || data.parent[child] >= 0) {
          return absl::InvalidArgumentError(absl::StrCat("nodes[", i, "].children: node ", child,
                                                         " does not exist or has two parents"));
        }
        data.parent[child] = int(i);
      }
      if (node.matrix.size() == 16) {
        data.matrix[i] = gltf_local_transform(node);
        continue;
      }
      NodePose& pose = data.rest[i];
      if (node.translation.size() == 3) std::copy_n(node.translation.begin(), 3, pose.t.begin());
      if (node.rotation.size() == 4) std::copy_n(node.rotation.begin(), 4, pose.r.begin());
      if (node.scale.size() == 3) std::copy_n(node.scale.begin(), 3, pose.s.begin());
      pose.weights = node.weights;
      if (pose.weights.empty() && node.mesh >= 0 && size_t(node.mesh) < model_.meshes.size()) {
        pose.weights = model_.meshes[node.mesh].weights;
      }
    }
    // The default scene's nodes, parents first, in the order the loader visits them.
    std::vector<int> pending;
    const std::vector<int> roots = gltf_root_nodes(model_);
    pending.assign(roots.rbegin(), roots.rend());
    std::vector<bool> seen(n, false);
    while (!pending.empty()) {
      const int node = pending.back();
      pending.pop_back();
      if (node < 0 || size_t(node) >= n || seen[node]) {
        return absl::InvalidArgumentError(
            absl::StrCat("node ", node, " does not exist or is reached twice"));
      }
      seen[node] = true;
      data.order.push_back(node);
      const std::vector<int>& children = model_.nodes[node].children;
      pending.insert(pending.end(), children.rbegin(), children.rend());
    }
    data.rest_world = world_maps(data, data.rest);
    return absl::OkStatus();
  }

  // Every number of accessor `index` of element type `type`, element by element; all finite.
  absl::StatusOr<std::vector<double>> numbers(int index, int type,
                                              std::initializer_list<int> component_types,
                                              const std::string& what) const {
    SCENE_ASSIGN_OR_RETURN(const AccessorView view,
                           AccessorView::open(model_, index, type, component_types, what));
    const int components = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(type));
    std::vector<double> out;
    out.reserve(view.count() * size_t(components));
    for (size_t i = 0; i < view.count(); ++i) {
      for (int c = 0; c < components; ++c) {
        const double x = view.get(i, c);
        if (!std::isfinite(x)) {
          return absl::InvalidArgumentError(
              absl::StrCat(what, " (accessor ", index, "): element ", i, " is not finite"));
        }
        out.push_back(x);
      }
    }
    return out;
  }

  absl::Status read_channel(const tinygltf::Animation& animation, size_t index,
                            const std::string& where, Data& data) const {
    const tinygltf::AnimationChannel& in = animation.channels[index];
    Channel channel;
    const int node = in.target_node;
    if (node < 0 || size_t(node) >= model_.nodes.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ".target.node: node ", node, " does not exist"));
    }
    channel.node = node;
    const std::string& path = in.target_path;
    size_t width = 3;
    int type = TINYGLTF_TYPE_VEC3;
    if (path == "translation") {
      channel.path = ChannelPath::kTranslation;
    } else if (path == "rotation") {
      channel.path = ChannelPath::kRotation;
      width = 4;
      type = TINYGLTF_TYPE_VEC4;
    } else if (path == "scale") {
      channel.path = ChannelPath::kScale;
    } else if (path == "weights") {
      channel.path = ChannelPath::kWeights;
      width = data.rest[node].weights.size();
      const tinygltf::Node& n = model_.nodes[node];
      if (n.mesh >= 0 && size_t(n.mesh) < model_.meshes.size() &&
          !model_.meshes[n.mesh].primitives.empty()) {
        width = model_.meshes[n.mesh].primitives[0].targets.size();
      }
      if (width == 0) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, ".target: animates the weights of node ", node,
                         ", whose mesh has no morph "
                         "targets"));
      }
      type = TINYGLTF_TYPE_SCALAR;
      data.rest[node].weights.resize(width, 0.0);
    } else {
      return absl::InvalidArgumentError(absl::StrCat(
          where, ".target.path: '", path, "' is not translation, rotation, scale or weights"));
    }
    if (channel.path != ChannelPath::kWeights && data.matrix[node]) {
      return absl::InvalidArgumentError(absl::StrCat(
          where, ": node ", node, " is placed by a matrix, which glTF does not animate"));
    }
    channel.width = width;
    if (in.sampler < 0 || size_t(in.sampler) >= animation.samplers.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ".sampler: sampler ", in.sampler, " does not exist"));
    }
    const tinygltf::AnimationSampler& sampler = animation.samplers[in.sampler];
    const std::string field = absl::StrCat(where, " (sampler ", in.sampler, ")");
    if (sampler.interpolation.empty() || sampler.interpolation == "LINEAR") {
      channel.interpolation = Interpolation::kLinear;
    } else if (sampler.interpolation == "STEP") {
      channel.interpolation = Interpolation::kStep;
    } else if (sampler.interpolation == "CUBICSPLINE") {
      channel.interpolation = Interpolation::kCubicSpline;
    } else {
      return absl::InvalidArgumentError(absl::StrCat(field, ".interpolation: '",
                                                     sampler.interpolation,
                                                     "' is not LINEAR, STEP or CUBICSPLINE"));
    }
    SCENE_ASSIGN_OR_RETURN(
        channel.times, numbers(sampler.input, TINYGLTF_TYPE_SCALAR, {TINYGLTF_COMPONENT_TYPE_FLOAT},
                               field + ".input"));
    if (channel.times.empty()) {
      return absl::InvalidArgumentError(absl::StrCat(field, ".input: has no keys"));
    }
    for (size_t k = 1; k < channel.times.size(); ++k) {
      if (channel.times[k] < channel.times[k - 1]) {
        return absl::InvalidArgumentError(absl::StrCat(field, ".input: key ", k, " at ",
                                                       channel.times[k], " s comes before key ",
                                                       k - 1, " at ", channel.times[k - 1], " s"));
      }
    }
    const bool normalized_allowed =
        channel.path == ChannelPath::kRotation || channel.path == ChannelPath::kWeights;
    std::initializer_list<int> components = {TINYGLTF_COMPONENT_TYPE_FLOAT};
    std::initializer_list<int> quantized = {
        TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE,
        TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_SHORT,
        TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT};
    SCENE_ASSIGN_OR_RETURN(
        channel.values, numbers(sampler.output, type, normalized_allowed ? quantized : components,
                                field + ".output"));
    const size_t groups = channel.interpolation == Interpolation::kCubicSpline ? 3 : 1;
    const size_t expected = channel.times.size() * groups * width;
    if (channel.values.size() != expected) {
      return absl::InvalidArgumentError(absl::StrCat(
          field, ".output: ", channel.values.size(), " numbers for ", channel.times.size(),
          " keys; ", path, " with ",
          sampler.interpolation.empty() ? "LINEAR" : sampler.interpolation, " takes ", expected));
    }
    data.duration = std::max(data.duration, channel.times.back());
    data.channels.push_back(std::move(channel));
    return absl::OkStatus();
  }

  absl::StatusOr<std::vector<Vec3f>> vec3s(int accessor, size_t count,
                                           const std::string& what) const {
    SCENE_ASSIGN_OR_RETURN(
        const std::vector<double> xs,
        numbers(accessor, TINYGLTF_TYPE_VEC3,
                {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE,
                 TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_SHORT,
                 TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
                what));
    if (xs.size() != 3 * count) {
      return absl::InvalidArgumentError(absl::StrCat(
          what, ": ", xs.size() / 3, " elements, but the primitive has ", count, " vertices"));
    }
    std::vector<Vec3f> out(count);
    for (size_t i = 0; i < count; ++i)
      out[i] = Vec3f(float(xs[3 * i]), float(xs[3 * i + 1]), float(xs[3 * i + 2]));
    return out;
  }

  absl::Status read_skin(int index, Data& data) {
    if (size_t(index) < data.skins.size() && !data.skins[index].joints.empty()) {
      return absl::OkStatus();
    }
    if (index < 0 || size_t(index) >= model_.skins.size()) {
      return absl::InvalidArgumentError(absl::StrCat("skin ", index, " does not exist"));
    }
    data.skins.resize(std::max(data.skins.size(), size_t(index) + 1));
    const tinygltf::Skin& in = model_.skins[index];
    Skin& skin = data.skins[index];
    const std::string where = absl::StrCat("skins[", index, "]");
    for (const int joint : in.joints) {
      if (joint < 0 || size_t(joint) >= model_.nodes.size()) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, ".joints: node ", joint, " does not exist"));
      }
    }
    if (in.joints.empty()) return absl::InvalidArgumentError(where + ".joints: is empty");
    skin.joints = in.joints;
    skin.inverse_bind.assign(in.joints.size(), Affine());
    if (in.inverseBindMatrices >= 0) {
      SCENE_ASSIGN_OR_RETURN(
          const std::vector<double> m,
          numbers(in.inverseBindMatrices, TINYGLTF_TYPE_MAT4, {TINYGLTF_COMPONENT_TYPE_FLOAT},
                  where + ".inverseBindMatrices"));
      if (m.size() != 16 * in.joints.size()) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, ".inverseBindMatrices: ", m.size() / 16, " matrices for ",
                         in.joints.size(), " joints"));
      }
      for (size_t j = 0; j < in.joints.size(); ++j) {
        std::array<double, 16> columns;
        std::copy_n(m.begin() + std::ptrdiff_t(16 * j), 16, columns.begin());
        skin.inverse_bind[j] = from_column_major(columns);
      }
    }
    return absl::OkStatus();
  }

  absl::Status read_influences(const tinygltf::Primitive& primitive, size_t joints,
                               const std::string& name, AnimatedMesh& mesh) const {
    const size_t count = mesh.positions.size();
    for (int set = 0;; ++set) {
      const auto joint = primitive.attributes.find(absl::StrCat("JOINTS_", set));
      const auto weight = primitive.attributes.find(absl::StrCat("WEIGHTS_", set));
      if (joint == primitive.attributes.end() || weight == primitive.attributes.end()) break;
      SCENE_ASSIGN_OR_RETURN(
          const std::vector<double> js,
          numbers(joint->second, TINYGLTF_TYPE_VEC4,
                  {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
                  absl::StrCat(name, ": JOINTS_", set)));
      SCENE_ASSIGN_OR_RETURN(
          const std::vector<double> ws,
          numbers(weight->second, TINYGLTF_TYPE_VEC4,
                  {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                   TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
                  absl::StrCat(name, ": WEIGHTS_", set)));
      if (js.size() != 4 * count || ws.size() != 4 * count) {
        return absl::InvalidArgumentError(absl::StrCat(name, ": JOINTS_", set, " and WEIGHTS_", set,
                                                       " must have one element a vertex"));
      }
      std::vector<Influence> merged;
      merged.reserve((mesh.influences_per_vertex + 4) * count);
      for (size_t v = 0; v < count; ++v) {
        for (size_t k = 0; k < mesh.influences_per_vertex; ++k) {
          merged.push_back(mesh.influences[v * mesh.influences_per_vertex + k]);
        }
        for (size_t k = 0; k < 4; ++k) {
          const double j = js[4 * v + k];
          if (ws[4 * v + k] != 0 && j >= double(joints)) {
            return absl::InvalidArgumentError(absl::StrCat(name, ": JOINTS_", set, " of vertex ", v,
                                                           " names joint ", j, " of ", joints));
          }
          merged.push_back({uint32_t(ws[4 * v + k] != 0 ? j : 0), ws[4 * v + k]});
        }
      }
      mesh.influences = std::move(merged);
      mesh.influences_per_vertex += 4;
    }
    if (mesh.influences_per_vertex == 0) {
      return absl::InvalidArgumentError(
          absl::StrCat(name, ": its node has a skin, but it has no JOINTS_0 and WEIGHTS_0"));
    }
    return absl::OkStatus();
  }

  // The meshes the loader makes, in its order, keeping those the animation moves or reshapes.
  absl::Status read_meshes(Data& data) {
    std::vector<bool> moves(model_.nodes.size(), false), morphs(model_.nodes.size(), false);
    for (const Channel& c : data.channels) {
      (c.path == ChannelPath::kWeights ? morphs : moves)[c.node] = true;
    }
    for (const int node : data.order) {
      if (data.parent[node] >= 0 && moves[data.parent[node]]) moves[node] = true;
    }
    for (const int node_index : data.order) {
      const tinygltf::Node& node = model_.nodes[node_index];
      if (node.mesh < 0) continue;
      if (size_t(node.mesh) >= model_.meshes.size()) {
        return absl::InvalidArgumentError(
            absl::StrCat("node ", node_index, " refers to missing mesh ", node.mesh));
      }
      bool skin_moves = false;
      if (node.skin >= 0) {
        SCENE_RETURN_IF_ERROR(read_skin(node.skin, data));
        for (const int joint : data.skins[node.skin].joints) skin_moves |= moves[joint];
      }
      const bool reshaped = morphs[node_index] || (node.skin >= 0 && skin_moves);
      if (!reshaped && !moves[node_index]) continue;
      const tinygltf::Mesh& gltf_mesh = model_.meshes[node.mesh];
      for (size_t p = 0; p < gltf_mesh.primitives.size(); ++p) {
        const tinygltf::Primitive& primitive = gltf_mesh.primitives[p];
        if (!gltf_draws_triangles(primitive)) continue;
        AnimatedMesh mesh;
        mesh.name = absl::StrCat(file_name_, ": ", gltf_primitive_name(model_, node_index, p));
        mesh.node = node_index;
        if (reshaped) SCENE_RETURN_IF_ERROR(read_shape(primitive, node, data, mesh));
        data.meshes.push_back(std::move(mesh));
      }
    }
    return absl::OkStatus();
  }

  absl::Status read_shape(const tinygltf::Primitive& primitive, const tinygltf::Node& node,
                          Data& data, AnimatedMesh& mesh) {
    const auto position = primitive.attributes.find("POSITION");
    if (position == primitive.attributes.end()) {
      return absl::InvalidArgumentError(absl::StrCat(mesh.name, ": no POSITION attribute"));
    }
    SCENE_ASSIGN_OR_RETURN(
        const AccessorView view,
        AccessorView::open(model_, position->second, TINYGLTF_TYPE_VEC3,
                           {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE,
                            TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_SHORT,
                            TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
                           mesh.name + ": POSITION"));
    const size_t count = view.count();
    SCENE_ASSIGN_OR_RETURN(mesh.positions,
                           vec3s(position->second, count, mesh.name + ": POSITION"));
    if (const auto normal = primitive.attributes.find("NORMAL");
        normal != primitive.attributes.end()) {
      SCENE_ASSIGN_OR_RETURN(mesh.normals, vec3s(normal->second, count, mesh.name + ": NORMAL"));
    }
    for (size_t t = 0; t < primitive.targets.size(); ++t) {
      const auto& target = primitive.targets[t];
      const std::string what = absl::StrCat(mesh.name, ": targets[", t, "]");
      std::vector<Vec3f> positions(count, Vec3f(0.0f)), normals;
      if (const auto p = target.find("POSITION"); p != target.end()) {
        SCENE_ASSIGN_OR_RETURN(positions, vec3s(p->second, count, what + ".POSITION"));
      }
      if (const auto n = target.find("NORMAL"); n != target.end() && !mesh.normals.empty()) {
        SCENE_ASSIGN_OR_RETURN(normals, vec3s(n->second, count, what + ".NORMAL"));
      }
      mesh.target_positions.push_back(std::move(positions));
      mesh.target_normals.push_back(std::move(normals));
    }
    mesh.morphed = !mesh.target_positions.empty();
    if (node.skin >= 0) {
      mesh.skin = node.skin;
      SCENE_RETURN_IF_ERROR(
          read_influences(primitive, data.skins[node.skin].joints.size(), mesh.name, mesh));
    }
    return absl::OkStatus();
  }

  const tinygltf::Model& model_;
  std::string file_name_;
};

Vec3f normalized(Vec3f v) {
  const float n = length(v);
  return n > 0 ? v / n : v;
}

}  // namespace

absl::StatusOr<GltfAnimation> GltfAnimation::load(const std::filesystem::path& path,
                                                  const std::string& animation) {
  absl::StatusOr<tinygltf::Model> model = load_gltf_model(path, nullptr);
  if (!model.ok()) return model.status();
  auto data = std::make_shared<Data>();
  if (absl::Status s = AnimationReader(*model, path.filename().string()).read(animation, *data);
      !s.ok()) {
    return annotate(s, path.string());
  }
  return GltfAnimation(std::move(data));
}

const std::string& GltfAnimation::name() const { return data_->name; }
double GltfAnimation::duration_s() const { return data_->duration; }
size_t GltfAnimation::meshes() const { return data_->meshes.size(); }

std::vector<MeshChange> GltfAnimation::at(double seconds) const {
  const Data& d = *data_;
  std::vector<NodePose> poses = d.rest;
  for (const Channel& c : d.channels) {
    const std::vector<double> v = sample(c, seconds);
    NodePose& pose = poses[c.node];
    switch (c.path) {
      case ChannelPath::kTranslation:
        std::copy_n(v.begin(), 3, pose.t.begin());
        break;
      case ChannelPath::kRotation:
        std::copy_n(v.begin(), 4, pose.r.begin());
        break;
      case ChannelPath::kScale:
        std::copy_n(v.begin(), 3, pose.s.begin());
        break;
      case ChannelPath::kWeights:
        pose.weights = v;
        break;
    }
  }
  const std::vector<Affine> world = world_maps(d, poses);
  std::vector<MeshChange> changes;
  changes.reserve(d.meshes.size());
  for (const AnimatedMesh& mesh : d.meshes) {
    MeshChange& change = changes.emplace_back();
    change.mesh = mesh.name;
    if (mesh.positions.empty()) {
      change.transform = world[mesh.node] * d.rest_world[mesh.node].inverse();
      continue;
    }
    // Morph targets first, in the primitive's own space.
    std::vector<Vec3f> positions = mesh.positions, normals = mesh.normals;
    const std::vector<double>& weights = poses[mesh.node].weights;
    for (size_t t = 0; t < mesh.target_positions.size() && t < weights.size(); ++t) {
      const float w = float(weights[t]);
      if (w == 0) continue;
      for (size_t i = 0; i < positions.size(); ++i) positions[i] += w * mesh.target_positions[t][i];
      if (!mesh.target_normals[t].empty()) {
        for (size_t i = 0; i < normals.size(); ++i) normals[i] += w * mesh.target_normals[t][i];
      }
    }
    if (mesh.skin >= 0) {
      // Linear blend skinning: each vertex by its joints' maps, blended by its weights; the
      // skinned mesh's own node does not place it (glTF 2.0, 3.7.3).
      const Skin& skin = d.skins[mesh.skin];
      std::vector<Affine> joints(skin.joints.size());
      for (size_t j = 0; j < joints.size(); ++j) {
        joints[j] = world[skin.joints[j]] * skin.inverse_bind[j];
      }
      const size_t per = mesh.influences_per_vertex;
      for (size_t i = 0; i < positions.size(); ++i) {
        Affine blend;
        for (auto& row : blend.m) row.fill(0);
        double total = 0;
        for (size_t k = 0; k < per; ++k) {
          const Influence& influence = mesh.influences[i * per + k];
          if (influence.weight == 0) continue;
          total += influence.weight;
          const Affine& joint = joints[influence.joint];
          for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c) blend.m[r][c] += influence.weight * joint.m[r][c];
        }
        if (total <= 0) {
          blend = Affine();
        } else if (total != 1) {
          for (auto& row : blend.m)
            for (double& x : row) x /= total;
        }
        positions[i] = blend.apply_to_point(positions[i]);
        if (!normals.empty()) {
          normals[i] = normalized(blend.normal_transform().apply_to_vector(normals[i]));
        }
      }
    } else {
      const Affine& placed = world[mesh.node];
      const Affine normal_map = placed.normal_transform();
      for (Vec3f& p : positions) p = placed.apply_to_point(p);
      for (Vec3f& n : normals) n = normalized(normal_map.apply_to_vector(n));
    }
    change.transform = Affine();
    change.positions = std::move(positions);
    if (!normals.empty()) change.normals = std::move(normals);
  }
  return changes;
}

void place_in_shape(const std::string& shape_path, const std::string& shape_name,
                    const Affine& shape_transform, std::vector<MeshChange>& changes) {
  const Affine& t = shape_transform;
  const Affine back = t.inverse(), normal_map = t.normal_transform();
  for (MeshChange& change : changes) {
    change.mesh = shape_label(shape_path, shape_name, change.mesh);
    if (change.transform) change.transform = t * *change.transform * back;
    if (change.positions) {
      for (Vec3f& p : *change.positions) p = t.apply_to_point(p);
    }
    if (change.normals) {
      for (Vec3f& n : *change.normals) n = normalized(normal_map.apply_to_vector(n));
    }
  }
}

}  // namespace caustica
