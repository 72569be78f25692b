#include "core/fields/sdf_cloud.h"

#include <cmath>
#include <stdexcept>

#include "core/kernels/kernels.h"

namespace nimbus {

float SdfCloudField::density(vec3 p) const {
    return scale * kern::sdfDensityFromDistance(tree->distance(p), falloff);
}

float SdfCloudField::majorantBall(float u, float r) const {
    return scale * kern::sdfDensityFromDistance(u - r - tree->displacementBound - margin, falloff);
}

float SdfCloudField::majorant(const Box& b) const {
    const vec3 c = 0.5f * (b.lo + b.hi);
    return majorantBall(tree->bound(c), 0.5f * glm::length(b.hi - b.lo));
}

float SdfCloudField::skip(vec3 p, float& u) const {
    u = tree->bound(p);
    return kern::sdfSkipDistance(u, tree->displacementBound, 0.0f) - margin;
}

SdfCloudField makeSdfCloudField(const SdfFieldDesc& desc, Box& bounds) {
    SdfCloudField f;
    auto tree = std::make_shared<SdfTree>(flattenSdf(desc.root));
    bounds = tree->supportBox(0.0f);
    if (!sdfBoxBounded(bounds))
        throw std::invalid_argument("the SDF cloud is unbounded (a plane not intersected with a "
                                    "bounded node)");
    f.tree = std::move(tree);
    f.scale = desc.density;
    f.falloff = desc.falloff;
    // the values are float sums of order |p| + the tree's sizes: a few ulp of the box's size
    const float size = maxComponent(glm::max(glm::abs(bounds.lo), glm::abs(bounds.hi)));
    f.margin = 1e-5f * std::max(size, 1.0f);
    // grow the box by the margin too, so the Field's clip never cuts density
    bounds.lo -= vec3(f.margin);
    bounds.hi += vec3(f.margin);
    return f;
}

Box sdfCloudBounds(const SdfFieldDesc& desc) {
    try {
        Box b;
        makeSdfCloudField(desc, b);
        return b;
    } catch (const std::invalid_argument&) {
        return Box{};
    }
}

} // namespace nimbus
