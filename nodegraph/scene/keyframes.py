"""Scene YAML keyframes: `animate:` on objects (translate, rotate, scale) and on the camera (eye, target,
up, fov), as lists of keys `{time: SECONDS | frame: N, value: ..., interpolation: linear|step|smooth}`.

The interpolation of a key applies to the segment that starts at it; `smooth` eases in and out of both
keys (smoothstep: zero velocity at each key). Before the first key and after the last the end values hold.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from .animation import Track

_INTERP = {"linear": "LINEAR", "step": "STEP", "smooth": "SMOOTH"}
MAX_KEY = 2**31 - 1
"""The latest key, as a frame number or in seconds: frame numbers are 32-bit (`output.write.MAX_FRAME`), so a key
beyond it could never be rendered; an animation longer than a run renders by default (`MAX_FRAMES`) is refused
when its frames are taken (`animation.default_frames`, suggesting --frames)."""


class _Spec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)


class KeySpec(_Spec):
    time: float | None = Field(None, ge=0, le=MAX_KEY, description="Key time in seconds (give this or 'frame').")
    frame: float | None = Field(None, ge=0, le=MAX_KEY, description="Key time as a frame number at the scene's fps "
                                "(give this or 'time').")
    value: float | list[float] = Field(description="The value at this key: [x, y, z] (translate, rotate in "
                                       "degrees, eye, target, up), a number (fov; scale: uniform) or [sx, sy, sz].")
    interpolation: Literal["linear", "step", "smooth"] = Field("linear", description="How the value moves from "
                                                               "this key to the next: linear, step (holds), or "
                                                               "smooth (eases in and out).")

    @model_validator(mode="after")
    def _one_time(self) -> KeySpec:
        if (self.time is None) == (self.frame is None):
            raise ValueError("give exactly one of 'time' (seconds) or 'frame'")
        values = self.value if isinstance(self.value, list) else [self.value]
        if not all(math.isfinite(v) for v in values):
            raise ValueError("key values must be finite")
        return self

    def seconds(self, fps: float) -> float:
        return float(self.time) if self.time is not None else float(self.frame) / fps  # type: ignore[arg-type]


Keys = list[KeySpec]


class ObjectAnimateSpec(_Spec):
    translate: Keys | None = Field(None, min_length=1, description="Keys of the translation [x, y, z].")
    rotate: Keys | None = Field(None, min_length=1, description="Keys of the rotation in degrees about X, Y, Z "
                                "(interpolated per angle).")
    scale: Keys | None = Field(None, min_length=1, description="Keys of the scale (a positive number or "
                               "[sx, sy, sz]).")


class CameraAnimateSpec(_Spec):
    eye: Keys | None = Field(None, min_length=1, description="Keys of the camera position.")
    target: Keys | None = Field(None, min_length=1, description="Keys of the point looked at.")
    up: Keys | None = Field(None, min_length=1, description="Keys of the up direction.")
    fov: Keys | None = Field(None, min_length=1, description="Keys of the field of view in degrees.")


def track(keys: Keys, fps: float, width: int, what: str) -> Track:
    """A Track from keys; `width` 3 broadcasts a single number (uniform scale), 1 takes one number."""
    times, values = [], []
    for k in keys:
        v = np.asarray(k.value, dtype=np.float64).reshape(-1)
        if v.size == 1 and width == 3:
            v = np.repeat(v, 3)
        if v.size != width:
            raise ValueError(f"{what}: expected {'a number' if width == 1 else f'{width} numbers'}, found {k.value}")
        times.append(k.seconds(fps))
        values.append(v)
    if any(b <= a for a, b in zip(times, times[1:], strict=False)):
        raise ValueError(f"{what}: key times must increase ({', '.join(f'{t:g} s' for t in times)})")
    return Track(np.array(times), np.array(values), "LINEAR", segment=tuple(_INTERP[k.interpolation] for k in keys))


def tracks(spec: Any, fps: float, widths: dict[str, int]) -> dict[str, Track]:
    """{field: Track} for the fields of an animate spec that have keys."""
    out = {}
    for name, width in widths.items():
        keys = getattr(spec, name, None)
        if keys:
            out[name] = track(keys, fps, width, name)
    return out


def time_range(found: dict[str, Track]) -> tuple[float, float] | None:
    if not found:
        return None
    return min(t.start for t in found.values()), max(t.end for t in found.values())
