"""The input files skelcore reads, by suffix (skelcore.readers has a reader for each): a module of its own, so
that the command line names them without importing the readers."""

LASER_FORMATS = (".las", ".laz")  # laspy's: a header with the point count, points with named dimensions
POINT_FORMATS = (".ply", ".pcd", ".xyz", ".pts", ".txt", ".off", *LASER_FORMATS)
GLTF_FORMATS = (".glb", ".gltf")  # a scene: meshes and point primitives placed by its transforms
MESH_FORMATS = (".obj", ".stl", *GLTF_FORMATS)
FORMATS = POINT_FORMATS + MESH_FORMATS
Y_UP_FORMATS = GLTF_FORMATS  # glTF 2.0 fixes +Y as up; the others say nothing of it
