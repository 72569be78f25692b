/// @file solid_tree.cpp
/// @brief An SdfSolid from a tree of SDF nodes (core/sdf/sdf.h): its distance, the safe step of
///        a displaced tree and its support box.
#include <memory>

#include "core/sdf/sdf.h"
#include "core/sdf/solid.h"

namespace nimbus {

SdfSolid solidFromTree(const SdfNodeDesc& root, const SolidShading& shading) {
    const auto tree = std::make_shared<const SdfTree>(flattenSdf(root));
    SdfSolid s;
    s.distance = [tree](vec3 p) { return tree->distance(p); };
    // a displaced tree's distance is no bound: the undisplaced bound minus the amplitude is
    if (tree->displacementBound > 0.0f)
        s.skip = [tree](vec3 p) { return tree->skipDistance(p, 0.0f); };
    s.box = tree->supportBox(0.0f);
    s.shading = shading;
    return s;
}

} // namespace nimbus
