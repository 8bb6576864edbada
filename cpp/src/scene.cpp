#include "moonbot/scene.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace moonbot {

namespace {

void check_material(const Material& m) {
    for (int c = 0; c < 3; ++c)
        if (!(m.albedo[c] >= 0.0f && m.albedo[c] <= 1.0f))
            throw std::invalid_argument("albedo: each channel must be in [0, 1], got " + std::to_string(m.albedo[c]));
    m.photometry.validate();
    if (m.woven) m.woven->validate();
}

}  // namespace

void WovenSurface::validate() const {
    fabric.validate();
    stain.validate();
    soiling.validate();
    if (!(std::isfinite(metres_per_uv) && metres_per_uv > 0))
        throw std::invalid_argument("metres_per_uv: must be positive and finite");
    for (int c = 0; c < 3; ++c)
        if (!(dirt_colour[c] >= 0.0 && dirt_colour[c] <= 1.0))
            throw std::invalid_argument("dirt_colour: each channel must be in [0, 1]");
}

namespace {

// Transforms go to Embree in float32; a finite double beyond float32's range would become
// infinite there (and the narrowing is undefined behaviour). 1e9 m is far beyond any scene.
constexpr double kMaxTransformEntry = 1e9;

void check_transform(const glm::dmat4& t) {
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) {
            if (!std::isfinite(t[c][r])) throw std::invalid_argument("world_from_object: must be finite");
            if (std::abs(t[c][r]) > kMaxTransformEntry)
                throw std::invalid_argument("world_from_object: entries must be at most 1e9 in magnitude");
        }
    // glm is column-major: t[c][3] is the bottom row.
    if (t[0][3] != 0.0 || t[1][3] != 0.0 || t[2][3] != 0.0 || t[3][3] != 1.0)
        throw std::invalid_argument("world_from_object: bottom row must be [0, 0, 0, 1]");
    const double det = glm::determinant(glm::dmat3(t));
    if (!(std::abs(det) > 1e-12)) throw std::invalid_argument("world_from_object: linear part is singular");
}

}  // namespace

Scene::Scene(Isa isa, bool watertight) : m_accel(isa, watertight) {}

void Scene::require_not_rendering() const {
    if (m_readers.load() > 0) throw std::logic_error("scene: cannot be modified while a render is using it");
}

uint32_t Scene::add_mesh(const float* vertices, size_t n_vertices, const uint32_t* triangles, size_t n_triangles,
                         const float* corner_uvs, const float* vertex_albedo, const float* vertex_normals,
                         int albedo_channels) {
    require_not_rendering();
    if (n_vertices == 0) throw std::invalid_argument("vertices: mesh has no vertices");
    if (n_triangles == 0) throw std::invalid_argument("triangles: mesh has no triangles");
    if (n_vertices > 0xFFFFFFFFull) throw std::invalid_argument("vertices: more than 2^32 vertices");
    for (size_t i = 0; i < 3 * n_vertices; ++i)
        if (!std::isfinite(vertices[i]))
            throw std::invalid_argument("vertices: non-finite coordinate at vertex " + std::to_string(i / 3));
    for (size_t i = 0; i < 3 * n_triangles; ++i)
        if (triangles[i] >= n_vertices)
            throw std::invalid_argument("triangles: index " + std::to_string(triangles[i]) + " out of range for " +
                                        std::to_string(n_vertices) + " vertices (triangle " + std::to_string(i / 3) +
                                        ")");
    if (corner_uvs)
        for (size_t i = 0; i < 6 * n_triangles; ++i)
            if (!std::isfinite(corner_uvs[i]))
                throw std::invalid_argument("corner_uvs: non-finite coordinate at triangle " + std::to_string(i / 6));
    if (albedo_channels != 1 && albedo_channels != 3)
        throw std::invalid_argument("vertex_albedo: 1 or 3 channels, got " + std::to_string(albedo_channels));
    const size_t n_albedo = n_vertices * static_cast<size_t>(albedo_channels);
    if (vertex_albedo)
        for (size_t i = 0; i < n_albedo; ++i)
            if (!(std::isfinite(vertex_albedo[i]) && vertex_albedo[i] >= 0.0f))
                throw std::invalid_argument("vertex_albedo: must be finite and >= 0, got " +
                                            std::to_string(vertex_albedo[i]) + " at vertex " +
                                            std::to_string(i / albedo_channels));
    auto mesh = std::make_unique<Mesh>();
    if (corner_uvs) mesh->corner_uvs.assign(corner_uvs, corner_uvs + 6 * n_triangles);
    if (vertex_albedo) mesh->vertex_albedo.assign(vertex_albedo, vertex_albedo + n_albedo);
    mesh->vertex_albedo_channels = albedo_channels;
    if (vertex_normals) {
        mesh->vertex_normals.resize(3 * n_vertices);
        for (size_t i = 0; i < n_vertices; ++i) {
            const double x = vertex_normals[3 * i], y = vertex_normals[3 * i + 1], z = vertex_normals[3 * i + 2];
            const double len = std::sqrt(x * x + y * y + z * z);
            if (!(std::isfinite(len) && len > 0.0))
                throw std::invalid_argument("vertex_normals: must be finite and non-zero, at vertex " +
                                            std::to_string(i));
            for (int c = 0; c < 3; ++c)
                mesh->vertex_normals[3 * i + c] = static_cast<float>(vertex_normals[3 * i + c] / len);
        }
    }
    mesh->vertices.assign(vertices, vertices + 3 * n_vertices);
    mesh->vertices.push_back(0.0f);  // Embree reads 16 bytes at the last vertex
    mesh->triangles.assign(triangles, triangles + 3 * n_triangles);
    const uint32_t id = m_accel.add_prototype(mesh->vertices.data(), n_vertices, mesh->triangles.data(), n_triangles);
    m_meshes.push_back(std::move(mesh));
    return id;
}

void Scene::update_mesh(uint32_t mesh, const float* vertices, size_t n_vertices) {
    require_not_rendering();
    if (mesh >= m_meshes.size())
        throw std::invalid_argument("mesh: no mesh " + std::to_string(mesh) + " in the scene (has " +
                                    std::to_string(m_meshes.size()) + ")");
    Mesh& m = *m_meshes[mesh];
    if (!m.vertex_normals.empty())
        throw std::invalid_argument("mesh: mesh " + std::to_string(mesh) +
                                    " has vertex normals, which moving it would leave stale");
    if (n_vertices != m.vertex_count())
        throw std::invalid_argument("vertices: mesh " + std::to_string(mesh) + " has " +
                                    std::to_string(m.vertex_count()) + " vertices, got " + std::to_string(n_vertices));
    for (size_t i = 0; i < 3 * n_vertices; ++i)
        if (!std::isfinite(vertices[i]))
            throw std::invalid_argument("vertices: non-finite coordinate at vertex " + std::to_string(i / 3));
    // In place: Embree shares this buffer, so it must not move.
    std::copy(vertices, vertices + 3 * n_vertices, m.vertices.begin());
    for (uint32_t i = 0; i < m_instances.size(); ++i) {
        Instance& inst = m_instances[i];
        if (inst.mesh != mesh || inst.moving) continue;
        inst.moving = true;
        m_accel.set_instance_mask(i, kMovingGeometry);
        ++m_static_revision;
    }
    m_accel.update_prototype(mesh);
    m_committed = false;
}

uint32_t Scene::add_instance(uint32_t mesh, const glm::dmat4& world_from_object, int label, const Material& material) {
    if (label < 1 || label > 255)
        throw std::invalid_argument("instance_id: must be in 1..255, got " + std::to_string(label));
    if (m_label_used[label]) throw std::invalid_argument("instance_id: " + std::to_string(label) + " is already used");
    const uint32_t index = add(mesh, world_from_object, static_cast<uint8_t>(label), material, false);
    m_label_used[label] = true;
    return index;
}

uint32_t Scene::add_background(uint32_t mesh, const glm::dmat4& world_from_object, const Material& material,
                               bool moving) {
    const uint32_t id = add(mesh, world_from_object, 0, material, moving);
    m_has_background = true;
    return id;
}

uint32_t Scene::add(uint32_t mesh, const glm::dmat4& world_from_object, uint8_t label, const Material& material,
                    bool moving) {
    require_not_rendering();
    if (mesh >= m_meshes.size())
        throw std::invalid_argument("mesh: no mesh " + std::to_string(mesh) + " in the scene (has " +
                                    std::to_string(m_meshes.size()) + ")");
    check_transform(world_from_object);
    check_material(material);
    if (material.woven && m_meshes[mesh]->corner_uvs.empty())
        throw std::invalid_argument("material: a woven surface needs the mesh's corner_uvs (mesh " +
                                    std::to_string(mesh) + " has none)");
    float xfm[12];
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 3; ++r) xfm[3 * c + r] = static_cast<float>(world_from_object[c][r]);
    Instance inst;
    inst.mesh = mesh;
    inst.world_from_object = world_from_object;
    inst.linear = glm::dmat3(world_from_object);
    inst.translation = glm::dvec3(world_from_object[3]);
    inst.normal_to_world = glm::transpose(glm::inverse(inst.linear));
    inst.label = label;
    inst.material = material;
    if (material.woven) {
        // Whatever the instance, fabric colour is the material's albedo.
        inst.material.woven->fabric.albedo = glm::dvec3(material.albedo);
        WovenSurface& w = *inst.material.woven;
        w.dust = nullptr;
        if (w.stain_mode == StainMode::Dust) {
            if (w.stain.stamps > 0) {  // zero deposits: no dust made
                SoilingParams p = w.soiling;
                p.deposits = w.stain.stamps;
                p.opacity = w.stain.opacity;
                const Mesh& m = *m_meshes[mesh];
                w.dust = std::make_shared<const Soiling>(p, w.stain_seed, m.vertices.data(), m.vertex_count(),
                                                         m.triangles.data(), m.triangle_count());
            }
        } else {
            std::unique_ptr<StainMask> mask = paint_stain(w.stain, w.stain_seed);
            if (mask) {  // zero stamps: no mask, nothing allocated
                inst.stain = mask.get();
                m_stains.push_back(std::move(mask));
            }
        }
    }
    inst.moving = moving;
    const uint32_t index = m_accel.add_instance(mesh, xfm);
    if (moving) m_accel.set_instance_mask(index, kMovingGeometry);
    else ++m_static_revision;
    m_instances.push_back(inst);
    m_committed = false;
    return index;
}

void Scene::commit() {
    require_not_rendering();
    m_accel.commit();
    m_committed = true;
}

}  // namespace moonbot
