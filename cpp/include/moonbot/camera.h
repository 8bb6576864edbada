// Pinhole camera in the OpenCV convention: x right, y down, z forward; pixel (u, v) covers
// [u, u+1) × [v, v+1), so its centre is (u + 0.5, v + 0.5), as the BOP toolkit assumes.
#pragma once

#include <glm/glm.hpp>

namespace moonbot {

/// Pinhole intrinsics: focal lengths and principal point in pixels, image size in pixels.
struct Intrinsics {
    double fx = 0, fy = 0, cx = 0, cy = 0;
    int width = 0, height = 0;
};

class Camera {
public:
    /// `cam_from_world`: x_cam = R · x_world + t (R orthonormal, det +1; t in metres).
    /// Throws std::invalid_argument naming the field on a bad value.
    Camera(const Intrinsics& k, const glm::dmat3& R, const glm::dvec3& t);

    const Intrinsics& intrinsics() const { return m_k; }
    int width() const { return m_k.width; }
    int height() const { return m_k.height; }
    /// Camera centre in the world frame (metres).
    const glm::dvec3& center() const { return m_center; }
    /// Optical axis (+z of the camera) in the world frame, unit length.
    glm::dvec3 forward() const { return m_world_from_cam[2]; }

    /// World-frame direction of the ray through continuous pixel position (x, y), scaled so its
    /// component along the optical axis is exactly 1: a hit at parameter t has z-depth t.
    glm::dvec3 direction(double x, double y) const {
        return m_world_from_cam * glm::dvec3((x - m_k.cx) / m_k.fx, (y - m_k.cy) / m_k.fy, 1.0);
    }

    /// direction() split into a part that depends on x only and one that depends on y only, so
    /// a renderer computes them once per column and row of a tile instead of once per pixel:
    /// direction(x, y) == (x_part(x) + y_part(y)) + forward(), bit for bit (glm sums the matrix's
    /// columns in this order, and forward() times the unit z component is exact).
    glm::dvec3 x_part(double x) const { return m_world_from_cam[0] * ((x - m_k.cx) / m_k.fx); }
    glm::dvec3 y_part(double y) const { return m_world_from_cam[1] * ((y - m_k.cy) / m_k.fy); }

    /// Continuous pixel position of a world point (pixel centres at +0.5) and its z-depth.
    glm::dvec3 project(const glm::dvec3& world) const;

private:
    Intrinsics m_k;
    glm::dmat3 m_cam_from_world;
    glm::dvec3 m_t;
    glm::dmat3 m_world_from_cam;
    glm::dvec3 m_center;
};

}  // namespace moonbot
