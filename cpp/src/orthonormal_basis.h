// Internal to the core: the orthonormal basis that completes a unit vector, shared by the ray
// builders (rays.h), the medium's phase-function frame and the Embree wrapper's tilted rays. In a
// header of its own because the Embree wrapper is below rays.h, which includes it.
#pragma once

#include <cmath>

#include <glm/glm.hpp>

namespace moonbot::detail {

/// An orthonormal basis (a, b) completing unit w (Duff et al. 2017, "Building an Orthonormal
/// Basis, Revisited", JCGT 6(1)): branchless and continuous except at w.z = −0.
inline void orthonormal_basis(const glm::dvec3& w, glm::dvec3& a, glm::dvec3& b) {
    const double sign = std::copysign(1.0, w.z);
    const double k = -1.0 / (sign + w.z);
    const double xy = w.x * w.y * k;
    a = {1.0 + sign * w.x * w.x * k, sign * xy, -sign * w.x};
    b = {xy, sign + w.y * w.y * k, -w.y};
}

}  // namespace moonbot::detail
