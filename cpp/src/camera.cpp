#include "moonbot/camera.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace moonbot {

namespace {

// Largest accepted image side: far above any sensor, and keeps W·H·3 floats well inside size_t.
constexpr int kMaxSide = 32768;

void require(bool ok, const std::string& message) {
    if (!ok) throw std::invalid_argument(message);
}

}  // namespace

Camera::Camera(const Intrinsics& k, const glm::dmat3& R, const glm::dvec3& t) : m_k(k) {
    require(std::isfinite(k.fx) && k.fx > 0, "fx: focal length must be positive and finite");
    require(std::isfinite(k.fy) && k.fy > 0, "fy: focal length must be positive and finite");
    require(std::isfinite(k.cx), "cx: principal point must be finite");
    require(std::isfinite(k.cy), "cy: principal point must be finite");
    require(k.width >= 1 && k.width <= kMaxSide,
            "width: must be in 1.." + std::to_string(kMaxSide) + ", got " + std::to_string(k.width));
    require(k.height >= 1 && k.height <= kMaxSide,
            "height: must be in 1.." + std::to_string(kMaxSide) + ", got " + std::to_string(k.height));
    for (int c = 0; c < 3; ++c) {
        for (int r = 0; r < 3; ++r) require(std::isfinite(R[c][r]), "R: must be finite");
        require(std::isfinite(t[c]), "t: must be finite");
    }
    const glm::dmat3 should_be_identity = glm::transpose(R) * R;
    double worst = 0.0;
    for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) worst = std::max(worst, std::abs(should_be_identity[c][r] - (c == r ? 1.0 : 0.0)));
    require(worst < 1e-6, "R: must be orthonormal (|RᵀR − I| = " + std::to_string(worst) + ")");
    require(glm::determinant(R) > 0, "R: must be a rotation (det +1), not a reflection");
    m_cam_from_world = R;
    m_t = t;
    m_world_from_cam = glm::transpose(R);
    m_center = -(m_world_from_cam * t);
}

glm::dvec3 Camera::project(const glm::dvec3& world) const {
    const glm::dvec3 p = m_cam_from_world * world + m_t;
    return {m_k.fx * p.x / p.z + m_k.cx, m_k.fy * p.y / p.z + m_k.cy, p.z};
}

}  // namespace moonbot
