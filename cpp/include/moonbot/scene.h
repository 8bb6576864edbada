// A scene: triangle-mesh prototypes, instances of them with rigid (or affine) transforms, an
// instance label for the masks and a material each. Built once, rendered from many cameras.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include <glm/glm.hpp>

#include "moonbot/accel.h"
#include "moonbot/fabric.h"
#include "moonbot/photometry.h"
#include "moonbot/regolith_texture.h"
#include "moonbot/soiling.h"
#include "moonbot/stain.h"
#include "moonbot/subgrid_craters.h"

namespace moonbot {

/// How a bag's dirt is made.
enum class StainMode : uint8_t {
    Stamp,  ///< the paper's splat stamps into a UV mask (stain.h)
    Dust,   ///< regolith dust gathered at the ground contact and where handled (soiling.h)
};

/// A bag's cloth: the woven fabric (fabric.h; its mean colour is the material's albedo) laid on
/// the mesh's corner UVs at `metres_per_uv`, and its dirt, made for this instance from
/// `stain_seed` — in Stamp mode the paper's stain (stain.h) painted into a mask, in Dust mode
/// regolith dust (soiling.h, with stain.stamps deposits and stain.opacity); with stain.stamps = 0
/// neither is made or allocated.
struct WovenSurface {
    FabricParams fabric;
    double metres_per_uv = 1.0;  ///< fabric metres per atlas UV unit (bag_mesh.uv_atlas's scale)
    StainParams stain;
    uint64_t stain_seed = 0;
    glm::dvec3 dirt_colour{0.12, 0.11, 0.10};  ///< linear RGB
    StainMode stain_mode = StainMode::Stamp;
    SoilingParams soiling;  ///< Dust mode's shape (its deposits and opacity are taken from `stain`)
    /// Set by Scene::add_instance in Dust mode with stamps > 0: this instance's dust.
    std::shared_ptr<const Soiling> dust;

    /// Throws std::invalid_argument naming the field: fabric, stain and soiling (each their
    /// validate()), metres_per_uv positive and finite, each dirt_colour channel in [0, 1].
    void validate() const;
};

/// A surface: `albedo` linear RGB in [0, 1] and the photometric function that shapes it (the
/// BRDF is albedo/π · photometric_shape(...); Lambertian by default); optionally woven; optionally
/// regolith's granular micro-texture (regolith_texture.h) at camera hits, which multiplies the
/// albedo and tilts the shading normal (null: none, and none of its code runs); optionally the
/// small craters its mesh did not draw (subgrid_craters.h), whose slopes tilt the shading normal
/// and whose walls hide the lights at camera hits (null: none, and none of their code runs).
struct Material {
    glm::vec3 albedo{0.5f};
    Photometry photometry{};
    std::optional<WovenSurface> woven;
    std::shared_ptr<const RegolithGrain> grain;
    std::shared_ptr<const SubgridCraters> craters;
};

/// A prototype mesh, held by the scene for the lifetime of its BVH.
struct Mesh {
    std::vector<float> vertices;      // xyz per vertex, metres, plus one padding float (Embree rule)
    std::vector<uint32_t> triangles;  // three vertex indices per triangle
    std::vector<float> corner_uvs;    // (u, v) per triangle corner, 6 per triangle; empty if none
    std::vector<float>
        vertex_albedo;  // a factor on the material's albedo per vertex (1 or 3 per vertex); empty if none
    int vertex_albedo_channels = 1;    // 1: one factor on all of RGB; 3: one per channel
    std::vector<float> vertex_normals;  // unit shading normal per vertex (object frame, xyz); empty if none
    size_t vertex_count() const { return (vertices.size() - 1) / 3; }
    size_t triangle_count() const { return triangles.size() / 3; }
    /// Vertex i in double precision (object frame, metres).
    glm::dvec3 vertex(uint32_t i) const { return {vertices[3 * i], vertices[3 * i + 1], vertices[3 * i + 2]}; }
};

/// One placed copy of a mesh.
struct Instance {
    uint32_t mesh = 0;
    glm::dmat4 world_from_object{1.0};
    glm::dmat3 linear{1.0};           // world_from_object's linear part, for cheap point transforms
    glm::dvec3 translation{0.0};      // world_from_object's translation, metres
    glm::dmat3 normal_to_world{1.0};  // inverse transpose of the linear part
    uint8_t label = 0;                 // instance id in masks; 0 = background (terrain, rocks)
    Material material;
    const StainMask* stain = nullptr;  // this instance's dirt mask (owned by the scene); none if clean
    /// Moves between views (the dust's ejecta): rays with mask kStaticGeometry (accel.h), the
    /// light cache's, pass through it.
    bool moving = false;
};

class Scene {
public:
    /// An empty scene whose BVHs run Embree's kernels in `isa` (resolved as accel.h's
    /// resolve_isa does; throws std::invalid_argument where this CPU cannot run it), watertight
    /// unless `watertight` is false (Accel; for measuring its cost only).
    explicit Scene(Isa isa = Isa::automatic, bool watertight = true);
    Scene(const Scene&) = delete;
    Scene& operator=(const Scene&) = delete;

    /// Adds a prototype: `vertices` is n_vertices×3 (metres, object frame, finite), `triangles`
    /// is n_triangles×3 indices into it. Both are copied. Throws std::invalid_argument naming the
    /// argument on an empty mesh, a non-finite vertex or an index out of range. Returns its index.
    /// `corner_uvs` (optional, n_triangles×3×2, finite) are texture coordinates per triangle
    /// corner, which a woven material needs. `vertex_albedo` (optional, n_vertices ×
    /// `albedo_channels` (1 or 3), finite, ≥ 0) multiplies the albedo of any material on the
    /// mesh, interpolated across triangles: one factor (regolith's albedo varies over a site) or
    /// one per RGB channel (a user mesh's base-colour texture). `vertex_normals` (optional, n_vertices×3, finite,
    /// non-zero; normalised here) are shading normals interpolated across triangles, so a
    /// tessellated smooth surface does not shade as facets; visibility still follows the
    /// triangles themselves.
    uint32_t add_mesh(const float* vertices, size_t n_vertices, const uint32_t* triangles, size_t n_triangles,
                      const float* corner_uvs = nullptr, const float* vertex_albedo = nullptr,
                      const float* vertex_normals = nullptr, int albedo_channels = 1);

    /// Moves the vertices of mesh `mesh` (one without vertex normals, whose shading would go
    /// stale) to `vertices` (n_vertices×3, the mesh's own count, finite; triangles and UVs stay)
    /// and rebuilds that mesh's BVH alone: per view, the dust's ejecta move while the terrain's
    /// and the bags' BVHs are kept. Its instances become `moving` (Instance) if they were not.
    /// Needs a commit before the next render. Throws std::invalid_argument naming the argument.
    void update_mesh(uint32_t mesh, const float* vertices, size_t n_vertices);

    /// Adds a labelled object (label 1–255, unique in the scene) with a world-from-object affine
    /// transform (metres). A woven material paints its stain mask here (none for 0 stamps).
    /// Returns the instance index.
    uint32_t add_instance(uint32_t mesh, const glm::dmat4& world_from_object, int label, const Material& material);

    /// Adds unlabelled geometry (terrain, rocks): it shows in RGB and depth with label 0.
    /// `moving`: it will move between views (Instance::moving).
    uint32_t add_background(uint32_t mesh, const glm::dmat4& world_from_object, const Material& material,
                            bool moving = false);

    /// Builds the top-level BVH. Rendering needs a committed scene; adding after a commit
    /// requires another commit.
    void commit();
    bool committed() const { return m_committed; }

    const Accel& accel() const { return m_accel; }
    const Mesh& mesh(uint32_t i) const { return *m_meshes[i]; }
    const Instance& instance(uint32_t i) const { return m_instances[i]; }
    size_t mesh_count() const { return m_meshes.size(); }
    size_t instance_count() const { return m_instances.size(); }
    /// Whether any instance is background (label 0): the terrain, which lies under everything.
    bool has_background() const { return m_has_background; }
    /// The ISA Embree traces this scene's rays in.
    Isa isa() const { return m_accel.isa(); }
    /// Counts the changes to the geometry that does not move (instances added, meshes moved that
    /// were not `moving`): a light cache is valid for the revision it was built at.
    uint64_t static_revision() const { return m_static_revision; }
    /// BVH builds so far (one per mesh plus one per commit).
    uint64_t bvh_builds() const { return m_accel.builds(); }

    /// Held by a renderer for the duration of a render: while any is alive, modifying the scene
    /// throws std::logic_error instead of racing the traversal (Python may call in from another
    /// thread while a render runs with the GIL released).
    class ReadLock {
    public:
        explicit ReadLock(const Scene& s) : m_scene(s) { ++m_scene.m_readers; }
        ~ReadLock() { --m_scene.m_readers; }
        ReadLock(const ReadLock&) = delete;
        ReadLock& operator=(const ReadLock&) = delete;

    private:
        const Scene& m_scene;
    };

private:
    uint32_t add(uint32_t mesh, const glm::dmat4& world_from_object, uint8_t label, const Material& material,
                 bool moving);
    void require_not_rendering() const;

    Accel m_accel;
    // unique_ptr: the vertex buffers are shared with Embree and must never move.
    std::vector<std::unique_ptr<Mesh>> m_meshes;
    std::vector<Instance> m_instances;
    std::vector<std::unique_ptr<StainMask>> m_stains;  // painted masks; instances point into them
    bool m_label_used[256] = {};
    bool m_has_background = false;
    bool m_committed = false;
    uint64_t m_static_revision = 0;
    mutable std::atomic<int> m_readers{0};
};

}  // namespace moonbot
