#!/usr/bin/env bash
# Rebuild the pictures in README.md and docs/ that show the shipped pipelines at their defaults (run from the
# repository root, with ../shared/meshes beside it; spot.obj is seen from its face, where the framing finds it).
# Pictures made to show one change side by side (field_*, lines_*, sizes_*) are made by the commands their
# sections name, not here.
set -euo pipefail
cd "$(dirname "$0")/.."
sg=${SKETCHGRAPH:-sketchgraph}
py=${PYTHON:-python}  # with pygltflib (the project's environment): the film shot
m=../shared/meshes
i=docs/images
$sg run nienhaus_sketchy -o $i/nienhaus_sketchy.png
$sg run pipelines/repeated_edges.yaml --size 560x560 -o $i/repeated_edges.png
$sg run pipelines/chalk.yaml --size 560x560 -o $i/chalk.png
$sg run pipelines/object_space_uncertainty.yaml --size 560x560 -o $i/object_space_uncertainty.png
$sg run pipelines/object_space_uncertainty.yaml --scene $m/spot.obj --size 560x560 -o $i/object_space_uncertainty_spot.png
$sg run pipelines/pencil.yaml --size 480x480 -o $i/pencil_torus.png
$sg run pipelines/pencil.yaml --scene $m/stanford-bunny.obj --size 480x480 -o $i/pencil_bunny.png
$sg run pipelines/pencil_contours.yaml --scene $m/fandisk.obj --size 480x480 -o $i/pencil_contours_fandisk.png
$sg run pipelines/loose_and_sketchy.yaml -o $i/loose_and_sketchy.png
$sg run pipelines/loose_and_sketchy.yaml --scene $m/spot.obj -o $i/loose_and_sketchy_spot.png
$sg run pipelines/loose_and_sketchy_shaded.yaml -o $i/loose_and_sketchy_shaded.png
$sg run pipelines/loose_and_sketchy_shaded.yaml --scene $m/spot.obj -o $i/loose_and_sketchy_shaded_spot.png
# sketchy_strokes beside the pixel pipeline it restates (docs/strokes.md)
mkdir -p out/strokes
$sg run sketchy_strokes --scene $m/spot.obj --size 384x384 -o out/strokes/spot.png
$sg run nienhaus_sketchy --scene $m/spot.obj --size 384x384 -o out/strokes/spot_pixels.png
$sg run sketchy_strokes --scene builtin:cloister --size 384x384 -o out/strokes/cloister.png
$py docs/side_by_side.py $i/sketchy_strokes.png "sketchy_strokes, spot" out/strokes/spot.png \
    "nienhaus_sketchy, spot (pixels)" out/strokes/spot_pixels.png "sketchy_strokes, builtin:cloister" \
    out/strokes/cloister.png
# plotter_lines' straight hatching on flat faces, and the same without it (docs/strokes.md)
$sg run plotter_lines --scene builtin:cloister --size 400x400 -o out/strokes/plot_cloister.png
$sg run plotter_lines --scene builtin:cloister --size 400x400 --set hatch.planes=false -o out/strokes/plot_cloister_off.png
$sg run plotter_lines --scene $m/fandisk.obj --size 400x400 -o out/strokes/plot_fandisk.png
$py docs/side_by_side.py $i/strokes_planes.png "plotter_lines, builtin:cloister" out/strokes/plot_cloister.png \
    "planes: false" out/strokes/plot_cloister_off.png "plotter_lines, fandisk" out/strokes/plot_fandisk.png
# the outline of coarse meshes (mesh_lines `outline`, docs/strokes.md): low-poly rocks made in code (the tests')
$py -c "from pathlib import Path; from tests.nodes.mesh_lines.test_mesh_lines_outline import rock
rock(Path('out/strokes/rock80.obj'), 33, 1, 0.1, True, 250); rock(Path('out/strokes/rock320.obj'), 35, 2, 0.08, True, 160)"
for r in rock80 rock320; do
    $sg run plotter_lines --scene out/strokes/$r.obj --size 400x400 -o out/strokes/$r.png
    $sg run plotter_lines --scene out/strokes/$r.obj --size 400x400 --set lines.outline=0 -o out/strokes/${r}_off.png
done
$py docs/side_by_side.py $i/strokes_outline.png "plotter_lines, 80-face rock" out/strokes/rock80.png \
    "lines.outline: 0" out/strokes/rock80_off.png "320-face rock" out/strokes/rock320.png \
    "lines.outline: 0" out/strokes/rock320_off.png
# intersection lines (mesh_lines `intersections`, docs/strokes.md): the teapot's spout and suzanne's eyes
for n in teapot suzanne; do
    $sg run plotter_lines --scene $m/$n.obj --size 400x400 -o out/strokes/x_$n.png
    $sg run plotter_lines --scene $m/$n.obj --size 400x400 --set lines.intersections=false -o out/strokes/x_${n}_off.png
done
$py docs/side_by_side.py $i/strokes_intersections.png "plotter_lines, teapot" out/strokes/x_teapot.png \
    "lines.intersections: false" out/strokes/x_teapot_off.png "suzanne" out/strokes/x_suzanne.png \
    "lines.intersections: false" out/strokes/x_suzanne_off.png
# the short film (README, docs/animation.md)
$py examples/film/make_shot.py out/shot
$sg run pencil --scene out/shot/shot.yaml --fps 12 --size 288x288 \
    --set distortion.hold=2 --set contour.hold=2 -o $i/film_pencil.gif
$sg run object_space_uncertainty --scene out/shot/shot.yaml --frames 0:48:4 --size 240x240 -o out/shot/osu/f_####.png
$py examples/film/make_shot.py sheet $i/film_object_space.png out/shot/osu/f_*.png
