"""What is drawn: scene files, meshes and their readers, the mesh store, glTF, primitives, animation and
keyframes, framing and views. Imports the core leaves only (errors, types, values, fsio, yamlio, schemas,
cache)."""
