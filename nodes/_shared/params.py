"""Param types nodes share: finite floats, RGB colours in [0, 1], 2x2 matrices of finite floats. Each
rejects NaN and infinity when the pipeline loads (a located one-line error), where a plain `float` would
let them through to the GPU."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

Finite = Annotated[float, Field(allow_inf_nan=False)]
Unit = Annotated[float, Field(ge=0.0, le=1.0, allow_inf_nan=False)]
Color = tuple[Unit, Unit, Unit]
Matrix2 = tuple[tuple[Finite, Finite], tuple[Finite, Finite]]
