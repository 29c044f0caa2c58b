#include "renderer/accel/sibling_pair.h"

#include <stdexcept>
#include <string>

#include "renderer/base/atomic.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {

Buffer<SiblingPairNode> encode_sibling_pairs(Backend& backend, const Bvh& tree, Aabb& root_box) {
  if (tree.leaf_count > kMaxSiblingReferences)
    throw std::invalid_argument("sibling-pair nodes address at most " +
                                std::to_string(kMaxSiblingReferences) + " leaves, not " +
                                std::to_string(tree.leaf_count));
  root_box = tree.bounds;
  const size_t n = tree.nodes.size();
  Buffer<SiblingPairNode> out(backend, n);
  if (n == 0) return out;
  Buffer<uint32_t> failures(backend, 1);
  backend.fill_bytes(failures.data(), 0, sizeof(uint32_t));
  const BvhNode* in = tree.nodes.data();
  SiblingPairNode* pairs = out.data();
  uint32_t* failed = failures.data();
  parallel_for(backend, "sibling_pair_encode", n, [=] CAUSTICA_HD(size_t k) {
    const BvhNode node = in[k];
    if (!encode_sibling_pair(node.child[0].bounds(), node.child[0].index, node.child[1].bounds(),
                             node.child[1].index, pairs[k]))
      atomic_fetch_add(failed, 1u);
  });
  uint32_t failed_nodes = 0;
  backend.copy_to_host(&failed_nodes, failed, sizeof(uint32_t));
  if (failed_nodes != 0)
    throw std::invalid_argument("encode_sibling_pairs: a node's box is not its children's union");
  BvhNode root;
  backend.copy_to_host(&root, in + tree.root, sizeof(BvhNode));
  root_box = sibling_pair_box(root.child[0].bounds(), root.child[1].bounds());
  return out;
}

}  // namespace caustica
