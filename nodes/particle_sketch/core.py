"""Float64 CPU core of the `particle_sketch` node: Curtis' "loose and sketchy" drawing (Curtis, "Loose and
Sketchy Animation", 1998).

Conventions. Images are [row, col] arrays with row 0 = the bottom row (GL textures); x = col, y = row,
so y points up. Positions are continuous: pixel (col i, row j) covers [i, i+1) x [j, j+1), its centre
is (i + 0.5, j + 0.5). Depth is float in [0, 1], 1.0 = background. Only NumPy is needed at run time
(SciPy is a test dependency of the project, not a runtime one).

Filters
-------
The tent blurs and the Sobel pair are float64 references shared with `depth_edges` and `force_field`
(`nodes/_shared/filters.py`, which says how Curtis' kernels map onto our arrays).

* `depth_edges`: tent3, Sobel, mag = sqrt(gx^2 + gy^2), edge where mag >= threshold. A depth step s
  gives a 4-pixel ridge s * [1, 3, 3, 1]: `threshold` is in depth units (0.03 finds steps >= 0.01).
* `force_field`: ff1 = rot90(sobel(tent3(depth))), ff2 = rot90(sobel(tent9(min(mag, clamp)))),
  ff = ff1 - ff2 with rot90(gx, gy) = (-gy, gx). Scaling: Curtis works on 8-bit depth d8 = 255 d and
  clamps the magnitude at 255; the same clamp on d is `clamp = 1.0` (default), and the field is then
  Curtis' / 255 (same shape, same ff1 : ff2 balance).

What the field does (measured on a disc, see the tests): both parts are rotated gradients, so
ff = rot90(grad psi), psi = -8 (tent3(depth) - tent9(min(mag, clamp))): divergence free, tangent to the
level lines of psi, which run along the edges. Nothing in it points *towards* an edge - Curtis'
"the second component forces the particle back onto the edge" is not what its pseudocode computes:
ff2 is a shear, with ff1 on the background side of a silhouette and against it on the object side
(the flow reverses about 1.5 px inside the rim). Particles stay on an edge only because, with drag,
they follow streamlines; inertia drifts them outwards on curves (by about v tau / R px per px, tau =
mass / drag) and the random force makes them wander, and a stroke ends once it is more than n px
from any remaining edge pixel. That, not a restoring force, sets the stroke length.

Speed: |ff| grows with the depth step, a 0.3 silhouette drives particles 10x faster than a 0.03 inner
edge. `force_field(..., saturate=s)` divides ff by max(|ff|, s): directions and streamlines stay (a
positive rescaling of a divergence-free field only re-times its flow), the speed is |ff| / s below s
and 1 above. `prepare` uses s = threshold, so every detected edge is drawn at about 1 / drag px per
unit time; with the raw field no single `step` suits both kinds of edge.

Particles
---------
A stroke, as in the seed: a start is a uniformly random position, accepted when its pixel is within
n px (Euclidean, pixel centres) of a remaining edge pixel and not within m px of a line pixel (ink >=
0.5); at most `retries` tries, and the first stroke that finds none ends the run (erasing and inking
only shrink the valid set, so later strokes would fail too). From rest the particle moves with
a = (ff(p) - drag v + r) / mass (computed as * (1 / mass)), ff bilinear between pixel centres and
clamped at the border, r = randomness * (U(-1, 1), U(-1, 1)) held over a step; classic RK4 (ff sampled
at the four stage positions) or explicit Euler, time step `step`. A step that leaves the image or
overflows ends the stroke undrawn. Otherwise its segment is drawn - ink = max(ink, clip(line_width / 2
+ 0.5 - d, 0, 1)), d the exact distance from a pixel centre to the segment - and erased from the edge
map (pixel centres within erase_width / 2 of it), and the stroke ends if the new position was not
within n px of a remaining edge pixel, or after `max_steps` steps. As in Curtis' method the particle draws,
erases, then tests - but the test looks at the edge map from before this segment's erasure, else it
could never see past its own brush. So the last, off-edge segment is drawn, and erase_width must stay
below 2 n. The default erase_width is the line width; wider erasing ends strokes early.

Random numbers are counter based (module `rng`): one 64-bit key from the generator, then splitmix64
of (key, stroke, index). A stroke's start candidates and forces do not depend on other strokes or on the
batch size, and the pure-Python reference and the compiled engine draw the very same numbers.

Defaults (tuned by eye on the 800 x 800 cow, see bench.py): mass 6, drag 1 (tau = 6: strokes overshoot
and leave tight curves, a new stroke takes over - the loose look), randomness 0.35, step 3 (RK4 is
accurate there: drag * step / mass = 0.5, and a 3 px chord of a 10 px radius strays 0.1 px),
max_steps 25 (strokes of at most ~75 px), line and erase width 1.2 px, n = m = 2.

Engines
-------
The method is sequential: each particle erases what the next would trace, and a start is tested against
the ink drawn so far. `simulate` runs it one of two ways, chosen by `batch`:

* batch=1 (default): strictly sequential, compiled with Numba (module `jit`): the pure-Python
  reference's statements with its floating-point order, so its output equals `simulate_python` bit
  for bit (tested), about 100x faster (docs/particles.md).
* batch=B > 1: B lanes in lock-step with NumPy (complex positions, vectorised RK4 and bilinear
  gathers); every lock-step inks and erases all its segments into the shared maps before the next one,
  and a lane whose particle dies is refilled at once with the next stroke, its start tested exactly
  against the maps as they are then. The start search is vectorised too: candidates are prefiltered
  with a cached valid mask (a dilation of the maps; always a superset, refreshed lazily, so results do
  not depend on it) and the survivors tested exactly. A stroke does not see strokes still running when
  it starts, so concurrent strokes trace parallel lines that a sequential run would have refused:
  more strokes, steps and ink, the same coverage and precision. Measured on the 800 x 800 cow
  (bench.py, seed 1), against batch=1: batch 16 -1% steps, 64 +9%, 256 +27% steps and +24% strokes,
  1024 +85% steps; coverage 0.999 and precision 0.934-0.938 throughout. With one lane
  (`engine="numpy"`) this code is the sequential algorithm too, equal to the reference (tested).

Before Numba the lock-step lanes were the speed (about 25x the reference with 256 lanes); the
compiled sequential run is faster still and draws exactly what Curtis describes, so it became the
default, and batching stays as a measured variant (a heavier, more doubled outline at large B).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from nodegraph.fsio import compiled

from .._shared import filters
from .common import LINE_LEVEL, ParticleParams, Sites, SketchResult, disc_offsets, pad_for
from .rng import (
    PAIR,
    draw_key,
    point_np,
    point_of,
    point_py,
    stroke_key_np,
    stroke_key_py,
    unit_np,
    unit_py,
)

# --- depth edges and force field ------------------------------------------------------------------

def depth_edges(depth: np.ndarray, threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """Tent blur, Sobel, magnitude; edge where magnitude >= threshold. Returns (edges bool, mag)."""
    gx, gy = filters.sobel(filters.tent3(depth))
    mag = np.sqrt(gx * gx + gy * gy)
    return mag >= threshold, mag


def force_field(depth: np.ndarray, clamp: float = 1.0, saturate: float | None = None) -> np.ndarray:
    """Curtis' force field ff = ff1 - ff2, (H, W, 2) float64, [..., 0] = x, [..., 1] = y.

    `clamp` is Curtis' 255 for 8-bit depth, rescaled to depth in [0, 1]. With `saturate` the field
    is divided by max(|ff|, saturate) (same streamlines, speed capped at 1; see the module docstring).
    """
    return _force(*filters.sobel(filters.tent3(depth)), clamp, saturate)


def _force(gx: np.ndarray, gy: np.ndarray, clamp: float, saturate: float | None) -> np.ndarray:
    if saturate is not None and not saturate > 0:
        raise ValueError(f"saturate: expected a value > 0 or None, got {saturate}")
    mag = np.minimum(np.sqrt(gx * gx + gy * gy), clamp)
    hx, hy = filters.sobel(filters.tent9(mag))
    ff = np.stack([-gy - -hy, gx - hx], axis=-1)  # (ff1x - ff2x, ff1y - ff2y)
    if saturate is not None:
        ff /= np.maximum(np.sqrt(ff[..., 0] ** 2 + ff[..., 1] ** 2), saturate)[..., None]
    return ff


def prepare(depth: np.ndarray, threshold: float = 0.03, clamp: float = 1.0,
            saturated: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """(edges, ff) for `simulate`: `depth_edges`, and `force_field` saturated at `threshold` (or the
    seed's raw field with saturated=False); the blur and Sobel are computed once."""
    if not threshold > 0:
        raise ValueError(f"threshold: expected a value > 0, got {threshold}")
    gx, gy = filters.sobel(filters.tent3(depth))
    edges = np.sqrt(gx * gx + gy * gy) >= threshold
    return edges, _force(gx, gy, clamp, threshold if saturated else None)


# --- shared geometry and checks --------------------------------------------------------------------

def _dilate_disc(src: np.ndarray, r: float, p: int, h: int, w: int) -> np.ndarray:
    """(h, w) window at offset p of `src` dilated by the disc of radius r (pixel centres, p >= r):
    row runs first, then rows, 4 floor(r) ORs instead of one per disc pixel."""
    k = int(math.floor(r))
    rows = src[p - k:p + k + h]
    runs = [rows[:, p:p + w]]
    for j in range(1, k + 1):
        runs.append(runs[-1] | rows[:, p - j:p - j + w] | rows[:, p + j:p + j + w])
    out = np.zeros((h, w), bool)
    for dy in range(-k, k + 1):
        kx = max(dx for dx in range(k + 1) if dx * dx + dy * dy <= r * r)
        out |= runs[kx][k + dy:k + dy + h]
    return out


def _check_inputs(edges: np.ndarray, ff: np.ndarray, params: ParticleParams) -> tuple[int, int]:
    if not isinstance(params, ParticleParams):
        raise TypeError(f"params: expected ParticleParams, got {type(params).__name__}")
    shape = np.shape(edges)
    if len(shape) != 2 or shape[0] < 2 or shape[1] < 2:
        raise ValueError(f"edges: expected a 2D [row, col] map of at least 2 x 2, got shape {shape}")
    h, w = shape
    if np.shape(ff) != (h, w, 2):
        raise ValueError(f"ff: expected shape {(h, w, 2)} to match edges, got {np.shape(ff)}")
    ffa = np.asarray(ff)
    # min and max propagate NaN and reach any inf: two reductions, no (H, W, 2) boolean temporary
    if ffa.size and not (np.isfinite(ffa.min()) and np.isfinite(ffa.max())):
        raise ValueError("ff: expected finite values, found NaN or inf")
    return h, w


def _check_sites(sites: Sites | None, h: int, w: int) -> None:
    if sites is None:
        return
    if not isinstance(sites, Sites):
        raise TypeError(f"sites: expected Sites, got {type(sites).__name__}")
    xy = sites.xy
    if len(xy) and not ((xy >= 0.0).all() and (xy[:, 0] < w).all() and (xy[:, 1] < h).all()):
        raise ValueError(f"sites: positions must lie inside the {w} x {h} image")



# --- vectorised simulation -------------------------------------------------------------------------

class _Maps:
    """Padded edge and ink maps shared by all lanes, with flat views for gathers and scatters."""

    def __init__(self, edges: np.ndarray, params: ParticleParams):
        h, w = np.shape(edges)
        self.h, self.w, self.pad = h, w, pad_for(params)
        p = self.pad
        self.wp = w + 2 * p
        self.edge = np.zeros((h + 2 * p, self.wp), bool)
        self.edge[p:p + h, p:p + w] = np.asarray(edges, bool)
        self.ink = np.zeros((h + 2 * p, self.wp), np.float64)
        self.edge_f = self.edge.reshape(-1)
        self.ink_f = self.ink.reshape(-1)
        self.n, self.m = params.n, params.m
        self.n_off = np.array([dy * self.wp + dx for dx, dy in disc_offsets(params.n)], np.int64)
        self.m_off = np.array([dy * self.wp + dx for dx, dy in disc_offsets(params.m)], np.int64)
        self.hw = params.line_width / 2.0
        self.re = params.erase / 2.0
        self.reach = max(self.hw + 0.5, self.re)
        self._scratch: dict = {}  # valid_mask's buffers
        self.inked = False  # whether `draw` ran: before, the ink map is all zero

    def flat(self, ix: np.ndarray, iy: np.ndarray) -> np.ndarray:
        return (iy + self.pad) * self.wp + (ix + self.pad)

    def near_edge(self, c: np.ndarray) -> np.ndarray:
        return self.edge_f[c[:, None] + self.n_off].any(axis=1)

    def near_ink(self, c: np.ndarray) -> np.ndarray:
        return (self.ink_f[c[:, None] + self.m_off] >= LINE_LEVEL).any(axis=1)

    def valid_mask(self, out: np.ndarray | None = None) -> np.ndarray:
        """(H, W) pixels where a start is valid now: dilations by the n and m discs (into `out`)."""
        scratch = self._scratch
        if not scratch:  # reused by every refresh: no large allocations (and page faults) per call
            size, rows = self.edge_f.size, self.h * self.wp
            k = int(math.floor(max(self.n, self.m)))
            scratch.update(line=np.empty(size, bool), near=np.empty(rows, bool), inked=np.empty(rows, bool),
                           runs=[np.empty(size, bool) for _ in range(k)])
        near = self._dilate_flat(self.edge_f, self.n, scratch["near"])
        if self.inked:
            line = np.greater_equal(self.ink_f, LINE_LEVEL, out=scratch["line"])
            inked = self._dilate_flat(line, self.m, scratch["inked"])
            near &= np.logical_not(inked, out=inked)
        p, w = self.pad, self.w
        view = near.reshape(self.h, self.wp)[:, p:p + w]
        if out is None:
            return view.copy()
        np.copyto(out.reshape(self.h, self.w), view)
        return out

    def _dilate_flat(self, src: np.ndarray, r: float, out: np.ndarray) -> np.ndarray:
        """`_dilate_disc` of the flat padded map `src` into `out`, whole padded rows pad .. pad + h (the
        window's columns are exact: pad >= floor(r) + 2, so no run wraps into them), with contiguous 1D
        ORs."""
        k = int(math.floor(r))
        n, wp = src.size, self.wp
        runs = [src[k:n - k]]  # runs[j][q - k] = OR of src[q - j .. q + j]
        for j in range(1, k + 1):
            run = self._scratch["runs"][j - 1][:n - 2 * k]
            np.bitwise_or(runs[-1], src[k - j:n - k - j], out=run)
            run |= src[k + j:n - k + j]
            runs.append(run)
        q0, q1 = self.pad * wp - k, (self.pad + self.h) * wp - k
        np.copyto(out, runs[k][q0:q1])
        for dy in range(1, k + 1):
            kx = max(dx for dx in range(k + 1) if dx * dx + dy * dy <= r * r)
            run = runs[kx]
            out |= run[q0 - dy * wp:q1 - dy * wp]
            out |= run[q0 + dy * wp:q1 + dy * wp]
        return out

    def draw(self, a: np.ndarray, b: np.ndarray) -> None:
        """Ink and erase the segments a[k] -> b[k] (complex positions inside the image)."""
        self.inked = True
        pa = np.ascontiguousarray(a).view(np.float64).reshape(-1, 2)  # (ax, ay)
        pb = np.ascontiguousarray(b).view(np.float64).reshape(-1, 2)
        r = self.reach
        lo = np.minimum(pa, pb)
        lo -= 0.5
        lo -= r
        ij0 = np.ceil(lo, out=lo).astype(np.int64)  # (i0, j0)
        hi = np.maximum(pa, pb)
        hi -= 0.5
        hi += r
        nxy = np.floor(hi, out=hi).astype(np.int64)
        nxy -= ij0
        nxy += 1  # (nx, ny): the box of candidate pixels
        nx = nxy[:, 0]
        cnt = nx * nxy[:, 1]
        sd = b - a  # (bx - ax) + i (by - ay)
        sdx, sdy = sd.real, sd.imag
        l2 = sdx * sdx + sdy * sdy
        l2 = np.where(l2 > 0.0, l2, 1.0)  # a zero-length segment has t = 0 / 1
        seg = np.repeat(np.arange(a.size), cnt)  # segment of each candidate pixel
        qy, qx = np.divmod(np.arange(seg.size) - (np.cumsum(cnt) - cnt)[seg], nx[seg])
        i = ij0[:, 0][seg] + qx
        j = ij0[:, 1][seg] + qy
        ds, az = sd[seg], a[seg]
        dx, dy = ds.real, ds.imag
        ex, ey = (i + 0.5) - az.real, (j + 0.5) - az.imag
        t = np.minimum(np.maximum((ex * dx + ey * dy) / l2[seg], 0.0), 1.0)
        ex = ex - t * dx
        ey = ey - t * dy
        d = np.sqrt(ex * ex + ey * ey)
        c = (j + self.pad) * self.wp + (i + self.pad)
        cov = self.hw + 0.5 - d
        inked = cov > 0.0
        np.maximum.at(self.ink_f, c[inked], np.minimum(cov[inked], 1.0))
        self.edge_f[c[d <= self.re]] = False


def _bilinear_np(fc: np.ndarray, w: int, h: int, p: np.ndarray,
                 consts: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Complex field fc (flat, row-major; complex64 is widened exactly after the gather) sampled
    bilinearly between pixel centres at complex positions p, clamped at the border. A NaN position
    gives NaN (its particle dies anyway). x and y go through the same operations side by side.
    `consts` is `_bilinear_consts(w, h)`, precomputed."""
    umax, imax, corners = consts if consts is not None else _bilinear_consts(w, h)
    uv = np.ascontiguousarray(p).view(np.float64).reshape(-1, 2) - 0.5  # (u, v)
    np.maximum(uv, 0.0, out=uv)
    np.minimum(uv, umax, out=uv)
    ij = uv.astype(np.int64)
    np.maximum(ij, 0, out=ij)
    np.minimum(ij, imax, out=ij)
    t = uv - ij  # (tx, ty)
    b = ij[:, 1] * w
    b += ij[:, 0]
    f = fc[b[:, None] + corners]  # f00, f10, f01, f11
    if f.dtype != np.complex128:
        f = f.astype(np.complex128)
    lo = f[:, :2]
    a = lo + t[:, 1:] * (f[:, 2:] - lo)  # columns i and i + 1, interpolated in y
    a0 = a[:, 0]
    return a0 + t[:, 0] * (a[:, 1] - a0)


def _bilinear_consts(w: int, h: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`_bilinear_np`'s bounds of (u, v) and (i, j), and the flat offsets of the four corners."""
    return np.array((w - 1.0, h - 1.0)), np.array((w - 2, h - 2), np.int64), np.array((0, 1, w, w + 1), np.int64)


class _Dynamics:
    """One RK4 or Euler step for many particles at once (complex positions and velocities)."""

    def __init__(self, ff: np.ndarray, params: ParticleParams):
        h, w = ff.shape[:2]
        self.w, self.h = w, h
        # x + iy; float32 stays complex64 (5 MB instead of a 10 MB copy), widened after each gather
        ffc = np.ascontiguousarray(ff, np.float32 if ff.dtype == np.float32 else np.float64)
        self.fc = ffc.reshape(-1, 2).view(np.complex64 if ffc.dtype == np.float32 else np.complex128)[:, 0]
        self.dt, self.hdt, self.dt6 = params.step, 0.5 * params.step, params.step / 6.0
        self.drag, self.inv_mass, self.rnd = params.drag, 1.0 / params.mass, params.randomness
        self.rk4 = params.integrator == "rk4"
        self.consts = _bilinear_consts(w, h)

    def force(self, fkey: np.ndarray, t: np.ndarray) -> np.ndarray:
        """The random force of step t of the streams fkey (complex)."""
        u = unit_np(fkey[:, None], (2 * t).astype(np.uint64)[:, None] + PAIR)
        return (self.rnd * (2.0 * u - 1.0)).view(np.complex128)[:, 0]

    def acc(self, p: np.ndarray, v: np.ndarray, r: np.ndarray) -> np.ndarray:
        return (_bilinear_np(self.fc, self.w, self.h, p, self.consts) - self.drag * v + r) * self.inv_mass

    def step(self, p: np.ndarray, v: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        dt, hdt = self.dt, self.hdt
        a1 = self.acc(p, v, r)
        if not self.rk4:
            return p + dt * v, v + dt * a1
        p2 = p + hdt * v
        v2 = v + hdt * a1
        a2 = self.acc(p2, v2, r)
        p3 = p + hdt * v2
        v3 = v + hdt * a2
        a3 = self.acc(p3, v3, r)
        p4 = p + dt * v3
        v4 = v + dt * a3
        a4 = self.acc(p4, v4, r)
        return (p + self.dt6 * (v + 2.0 * v2 + 2.0 * v3 + v4),
                v + self.dt6 * (a1 + 2.0 * a2 + 2.0 * a3 + a4))


class _Starts:
    """Start search: stroke k's candidates are `point_py(start key of k, i)`, i = 0, 1, ...; the first
    valid one wins. Candidates are prefiltered with a cached valid mask (a superset: the valid set only
    shrinks), refreshed when more than half of those passing it fail the exact test, which reads the
    maps as they are now; so the answer is the sequential one whatever the cache holds."""

    def __init__(self, maps: _Maps, key: int, retries: int):
        self.maps, self.key, self.retries = maps, key, retries
        self.valid = np.zeros(0, bool)
        self.frac = 1.0
        self.tested = self.failed = 0
        self.stale = True

    def _refresh(self) -> None:
        if self.valid.size == 0:
            self.valid = np.empty(self.maps.h * self.maps.w, bool)
        self.maps.valid_mask(self.valid)
        self.frac = np.count_nonzero(self.valid) / self.valid.size
        self.tested = self.failed = 0
        self.stale = False

    def find(self, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Complex start of each stroke in `ids`, NaN where none of `retries` candidates is valid, and the keys
        of their random forces."""
        maps, w, h = self.maps, self.maps.w, self.maps.h
        skey = stroke_key_np(self.key, ids, 0)
        found = np.full(ids.size, np.nan, np.complex128)
        pending = np.arange(ids.size)
        k0, grow = 0, 1.0
        while pending.size and k0 < self.retries:
            if self.stale or (self.tested > 32 and 2 * self.failed > self.tested):
                self._refresh()
            if self.frac == 0.0:  # nothing valid anywhere: every candidate fails
                break
            cnum = int(min(max(32.0, 2.0 * grow / self.frac), 8192, self.retries - k0))
            grow *= 2.0
            z, flat = point_np(skey[pending][:, None], np.arange(k0, k0 + cnum, dtype=np.uint64), w, h)
            ok = self.valid[flat]
            rows, cols = np.nonzero(ok)
            if rows.size:
                iy, ix = np.divmod(flat[rows, cols], w)
                c = maps.flat(ix, iy)
                bad = ~maps.near_edge(c) | maps.near_ink(c)
                self.tested += rows.size
                self.failed += int(np.count_nonzero(bad))
                ok[rows[bad], cols[bad]] = False
            has = ok.any(axis=1)
            if has.any():
                hit = np.flatnonzero(has)
                first = np.argmax(ok[hit], axis=1)
                found[pending[hit]] = point_of(z[hit, first], w, h)
                pending = pending[~has]
            k0 += cnum
        return found, stroke_key_np(self.key, ids, 1)


class _SiteStarts:
    """Start search over given sites (`Sites`): the next valid sites in their order, tested exactly against the
    maps as they are now; a site found invalid is not tried again (the valid set only shrinks)."""

    def __init__(self, maps: _Maps, key: int, sites: Sites):
        self.maps, self.xy, self.next = maps, sites.xy, 0
        self.fkey = stroke_key_np(key, sites.key, 1)  # as a stroke's forces, the site's key for its number

    def find(self, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        maps, want = self.maps, ids.size
        found = np.full(want, np.nan, np.complex128)
        keys = np.zeros(want, np.uint64)
        got = 0
        while got < want and self.next < len(self.xy):
            lo = self.next
            hi = min(lo + max(64, 4 * (want - got)), len(self.xy))
            xy = self.xy[lo:hi]
            ix = np.minimum(xy[:, 0].astype(np.int64), maps.w - 1)
            iy = np.minimum(xy[:, 1].astype(np.int64), maps.h - 1)
            c = maps.flat(ix, iy)
            hit = np.flatnonzero(maps.near_edge(c) & ~maps.near_ink(c))[:want - got]
            found[got:got + hit.size] = xy[hit, 0] + 1j * xy[hit, 1]
            keys[got:got + hit.size] = self.fkey[lo + hit]
            got += hit.size
            self.next = lo + int(hit[-1]) + 1 if got == want else hi
        return found, keys


def _jit():
    """The compiled sequential sketcher (module `jit`), or None where Numba cannot be imported or finds no writable
    place for its cache (a warning, once: the NumPy engine gives the same output, slower; `fsio.compiled`)."""
    return compiled(__package__, "jit", "particle_sketch: the compiled sketcher is",
                    "the NumPy engine, same output, much slower")


def simulate(edges: np.ndarray, ff: np.ndarray, params: ParticleParams | None = None,
             rng: np.random.Generator | None = None,
             engine: Literal["auto", "jit", "numpy"] = "auto", sites: Sites | None = None) -> SketchResult:
    """Curtis' particle sketcher (see the module docstring).

    batch=1 is the strictly sequential algorithm: `engine` "auto" or "jit" runs it compiled
    (`jit.simulate_sequential`), "numpy" on the lock-step NumPy code with one lane; all give the same
    output as `simulate_python`. batch > 1 runs `params.batch` lanes in lock-step with NumPy.
    `sites`: starts tried in their order instead of random positions (`Sites`); `retries` is then unused.
    """
    params = params if params is not None else ParticleParams()
    h, w = _check_inputs(edges, ff, params)
    _check_sites(sites, h, w)
    if engine not in ("auto", "jit", "numpy"):
        raise ValueError(f"engine: expected 'auto', 'jit' or 'numpy', got {engine!r}")
    key = draw_key(rng)
    if engine != "numpy" and params.batch == 1:
        jit = _jit()
        if jit is None and engine == "jit":
            raise RuntimeError("engine 'jit' needs numba, which could not be imported")
        if jit is not None:
            return jit.simulate_sequential(edges, ff, params, key, sites)
    elif engine == "jit":
        raise ValueError(f"engine 'jit' runs one particle at a time: it needs batch=1, got batch={params.batch}")
    maps = _Maps(edges, params)
    starts: _Starts | _SiteStarts = _Starts(maps, key, params.retries) if sites is None else \
        _SiteStarts(maps, key, sites)
    dyn = _Dynamics(np.asarray(ff), params)
    nb = max(1, min(params.batch, params.strokes))
    group = max(1, nb // 16)
    max_steps = params.max_steps

    wh = np.array((w, h), np.float64)
    pos = np.zeros(nb, np.complex128)
    vel = np.zeros(nb, np.complex128)
    steps = np.zeros(nb, np.int64)
    sid = np.zeros(nb, np.int64)
    fkey = np.zeros(nb, np.uint64)
    active = np.zeros(nb, bool)
    buf = np.zeros((nb, min(max_steps, 63) + 1), np.complex128)  # polylines; grows on demand
    done: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # (stroke ids, points, flat points)
    nxt = launched = total_steps = 0
    stopped = params.strokes == 0
    exhausted = False

    with np.errstate(all="ignore"):  # overflow with extreme params: such particles just die
        while True:
            free = np.flatnonzero(~active)
            # refill idle lanes with the next strokes, in order; in groups of nb / 16 (fewer, larger
            # searches), or at once when every lane is idle (always, with batch 1)
            if not stopped and (free.size >= group or free.size == nb):
                ids = np.arange(nxt, min(nxt + free.size, params.strokes), dtype=np.int64)
                found, keys = starts.find(ids)
                miss = np.flatnonzero(np.isnan(found.real))
                if miss.size:
                    stopped = exhausted = True
                    ids, found, keys = ids[:miss[0]], found[:miss[0]], keys[:miss[0]]
                nxt += ids.size
                launched += ids.size
                stopped = stopped or nxt >= params.strokes
                ln = free[:ids.size]
                pos[ln] = buf[ln, 0] = found
                vel[ln] = 0.0
                steps[ln] = 0
                sid[ln] = ids
                fkey[ln] = keys
                active[ln] = True
            a = np.flatnonzero(active)
            if a.size == 0:
                break
            p, v, t = pos[a], vel[a], steps[a]
            p1, v1 = dyn.step(p, v, dyn.force(fkey[a], t))
            xy1 = np.ascontiguousarray(p1).view(np.float64).reshape(-1, 2)
            inside = (xy1 >= 0.0) & (xy1 < wh)
            ok = inside[:, 0] & inside[:, 1] & np.isfinite(v1)
            if not ok.all():  # a step out of the image (or overflowing) is not drawn; the lane dies
                a, p, t, p1, v1 = a[ok], p[ok], t[ok], p1[ok], v1[ok]
            alive = np.zeros(nb, bool)
            if a.size:
                if t.max() + 1 >= buf.shape[1]:
                    buf = np.concatenate([buf, np.zeros_like(buf)], axis=1)[:, :max_steps + 1]
                # the end test reads the edge map before this step's erasure (module docstring)
                ij = np.ascontiguousarray(p1).view(np.float64).reshape(-1, 2).astype(np.int64)
                alive[a] = maps.near_edge(maps.flat(ij[:, 0], ij[:, 1]))
                maps.draw(p, p1)
                buf[a, t + 1] = p1
                steps[a] = t + 1
                pos[a] = p1
                vel[a] = v1
                total_steps += a.size
                alive[a] &= t + 1 < max_steps
            dead = np.flatnonzero(active & ~alive)
            if dead.size:
                k = steps[dead] + 1
                drawn = k >= 2
                d, k = dead[drawn], k[drawn]
                if d.size:  # their polylines, lane by lane: buf[lane, :k]
                    done.append((sid[d], k, buf[d][np.arange(buf.shape[1]) < k[:, None]]))
                active[dead] = False

    strokes: list[np.ndarray] = []
    if done:  # one float32 array, sliced into the strokes in stroke order
        ids, ks, pts = (np.concatenate(x) for x in zip(*done, strict=True))
        pts = pts.view(np.float64).reshape(-1, 2).astype(np.float32)
        ends = np.cumsum(ks)
        order = np.argsort(ids)
        strokes = [pts[i:j] for i, j in zip((ends - ks)[order].tolist(), ends[order].tolist(), strict=True)]
    p = maps.pad
    return SketchResult(sketch=maps.ink[p:p + h, p:p + w].astype(np.float32),
                        edges=maps.edge[p:p + h, p:p + w].copy(), strokes=strokes,
                        launched=launched, steps=total_steps, exhausted=exhausted)


def particle_path(ff: np.ndarray, starts: np.ndarray, params: ParticleParams | None = None,
                  n_steps: int = 100, key: int = 0) -> np.ndarray:
    """Free trajectories in the force field alone: no edge map, no ink, no end test, no image bounds.

    `starts` is (k, 2) (x, y); returns (k, n_steps + 1, 2) float64. Particle i gets the random forces
    of stroke i of stream `key`, with the same dynamics as `simulate`.
    """
    params = params if params is not None else ParticleParams()
    ffa = np.asarray(ff, np.float64)
    if ffa.ndim != 3 or ffa.shape[2] != 2 or min(ffa.shape[:2]) < 2:
        raise ValueError(f"ff: expected shape (H, W, 2) with H, W >= 2, got {ffa.shape}")
    s = np.asarray(starts, np.float64).reshape(-1, 2)
    dyn = _Dynamics(ffa, params)
    fkey = stroke_key_np(key, np.arange(len(s), dtype=np.int64), 1)
    p = s[:, 0] + 1j * s[:, 1]
    v = np.zeros_like(p)
    out = np.empty((len(s), n_steps + 1), np.complex128)
    out[:, 0] = p
    with np.errstate(all="ignore"):
        for t in range(n_steps):
            p, v = dyn.step(p, v, dyn.force(fkey, np.full(len(s), t, np.int64)))
            out[:, t + 1] = p
    return np.stack([out.real, out.imag], axis=-1)


# --- pure-Python reference -------------------------------------------------------------------------

def simulate_python(edges: np.ndarray, ff: np.ndarray, params: ParticleParams | None = None,
                    rng: np.random.Generator | None = None, sites: Sites | None = None) -> SketchResult:
    """The same algorithm one particle at a time, in plain Python (lists, `math`); the speed reference.

    NumPy is used only to read the inputs into lists and to package the result. Same params, same
    random numbers: the output equals `simulate` with batch=1.
    """
    params = params if params is not None else ParticleParams()
    h, w = _check_inputs(edges, ff, params)
    _check_sites(sites, h, w)
    key = draw_key(rng)
    pad = pad_for(params)
    wp = w + 2 * pad
    edge = [[False] * wp for _ in range(h + 2 * pad)]
    for j, row in enumerate(np.asarray(edges, bool).tolist()):
        edge[j + pad][pad:pad + w] = row
    ink = [[0.0] * wp for _ in range(h + 2 * pad)]
    ffa = np.asarray(ff, np.float64)
    fxl = ffa[..., 0].reshape(-1).tolist()
    fyl = ffa[..., 1].reshape(-1).tolist()
    n_xy, m_xy = disc_offsets(params.n), disc_offsets(params.m)
    hw, re = params.line_width / 2.0, params.erase / 2.0
    reach = max(hw + 0.5, re)
    dt, hdt, dt6 = params.step, 0.5 * params.step, params.step / 6.0
    drag, inv_mass, rnd = params.drag, 1.0 / params.mass, params.randomness
    rk4 = params.integrator == "rk4"

    # explicit loops: about twice as fast as any(<generator>) here
    def near_edge(ix: int, iy: int) -> bool:
        for dx, dy in n_xy:  # noqa: SIM110
            if edge[iy + pad + dy][ix + pad + dx]:
                return True
        return False

    def near_ink(ix: int, iy: int) -> bool:
        for dx, dy in m_xy:  # noqa: SIM110
            if ink[iy + pad + dy][ix + pad + dx] >= LINE_LEVEL:
                return True
        return False

    def sample(x: float, y: float) -> tuple[float, float]:
        u, v = x - 0.5, y - 0.5
        u = (w - 1.0 if u > w - 1.0 else u) if u >= 0.0 else 0.0
        v = (h - 1.0 if v > h - 1.0 else v) if v >= 0.0 else 0.0
        i, j = min(int(u), w - 2), min(int(v), h - 2)
        tx, ty = u - i, v - j
        b = j * w + i
        f00, f10, f01, f11 = fxl[b], fxl[b + 1], fxl[b + w], fxl[b + w + 1]
        a0 = f00 + ty * (f01 - f00)
        a1 = f10 + ty * (f11 - f10)
        fx = a0 + tx * (a1 - a0)
        f00, f10, f01, f11 = fyl[b], fyl[b + 1], fyl[b + w], fyl[b + w + 1]
        a0 = f00 + ty * (f01 - f00)
        a1 = f10 + ty * (f11 - f10)
        return fx, a0 + tx * (a1 - a0)

    def acc(x: float, y: float, vx: float, vy: float, rx: float, ry: float) -> tuple[float, float]:
        fx, fy = sample(x, y)
        return (fx - drag * vx + rx) * inv_mass, (fy - drag * vy + ry) * inv_mass

    def draw(ax: float, ay: float, bx: float, by: float) -> None:
        dx, dy = bx - ax, by - ay
        l2 = dx * dx + dy * dy
        l2 = l2 if l2 > 0.0 else 1.0  # a zero-length segment has t = 0 / 1
        for j in range(math.ceil(min(ay, by) - 0.5 - reach), math.floor(max(ay, by) - 0.5 + reach) + 1):
            for i in range(math.ceil(min(ax, bx) - 0.5 - reach), math.floor(max(ax, bx) - 0.5 + reach) + 1):
                ex, ey = (i + 0.5) - ax, (j + 0.5) - ay
                t = min(max((ex * dx + ey * dy) / l2, 0.0), 1.0)
                ex = ex - t * dx
                ey = ey - t * dy
                d = math.sqrt(ex * ex + ey * ey)
                cov = hw + 0.5 - d
                row = ink[j + pad]
                if cov > 0.0 and min(cov, 1.0) > row[i + pad]:
                    row[i + pad] = min(cov, 1.0)
                if d <= re:
                    edge[j + pad][i + pad] = False

    strokes: list[np.ndarray] = []
    launched = total_steps = 0
    exhausted = False
    site_xy = sites.xy.tolist() if sites is not None else []
    site_keys = sites.key.tolist() if sites is not None else []
    sp = 0  # the next site to try
    for s in range(params.strokes):
        skey, fkey = stroke_key_py(key, s, 0), stroke_key_py(key, s, 1)
        start = None
        if sites is not None:
            while sp < len(site_xy):
                x, y = site_xy[sp]
                fkey = stroke_key_py(key, site_keys[sp], 1)
                sp += 1
                ix, iy = min(int(x), w - 1), min(int(y), h - 1)
                if near_edge(ix, iy) and not near_ink(ix, iy):
                    start = (x, y)
                    break
        else:
            for k in range(params.retries):
                x, y = point_py(skey, k, w, h)
                ix, iy = min(int(x), w - 1), min(int(y), h - 1)
                if near_edge(ix, iy) and not near_ink(ix, iy):
                    start = (x, y)
                    break
        if start is None:
            exhausted = True
            break
        launched += 1
        x, y = start
        vx = vy = 0.0
        path = [(x, y)]
        for t in range(params.max_steps):
            rx = rnd * (2.0 * unit_py(fkey, 2 * t) - 1.0)
            ry = rnd * (2.0 * unit_py(fkey, 2 * t + 1) - 1.0)
            a1x, a1y = acc(x, y, vx, vy, rx, ry)
            if rk4:
                x2, y2 = x + hdt * vx, y + hdt * vy
                v2x, v2y = vx + hdt * a1x, vy + hdt * a1y
                a2x, a2y = acc(x2, y2, v2x, v2y, rx, ry)
                x3, y3 = x + hdt * v2x, y + hdt * v2y
                v3x, v3y = vx + hdt * a2x, vy + hdt * a2y
                a3x, a3y = acc(x3, y3, v3x, v3y, rx, ry)
                x4, y4 = x + dt * v3x, y + dt * v3y
                v4x, v4y = vx + dt * a3x, vy + dt * a3y
                a4x, a4y = acc(x4, y4, v4x, v4y, rx, ry)
                nx = x + dt6 * (vx + 2.0 * v2x + 2.0 * v3x + v4x)
                ny = y + dt6 * (vy + 2.0 * v2y + 2.0 * v3y + v4y)
                nvx = vx + dt6 * (a1x + 2.0 * a2x + 2.0 * a3x + a4x)
                nvy = vy + dt6 * (a1y + 2.0 * a2y + 2.0 * a3y + a4y)
            else:
                nx, ny = x + dt * vx, y + dt * vy
                nvx, nvy = vx + dt * a1x, vy + dt * a1y
            if not (math.isfinite(nvx) and math.isfinite(nvy) and 0.0 <= nx < w and 0.0 <= ny < h):
                break
            alive = near_edge(int(nx), int(ny))
            draw(x, y, nx, ny)
            total_steps += 1
            path.append((nx, ny))
            x, y, vx, vy = nx, ny, nvx, nvy
            if not alive:
                break
        if len(path) >= 2:
            strokes.append(np.array(path, np.float32))

    sketch = np.array([row[pad:pad + w] for row in ink[pad:pad + h]], np.float32)
    remaining = np.array([row[pad:pad + w] for row in edge[pad:pad + h]], bool)
    return SketchResult(sketch=sketch, edges=remaining, strokes=strokes, launched=launched,
                        steps=total_steps, exhausted=exhausted)


# --- measures --------------------------------------------------------------------------------------

def dilate(mask: np.ndarray, r: float) -> np.ndarray:
    """The pixels within r px (pixel centres, Euclidean) of a set pixel of `mask`."""
    k = int(math.floor(r))
    return _dilate_disc(np.pad(mask, k), r, k, *mask.shape)


def coverage_precision(sketch: np.ndarray, edges: np.ndarray, tol: float = 2.0,
                       ink_level: float = 0.1) -> tuple[float, float]:
    """(edge pixels within tol px of ink > ink_level, ink pixels within tol px of an edge pixel).

    Distances are Euclidean between pixel centres. Each is 1.0 when its denominator is empty.
    """
    ink = np.asarray(sketch) > ink_level
    e = np.asarray(edges, bool)
    if ink.shape != e.shape:
        raise ValueError(f"sketch {ink.shape} and edges {e.shape} differ in shape")
    ne, ni = int(e.sum()), int(ink.sum())
    coverage = float((dilate(ink, tol) & e).sum() / ne) if ne else 1.0
    precision = float((dilate(e, tol) & ink).sum() / ni) if ni else 1.0
    return coverage, precision
