"""Physical camera exposure: from an EV100 to the scale the tone map applies to rendered radiance.

Renders are linear RGB radiance in W/(m²·sr) of sunlight (a grey surface reflects the solar
spectrum unchanged). Photometry and a camera model turn that into a sensor signal:

1. Luminance. L_v = K_sun · L_e, with K_sun = 1.27e5 lx / 1361 W/m² = 93.3 lm/W the luminous
   efficacy of sunlight above an atmosphere (docs/physics.md: solar illuminance ≈ 1.27e5 lx at
   1361 W/m²). Darula, Kittler & Gueymard (2005, Solar Energy 79:559) give 133.8 klx instead,
   98.3 lm/W: 0.08 EV brighter, below any exposure choice made here.
2. Saturation-based exposure (ISO 12232's saturation speed S = 78 / H_sat with the focal-plane
   exposure H = q·L·t/N², q = 0.65 for a typical lens and field position): the luminance that just
   saturates an ISO 100 sensor at EV100 = log2(N²/t) is L_sat = 78 / (100 · 0.65) · 2^EV100
   = 1.2 · 2^EV100 cd/m². The same relation is in Lagarde & de Rousiers, "Moving Frostbite to
   Physically Based Rendering 3.0" (SIGGRAPH 2014 course notes, the section on the camera).
3. The signal the tone map compresses is v = L_v / L_sat, so v = 1 is sensor saturation; the core
   takes `scale` = K_sun / L_sat in sr·m²/W and applies Reinhard (2002) v/(1+v) on luminance, so
   nothing above saturation clips: it rolls off toward white.

`auto` meters the scene's own regolith the way a reflected-light meter would (calibration
constant K = 12.5 cd·s/m² at ISO 100, ISO 2720): the EV100 at which level regolith lit by the
configured Sun, L = ρ·E_v·sin(elevation)/π, reads as the meter's mid-grey, EV100 =
log2(L · 100 / K). That grey lands at v = 0.125/1.2 = 0.104 of saturation, i.e. sRGB code 87
after Reinhard. ρ is what the orbit camera sees (`regolith_reflectance`): the regolith's
photometric function at the camera's depression angle, averaged over the camera's azimuth from
the Sun; for a Lambertian, the albedo itself, which reproduces docs/physics.md: ρ = 0.12
gives EV100 14.24 at 30° (Apollo's sunlit f/11, 1/250 s, ISO 160 is 14.2) and 12.72 at 10°.
Lunar-Lambert regolith of normal albedo 0.12 looks darker than that Lambertian away from zero
phase, and the meter follows it.

**Veiling glare.** A real lens scatters a fraction of all the light it passes over the whole
focal plane (reflections between element surfaces, the barrel, the sensor or film and, on the
Apollo Hasselblads, the réseau plate), so no part of a photograph of a bright scene is black.
ISO 9358 measures it by the integral method: the veiling glare index (VGI) is the image
irradiance at the centre of a small black spot over that of the uniform bright field around it.
`tonemap` applies it as a uniform veil: every pixel gains VGI × the frame's mean radiance (per
channel) before the exposure and tone map, which is exactly ISO 9358's black-spot reading for a
uniform field (the veil's spatial spread is taken as flat over the frame). Coated photographic
lenses measure around 1–3 %; `tonemap.veiling_glare` defaults to 2 % (0 = none: the image is the
previous bit for bit and no glare code runs). rgb.exr keeps the scene radiance without the veil.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from moonbot.config.schema import Config
from moonbot.render.view import regolith

SOLAR_IRRADIANCE_W_M2 = 1361.0
SOLAR_ILLUMINANCE_LX = 1.27e5
# lm/W: photometric luminance (cd/m²) of 1 W/(m²·sr) of sunlight.
LUMINOUS_EFFICACY_LM_W = SOLAR_ILLUMINANCE_LX / SOLAR_IRRADIANCE_W_M2
ISO_SPEED = 100.0
LENS_Q = 0.65  # ISO 12232's q: lens transmittance, vignetting and the π/4 of the f-number
SATURATION_CONSTANT = 78.0  # ISO 12232: saturation speed S = 78 / H_sat (lx·s)
METER_K = 12.5  # reflected-light meter calibration, cd·s/m² (ISO 2720; Canon, Nikon, Sekonic)
# `auto` meters a Sun at least this high: as the Sun sinks to the horizon the metered plane's
# luminance, and so EV100, falls to -inf, while the Sun-facing sides of bags, rocks and slopes
# stay brightly lit. 1° is below the SynBag sweep (5-30°) and the low polar Sun the reference
# lists (0-7°) barely reaches it; below it the exposure is held at its 1° value.
AUTO_MIN_ELEVATION_DEG = 1.0
# Valid EV100s (the config's range too): starlight is about -6, Earthshine-lit regolith about 3,
# the Sun's own disk about 33. `auto` is clamped into it (it reaches -10 only for a black Sun or
# a black terrain, where any exposure renders black).
EV100_MIN, EV100_MAX = -10.0, 30.0


def saturation_luminance(ev100: float) -> float:
    """L_sat (cd/m²): the luminance that saturates an ISO 100 sensor at `ev100`, 1.2 · 2^EV100."""
    return SATURATION_CONSTANT / (ISO_SPEED * LENS_Q) * 2.0**ev100


def metered_ev100(luminance_cd_m2: float) -> float:
    """The EV100 a reflected-light meter (K = 12.5) gives for a uniform `luminance_cd_m2` > 0."""
    return math.log2(luminance_cd_m2 * ISO_SPEED / METER_K)


def auto_ev100(albedo: float, sun_elevation_deg: float, irradiance_w_m2: float) -> float:
    """`tonemap.ev100: auto`: the metered EV100 of a horizontal Lambertian of `albedo` lit by the
    Sun at `sun_elevation_deg` (held at AUTO_MIN_ELEVATION_DEG or above) with `irradiance_w_m2`;
    clamped into [EV100_MIN, EV100_MAX], so always finite."""
    elevation = math.radians(max(sun_elevation_deg, AUTO_MIN_ELEVATION_DEG))
    luminance = albedo * irradiance_w_m2 * LUMINOUS_EFFICACY_LM_W * math.sin(elevation) / math.pi
    if not luminance > 0.0:
        return EV100_MIN
    return min(max(metered_ev100(luminance), EV100_MIN), EV100_MAX)


@dataclass(frozen=True)
class Exposure:
    """The exposure of a view: `ev100` (camera exposure value at ISO 100), `setting` as configured
    ("auto" or the number), `scale` in sr·m²/W (rendered radiance → signal, 1 = saturation),
    `veiling_glare` the lens's veiling glare index (a fraction, 0 = none; see `tonemap`)."""

    ev100: float
    setting: float | str
    scale: float
    veiling_glare: float = 0.0

    def metadata(self) -> dict:
        """What gt.json records about the exposure."""
        return {
            "ev100": self.ev100,
            "ev100_setting": self.setting,
            "saturation_luminance_cd_m2": saturation_luminance(self.ev100),
            "luminous_efficacy_lm_w": LUMINOUS_EFFICACY_LM_W,
            "scale_sr_m2_w": self.scale,
            "veiling_glare_index": self.veiling_glare,
            "tonemap": "reinhard2002-luminance-srgb8",
        }


def exposure_for_ev100(ev100: float, setting: float | str | None = None, veiling_glare: float = 0.0) -> Exposure:
    """The exposure at `ev100`: scale = K_sun / L_sat(EV100) in sr·m²/W."""
    return Exposure(
        ev100=ev100,
        setting=ev100 if setting is None else setting,
        scale=LUMINOUS_EFFICACY_LM_W / saturation_luminance(ev100),
        veiling_glare=veiling_glare,
    )


def tonemap(rgb: np.ndarray, exposure: Exposure) -> tuple[np.ndarray, int]:
    """(H, W, 3) linear radiance (W/(m²·sr)) to 8-bit sRGB at `exposure`: the lens's veiling
    glare (`exposure.veiling_glare`, ISO 9358's index: that fraction of each channel's mean over
    the frame's finite, non-negative pixels added to those pixels; 0 = none), then Reinhard's tone
    map, both in the core (`_core.tonemap_reinhard`). Returns (uint8 (H, W, 3), the count of
    invalid pixels: a NaN, ±Inf or negative channel)."""
    from moonbot import _core

    return _core.tonemap_reinhard(rgb, exposure.scale, exposure.veiling_glare)


def regolith_reflectance(config: Config, azimuths: int = 36) -> float:
    """The Lambert-equivalent reflectance ρ of the terrain's regolith as the orbit camera sees
    it: albedo × the photometric shape, averaged over `azimuths` camera azimuths from the Sun,
    with the Sun at max(elevation, AUTO_MIN_ELEVATION_DEG) and the view at the camera's
    depression angle toward the target (at least 5°). For a Lambertian surface, its albedo."""
    photometry, albedo = regolith(config.terrain.photometry, config.terrain.albedo)
    mu_i = math.sin(math.radians(max(config.sun.elevation_deg, AUTO_MIN_ELEVATION_DEG)))
    depression = math.atan2(config.orbit.height_m, config.orbit.radius_m)
    mu_o = math.sin(max(depression, math.radians(5.0)))
    across = math.sqrt(max(0.0, 1.0 - mu_i * mu_i)) * math.sqrt(max(0.0, 1.0 - mu_o * mu_o))
    shapes = [
        photometry.shape(mu_i, mu_o, mu_i * mu_o + across * math.cos(2 * math.pi * (k + 0.5) / azimuths))
        for k in range(azimuths)
    ]
    return albedo[0] * sum(shapes) / azimuths


def resolve_exposure(config: Config) -> Exposure:
    """The configured exposure: `tonemap.ev100` as a number, or `auto` metered on the terrain's
    regolith as the camera sees it under the configured Sun (see regolith_reflectance and
    auto_ev100)."""
    setting = config.tonemap.ev100
    if setting == "auto":
        ev100 = auto_ev100(regolith_reflectance(config), config.sun.elevation_deg, config.sun.irradiance_w_m2)
    else:
        ev100 = float(setting)
    return exposure_for_ev100(ev100, setting, config.tonemap.veiling_glare)


def exposure_scale(config: Config) -> float:
    """The configured exposure's scale in sr·m²/W (see resolve_exposure)."""
    return resolve_exposure(config).scale
