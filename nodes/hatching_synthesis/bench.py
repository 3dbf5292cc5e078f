"""Time TAM synthesis and optionally write a contact strip: ``python -m nodes.hatching_synthesis.bench [out.png]``.

The first call in the process is the cold figure; then the best of 3.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from nodes.hatching_synthesis.tam import measured_darkness, synthesize_tam


def main(argv: list[str]) -> None:
    t0 = time.perf_counter()
    tam = synthesize_tam()
    cold = time.perf_counter() - t0
    warm = []
    for _ in range(3):
        t0 = time.perf_counter()
        synthesize_tam()
        warm.append(time.perf_counter() - t0)
    d = measured_darkness(tam)
    print(f"{tam.shape[0]} tones at {tam.shape[1]}x{tam.shape[2]}: cold {cold:.3f} s, warm best {min(warm):.3f} s")
    print(f"darkness {d[0]:.3f} .. {d[-1]:.3f}, max step {np.diff(d).max():.4f}, min step {np.diff(d).min():.4f}")
    if argv:
        import OpenImageIO as oiio

        picks = [0, 2, 4, 8, 12, 16, 20, 24, 28, tam.shape[0] - 1]
        strip = np.concatenate([np.pad(tam[k], ((0, 0), (0, 4)), constant_values=1.0) for k in picks], axis=1)
        out = oiio.ImageOutput.create(argv[0])
        if out is None:
            raise SystemExit(f"cannot write {argv[0]}: {oiio.geterror()}")
        out.open(argv[0], oiio.ImageSpec(strip.shape[1], strip.shape[0], 1, "uint8"))
        out.write_image(np.ascontiguousarray(np.round(strip * 255).astype(np.uint8)[:, :, None]))
        out.close()
        print(f"wrote {argv[0]} (tones {picks})")


if __name__ == "__main__":
    main(sys.argv[1:])
