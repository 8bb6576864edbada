"""The dust of one scene (paper 3.2) through `moonbot._core`: granular ejecta as one
moving mesh of opaque regolith fragments, and the fine-dust cloud as a medium for the renderer.

Only a scene whose config turns dust on builds a `SceneDust`; without it nothing here runs (no
simulation, no fragment mesh, no medium). Every view has its own capture time,
`warmup_s + view × view_interval_s` (the orbit index, so a view renders the same alone or in its
orbit). The ejecta collide with the scene, so every capture is simulated before the fragments'
own mesh joins it; the mesh is then added once, from the first view's state, and each later view
moves its vertices (`Scene.update_mesh`), which rebuilds the ejecta's BVH and the top level only,
never the terrain's or the bags'. The cloud's puffs are a closed-form function of time, computed
per view. Both emitters stand on the ground `dust.emitter_offset_m` from the target's centre.
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass

import numpy as np

from moonbot import _core
from moonbot.config.schema import Config, DustConfig
from moonbot.render import params
from moonbot.render.view import regolith, regolith_grain
from moonbot.scene.compose import SceneSpec

# What a dataset user must know about a dust sample's annotations (gt.json "dust").
DUST_NOTE = (
    "dust changes RGB only: the fine-dust cloud is a medium that attenuates and scatters "
    "sunlight in rgb, and depth and masks stay geometric; the ejecta fragments are opaque "
    "background geometry (label 0), so they do appear in depth and masks, occluding bags"
)


# How far below the emitter's ground the dust grid reaches, metres: under it, dust is never seen.
FLOOR_DEPTH_M = 1.0


def dust_seed(dataset_seed: int) -> int:
    """The seed of a scene's dust (ejecta and cloud; the core gives each its own stream): a 64-bit
    hash of the dataset seed, so dust is reproducible and unrelated to every other seeded stage."""
    digest = hashlib.blake2b(f"moonbot.dust:{dataset_seed}".encode(), digest_size=8).digest()
    return int.from_bytes(digest, "little")


def capture_time(dust: DustConfig, view: int) -> float:
    """Seconds after the emitters start at which orbit view `view` is captured."""
    return dust.warmup_s + view * dust.view_interval_s


def emitter_origin(spec: SceneSpec, dust: DustConfig) -> np.ndarray:
    """Where both emitters stand: `emitter_offset_m` east and north of the target's centre, on the
    ground there. (3,) float64 world metres."""
    x = float(spec.target[0]) + dust.emitter_offset_m[0]
    y = float(spec.target[1]) + dust.emitter_offset_m[1]
    z = float(spec.ground.height(np.array([x]), np.array([y]))[0])
    return np.array([x, y, z])


def ejecta_state(
    scene: _core.Scene, dust: DustConfig, seed: int, origin: np.ndarray, time_s: float, threads: int = 0
) -> dict:
    """The ejecta of `dust.ejecta` thrown from `origin` ((3,) world metres) at `time_s` seconds
    after the emitter starts, flown on `scene` (committed, without the fragments' own mesh) in
    steps of `dust.time_step_s`: `_core.simulate_ejecta`'s state, every fragment of the burst
    (none is ever dropped)."""
    return _core.simulate_ejecta(
        scene, params.ejecta(dust.ejecta, origin), seed, time_s, dt_s=dust.time_step_s, threads=threads
    )


@dataclass(frozen=True)
class ViewDust:
    """One view's dust, ready to render: `medium` for `_core.render` (None when the cloud has no
    puff alive), `seconds` this view's dust stage cost (its ejecta simulation, moving the
    fragment mesh and rebuilding its BVH, the puffs and the medium), `meta` its record for gt.json."""

    medium: _core.Medium | None
    seconds: float
    meta: dict


class SceneDust:
    """The dust of one built, committed scene for the views about to be rendered. Construct it
    after `build_scene` and before rendering; then `for_view(v)` before rendering view v."""

    def __init__(self, scene: _core.Scene, spec: SceneSpec, config: Config, views: list[int]) -> None:
        self._scene = scene
        self._dust = config.dust
        self._seed = dust_seed(config.seed)
        self._origin = emitter_origin(spec, config.dust)
        self._mesh: int | None = None
        self._current: int | None = None  # the view whose fragments the mesh holds
        self._fragments: dict[int, tuple[int, np.ndarray]] = {}  # view → (count, vertices (12 N, 3))
        self._triangles: np.ndarray | None = None
        self._seconds: dict[int, float] = {}
        # Regolith like the terrain's rocks, background (label 0): its albedo, photometric function
        # and granular micro-texture.
        self._photometry, self._albedo = regolith(spec.terrain_photometry, spec.terrain_albedo)
        self._grain = regolith_grain(spec.terrain_photometry.grain)
        e = config.dust.ejecta
        if e.count == 0:
            return  # no ejecta: nothing simulated, no mesh
        # Every capture first: the fragments must not collide with their own mesh.
        for v in dict.fromkeys(views):
            start = time.perf_counter()
            state = ejecta_state(
                scene,
                config.dust,
                self._seed,
                self._origin,
                capture_time(config.dust, v),
                threads=config.render.threads,
            )
            self._fragments[v] = (len(state["position"]), state["vertices"])
            self._triangles = state["triangles"]
            self._seconds[v] = time.perf_counter() - start

    def for_view(self, view: int) -> ViewDust:
        """Puts view `view`'s fragments into the scene (and commits it) and returns its medium.
        `view` must be one of the views this was built for."""
        d, c = self._dust, self._dust.cloud
        t = capture_time(d, view)
        seconds = self._seconds.pop(view, 0.0)  # its simulation, paid once
        start = time.perf_counter()
        fragments = 0
        if self._triangles is not None:
            fragments, vertices = self._fragments[view]
            if self._mesh is None:
                self._mesh = self._scene.add_mesh(vertices, self._triangles)
                # Moving: a light cache neither caches the fragments nor lets them shade what it does.
                self._scene.add_background(
                    self._mesh, np.eye(4), self._albedo, self._photometry, grain=self._grain, moving=True
                )
                self._scene.commit()
            elif self._current != view:
                self._scene.update_mesh(self._mesh, vertices)
                self._scene.commit()
            self._current = view
        puffs = _core.cloud_puffs(params.cloud(c, self._origin), self._seed, t)
        # No puff alive (no rate, no opacity, or not yet born): no medium to trace.
        # Dust more than a metre under the emitter's ground is never seen or lit: the core's grid
        # stops there (the default plume rises from 1.7 m below).
        medium = params.medium(c, puffs, float(self._origin[2]) - FLOOR_DEPTH_M) if len(puffs) else None
        seconds += time.perf_counter() - start
        meta = {
            "capture_time_s": t,
            "fragments": fragments,
            "puffs": int(len(puffs)),
            "emitter_m": self._origin.tolist(),
            "note": DUST_NOTE,
        }
        return ViewDust(medium=medium, seconds=seconds, meta=meta)
