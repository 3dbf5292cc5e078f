"""When back faces may be culled on a mesh that is not closed (rasterize's `backfaces: auto`, pencil_shade)."""

# cull back faces when holes can show at most this share of the surface (Mesh.hole_share): closed meshes and
# ogre.obj (0.0085; culling changes 1 pixel of 800x800), not the teapot (0.24; 0.5% of pixels)
HOLE_SHARE_CULL = 0.01
