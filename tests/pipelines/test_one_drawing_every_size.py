"""One drawing at every size: each shipped pipeline rendered at 1600x1600 and area-averaged to 400x400
looks like its direct 400x400 render (SSIM on luminance, scikit-image), because its image-space params are
pixels at the pipeline's reference size (docs/sizes.md). Before reference_size the default pipeline scored
0.79 and pencil 0.86 (columns of the cloister turned into black masses at 400)."""

from __future__ import annotations

import pytest

from nodegraph.shipped import names
from nodegraph.tools.bench import sizes

# Particle pipelines: two renders of one pipeline at one size with another particle seed score about 0.91 (the
# strokes are random), so they are held at the issue's 0.85; with depth_edges' and force_field's filters in
# reference pixels they measure 0.896 and 0.908 (0.819 and 0.844 with the per-pixel filters; docs/sizes.md).
# particle strokes and plotter_lines' hatching streamlines are laid out anew at each size (the same density and
# tone, other places: plotter_lines 0.82 with hatching, 0.92 without; its tone within 0.005)
FLOOR = {"loose_and_sketchy": 0.85, "loose_and_sketchy_shaded": 0.85, "plotter_lines": 0.80}


@pytest.fixture(scope="module")
def session(gl):
    from nodegraph.api import Session

    with Session(cache=False) as s:
        yield s


@pytest.mark.slow  # a large render per pipeline, up to 3.4 s
@pytest.mark.parametrize("name", names())
def test_large_render_downsampled_matches_the_small_one(session, name):
    keep: dict = {}
    row = sizes.compare(name, 400, 1600, session=session, keep=keep)
    floor = FLOOR.get(name, 0.92)
    assert row["ssim"] >= floor, f"{name}: SSIM {row['ssim']} < {floor}"
    # the tone too: the same share of ink at both sizes, not only the same structure
    assert abs(row["mean_luminance_small"] - row["mean_luminance_large"]) < 0.025


@pytest.mark.slow  # 2.3 s
def test_per_pixel_params_fail_the_check(session):
    """The check can fail: with every size its own reference (the old per-pixel params) the default
    pipeline's 400 px render is far from the 1600 px one."""
    direct = session.load("nienhaus_sketchy", size=(400, 400), reference_size=400).render()
    big = session.load("nienhaus_sketchy", size=(1600, 1600), reference_size=1600).render()
    score = sizes.ssim(sizes.luminance(direct), sizes.area_down(sizes.luminance(big), 4))
    assert score < 0.85


def test_area_down_and_luminance():
    import numpy as np

    a = np.arange(16, dtype=np.float64).reshape(4, 4)
    assert sizes.area_down(a, 2).tolist() == [[2.5, 4.5], [10.5, 12.5]]
    rgb = np.zeros((1, 2, 4), dtype=np.uint8)
    rgb[0, 1] = (255, 255, 255, 255)
    assert sizes.luminance(rgb).tolist() == [[0.0, pytest.approx(1.0)]]
    with pytest.raises(ValueError):
        sizes.area_down(np.zeros((5, 4)), 2)
