"""Pictures side by side with a label under each, for the docs: `python docs/side_by_side.py OUT.png [--columns=N]
LABEL A.png [LABEL B.png ...]` (docs/make_images.sh; default: all in one row)."""

from __future__ import annotations

import sys

from nodegraph.tools.viz import Cell, contact_sheet, read_png, write_png


def main(out: str, pairs: list[str]) -> None:
    columns = None
    if pairs and pairs[0].startswith("--columns="):
        columns, pairs = int(pairs[0].split("=", 1)[1]), pairs[1:]
    if not pairs or len(pairs) % 2:
        raise SystemExit("usage: side_by_side.py OUT.png [--columns=N] LABEL A.png [LABEL B.png ...]")
    cells = [Cell(read_png(path)[..., :3], [label]) for label, path in zip(pairs[::2], pairs[1::2], strict=True)]
    size = max(max(c.image.shape[:2]) for c in cells)
    write_png(out, contact_sheet(cells, cell=size, columns=columns or len(cells)))
    print(f"wrote {out} ({len(cells)} pictures)")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
