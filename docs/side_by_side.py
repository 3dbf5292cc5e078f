"""Pictures side by side with a label under each, for the docs: `python docs/side_by_side.py OUT.png LABEL A.png
[LABEL B.png ...]` (docs/make_images.sh)."""

from __future__ import annotations

import sys

import numpy as np
from PIL import Image

from nodegraph.tools.viz import Cell, contact_sheet


def main(out: str, pairs: list[str]) -> None:
    if not pairs or len(pairs) % 2:
        raise SystemExit("usage: side_by_side.py OUT.png LABEL A.png [LABEL B.png ...]")
    cells = [Cell(np.asarray(Image.open(path).convert("RGB"), np.float32) / 255.0, [label])
             for label, path in zip(pairs[::2], pairs[1::2], strict=True)]
    size = max(max(c.image.shape[:2]) for c in cells)
    img = contact_sheet(cells, cell=size, columns=len(cells))
    Image.fromarray((np.clip(img, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)).save(out, optimize=True)
    print(f"wrote {out} ({len(cells)} pictures)")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
