// Small analytic scenes shared by the C++ tests.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "moonbot/camera.h"
#include "moonbot/scene.h"

namespace fixtures {

/// A square in the z = 0 plane, half-size `half` metres, normal +z.
inline uint32_t add_plane_mesh(moonbot::Scene& scene, float half) {
    const std::vector<float> v = {-half, -half, 0, half, -half, 0, half, half, 0, -half, half, 0};
    const std::vector<uint32_t> t = {0, 1, 2, 0, 2, 3};
    return scene.add_mesh(v.data(), 4, t.data(), 2);
}

/// An axis-aligned box [-sx/2, sx/2]×[-sy/2, sy/2]×[0, sz] (sitting on z = 0), outward normals.
inline uint32_t add_box_mesh(moonbot::Scene& scene, float sx, float sy, float sz) {
    const float x = sx / 2, y = sy / 2;
    const std::vector<float> v = {-x, -y, 0, x, -y, 0, x, y, 0, -x, y, 0, -x, -y, sz, x, -y, sz, x, y, sz, -x, y, sz};
    const std::vector<uint32_t> t = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                     1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7};
    return scene.add_mesh(v.data(), 8, t.data(), 12);
}

/// A camera at `eye` looking at `target` with world +z up (OpenCV axes: y down in the image).
inline moonbot::Camera look_at(const glm::dvec3& eye, const glm::dvec3& target, int w, int h, double f) {
    const glm::dvec3 z = glm::normalize(target - eye);
    glm::dvec3 x = glm::cross(z, glm::dvec3(0, 0, 1));
    if (glm::length(x) < 1e-9) x = glm::dvec3(1, 0, 0);  // looking straight down
    x = glm::normalize(x);
    const glm::dvec3 y = glm::cross(z, x);
    // Rows of R are the camera axes in world coordinates; glm is column-major, so transpose.
    const glm::dmat3 R = glm::transpose(glm::dmat3(x, y, z));
    moonbot::Intrinsics k{f, f, w / 2.0, h / 2.0, w, h};
    return moonbot::Camera(k, R, -(R * eye));
}

}  // namespace fixtures
