"""Blender lights and world → libtranscut lights, with Blender's units converted.

Each light becomes a :class:`LightSpec`: the name of a ``transcut.Scene`` method and its keyword
arguments, in world space (scene units, Blender's +Z up; the library uses the same axes).

Conversions (Blender's light units are those of Cycles; c is the light colour, times the
blackbody colour when "Temperature" is on, times 2^exposure):

- **Sun**: "Strength" S is irradiance in W/m² on a surface facing the sun, so
  E = S·c. It travels along the object's local −Z; its "Angle" is the angular diameter.
- **Point**: "Power" P is the total radiant flux in W of an isotropic emitter, so its radiant
  intensity is I = P·c / (4π) W/sr (flux = ∫ I dω = 4π I).
- **Spot**: Blender's spot is a point light masked by its cone (the cone does not concentrate
  the power), so I = P·c / (4π) as for a point; cone half-angle = "Size"/2, blend = "Blend",
  axis = local −Z.
- **Area**: a one-sided Lambertian emitter of area A (world space, object scale included)
  radiating flux P has radiance L = P·c / (π·A) (flux = L·π·A). With "Normalize" off Blender
  does not divide by the area: L = P·c / π. Square and rectangle → a rectangle light emitting
  along local −Z; disk → a disc; an ellipse → the disc of equal area (a warning says so).
- **World**: a Background shader whose Color is unlinked is a constant environment of radiance
  Color × Strength (W/(m²·sr)); an Environment Texture (equirectangular) feeding it becomes an
  equirect environment (rows flipped to top-first; 8-bit sRGB images linearised; Strength as the
  multiplier). A world without nodes uses its viewport colour as a constant environment.

A point or spot "Radius" (soft shadows) is treated as a point; an area light's "Spread" is ignored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .mesh_export import matrix_array

FOUR_PI = 4.0 * math.pi


@dataclass
class LightSpec:
    """A light for ``transcut.Scene``: ``getattr(scene, method)(**kwargs)``."""

    method: str
    kwargs: dict = field(default_factory=dict)
    source: str = ""  # the Blender object or world it came from


def light_colour(light) -> np.ndarray:
    """c = colour × blackbody colour (when "Temperature" is on) × 2^exposure."""
    c = np.array(light.color[:3], dtype=np.float64)
    if getattr(light, "use_temperature", False):
        c = c * np.array(light.temperature_color[:3], dtype=np.float64)
    return c * 2.0 ** float(getattr(light, "exposure", 0.0))


def sun_irradiance(strength: float, colour) -> list:
    """Sun strength (W/m²) → irradiance E = S·c."""
    return [float(strength) * float(x) for x in colour]


def point_intensity(power: float, colour) -> list:
    """Point or spot power P (W) → radiant intensity I = P·c/(4π) (W/sr)."""
    return [float(power) * float(x) / FOUR_PI for x in colour]


def area_radiance(power: float, colour, area: float, normalize: bool = True) -> list:
    """Area light power P (W) → radiance L = P·c/(π·A) (one-sided Lambertian; A = 1 when not
    normalised, as Blender does)."""
    a = float(area) if normalize else 1.0
    return [float(power) * float(x) / (math.pi * a) for x in colour]


def _unit(v: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(v))
    return v / n if n > 0.0 else v


def convert_light(obj_name: str, light, matrix_world, warnings: list) -> list:
    """One Blender light (``bpy.types.Light``) with its world matrix → ``LightSpec`` list (empty
    when it emits nothing)."""
    m = matrix_array(matrix_world)
    m3 = m[:3, :3]
    position = m[:3, 3]
    down = _unit(m3 @ np.array([0.0, 0.0, -1.0]))
    colour = light_colour(light)
    power = float(light.energy)
    if power == 0.0 or not np.any(colour > 0.0):
        return []
    if light.type == "SUN":
        return [
            LightSpec(
                "add_sun",
                dict(
                    direction=down.tolist(),
                    irradiance=sun_irradiance(power, colour),
                    angular_diameter_deg=math.degrees(float(light.angle)),
                ),
                obj_name,
            )
        ]
    if light.type == "POINT":
        return [
            LightSpec("add_point", dict(position=position.tolist(), intensity=point_intensity(power, colour)), obj_name)
        ]
    if light.type == "SPOT":
        return [
            LightSpec(
                "add_spot",
                dict(
                    position=position.tolist(),
                    direction=down.tolist(),
                    intensity=point_intensity(power, colour),
                    cone_half_angle_deg=math.degrees(float(light.spot_size)) / 2.0,
                    blend=float(light.spot_blend),
                ),
                obj_name,
            )
        ]
    if light.type == "AREA":
        sx = float(light.size)
        sy = float(light.size) if light.shape in ("SQUARE", "DISK") else float(light.size_y)
        half_u = m3 @ np.array([sx / 2.0, 0.0, 0.0])
        # half_u × half_v points along local −Z, the side Blender's area light emits towards.
        half_v = m3 @ np.array([0.0, -sy / 2.0, 0.0])
        rect_area = 4.0 * float(np.linalg.norm(np.cross(half_u, half_v)))
        normalize = bool(getattr(light, "normalize", True))
        if getattr(light, "spread", math.pi) < math.pi - 1e-6:
            warnings.append(f"area light '{obj_name}': spread is ignored (treated as 180°)")
        if light.shape in ("SQUARE", "RECTANGLE"):
            return [
                LightSpec(
                    "add_rect",
                    dict(
                        center=position.tolist(),
                        half_u=half_u.tolist(),
                        half_v=half_v.tolist(),
                        radiance=area_radiance(power, colour, rect_area, normalize),
                        two_sided=False,
                    ),
                    obj_name,
                )
            ]
        # DISK / ELLIPSE: the inscribed ellipse has π/4 of the rectangle's area.
        area = rect_area * math.pi / 4.0
        if light.shape == "ELLIPSE" and abs(sx - sy) > 1e-9 * max(sx, sy):
            warnings.append(f"area light '{obj_name}': ellipse approximated by the disc of equal area")
        normal = _unit(np.cross(half_u, half_v))
        return [
            LightSpec(
                "add_disc",
                dict(
                    center=position.tolist(),
                    normal=normal.tolist(),
                    radius=math.sqrt(area / math.pi),
                    radiance=area_radiance(power, colour, area, normalize),
                    two_sided=False,
                ),
                obj_name,
            )
        ]
    warnings.append(f"light '{obj_name}' of type {light.type} is not supported and was skipped")
    return []


def scene_lights(depsgraph, warnings: list) -> list:
    """Every visible light instance of the evaluated scene (collection instances included)."""
    specs = []
    for inst in depsgraph.object_instances:
        ob = inst.object
        if ob.type != "LIGHT":
            continue
        specs.extend(convert_light(ob.name, ob.data, inst.matrix_world, warnings))
    return specs


def _srgb_to_linear(c: np.ndarray) -> np.ndarray:
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def environment_image(image) -> np.ndarray:
    """An image's pixels as linear RGB (height, width, 3), row 0 = top."""
    width, height = image.size
    channels = image.channels
    if width == 0 or height == 0:
        raise ValueError(f"environment image '{image.name}' has no pixels (missing file?)")
    buf = np.empty(width * height * channels, dtype=np.float32)
    image.pixels.foreach_get(buf)
    rgb = buf.reshape(height, width, channels)[::-1, :, :3]
    if channels < 3:
        rgb = np.repeat(buf.reshape(height, width, channels)[::-1, :, :1], 3, axis=2)
    if not image.is_float and image.colorspace_settings.name == "sRGB":
        rgb = _srgb_to_linear(rgb)
    return np.ascontiguousarray(rgb, dtype=np.float32)


def world_lights(world, warnings: list) -> list:
    """The world as an environment light (see the module docs); [] when it is black or absent."""
    if world is None:
        return []
    if not world.use_nodes or world.node_tree is None:
        rgb = [float(x) for x in world.color[:3]]
        return [LightSpec("add_environment", dict(radiance=rgb), world.name)] if any(rgb) else []
    output = world.node_tree.get_output_node("ALL")
    if output is None or not output.inputs["Surface"].is_linked:
        return []
    node = output.inputs["Surface"].links[0].from_node
    if node.type != "BACKGROUND":
        warnings.append(f"world '{world.name}': surface is a {node.type} node, not Background; world ignored")
        return []
    strength_in = node.inputs["Strength"]
    if strength_in.is_linked:
        warnings.append(f"world '{world.name}': linked Strength ignored (value {strength_in.default_value} used)")
    strength = float(strength_in.default_value)
    colour_in = node.inputs["Color"]
    if not colour_in.is_linked:
        rgb = [float(x) * strength for x in colour_in.default_value[:3]]
        return [LightSpec("add_environment", dict(radiance=rgb), world.name)] if any(rgb) else []
    tex = colour_in.links[0].from_node
    if tex.type != "TEX_ENVIRONMENT" or tex.image is None or tex.projection != "EQUIRECTANGULAR":
        warnings.append(
            f"world '{world.name}': colour comes from a {tex.type} node the add-on cannot read "
            "(only an equirectangular Environment Texture); world ignored"
        )
        return []
    if tex.inputs["Vector"].is_linked:
        warnings.append(f"world '{world.name}': environment texture mapping ignored")
    if strength == 0.0:
        return []
    return [LightSpec("add_environment_image", dict(rgb=environment_image(tex.image), strength=strength), world.name)]
