"""The input files skelcore reads, by suffix (skelcore.readers has a reader for each): a module of its own, so
that the command line names them without importing the readers."""

POINT_FORMATS = (".ply", ".pcd", ".xyz", ".pts", ".txt", ".off", ".las", ".laz")
MESH_FORMATS = (".obj", ".stl", ".glb", ".gltf")
FORMATS = POINT_FORMATS + MESH_FORMATS
Y_UP_FORMATS = (".glb", ".gltf")  # glTF 2.0 fixes +Y as up; the others say nothing of it
