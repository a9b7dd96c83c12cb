#include "hr/element_rho.h"

#include "scene/texture.h"

namespace hrad::hr {

ElementRho::ElementRho(const scene::Scene& scene) : scene_(&scene) {
    textured_.assign(scene.patches.size(), 0);
    if (scene.textures.empty()) return;
    for (size_t i = 0; i < scene.patches.size(); ++i)
        if (scene::patchTexture(scene, scene.patches[i])) {
            textured_[i] = 1;
            any_ = true;
        }
}

void ElementRho::addChildren(uint32_t firstChild, const scene::Patch& p,
                             const scene::Domain& parent) {
    const auto [it, fresh] = block_.emplace(firstChild, uint32_t(rho_.size() / 4));
    if (!fresh) return;
    for (int c = 0; c < 4; ++c)
        rho_.push_back(scene::elementRho(*scene_, p, scene::childDomain(p.kind, parent, c)));
}

uint64_t ElementRho::bytes() const {
    // An unordered_map node holds the pair and a next pointer; one bucket
    // pointer per bucket.
    return textured_.capacity() + rho_.capacity() * sizeof(RGB) +
           block_.size() * (sizeof(std::pair<const uint32_t, uint32_t>) + sizeof(void*)) +
           block_.bucket_count() * sizeof(void*);
}

}  // namespace hrad::hr
