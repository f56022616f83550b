"""The direct PLY/XYZ readers (skelcore.readers) agree with trimesh and fall back on anything unusual."""
import numpy as np
import pytest
import trimesh

from skelcore import io, readers, text_clouds


@pytest.fixture
def cloud():
    rng = np.random.default_rng(0)
    return rng.random((500, 3)), rng.integers(0, 500, (300, 3))


@pytest.mark.parametrize("encoding", ["binary", "ascii"])
@pytest.mark.parametrize("with_faces", [False, True])
def test_ply_matches_trimesh(tmp_path, cloud, encoding, with_faces):
    points, faces = cloud
    geometry = trimesh.Trimesh(points, faces, process=False) if with_faces else trimesh.PointCloud(points)
    path = tmp_path / "c.ply"
    path.write_bytes(trimesh.exchange.ply.export_ply(geometry, encoding=encoding))
    fast = readers.read_ply(path)
    if encoding == "ascii" and with_faces:
        assert fast is None  # ASCII faces: left to trimesh
    else:
        np.testing.assert_allclose(fast[0], points, atol=1e-6)  # trimesh writes float32
        assert (fast[1] is None) if not with_faces else np.array_equal(fast[1], faces)
    loaded = io.load(path)
    assert loaded.points.shape == points.shape and (loaded.faces is not None) == with_faces


def test_big_endian_and_extra_properties(tmp_path, cloud):
    points = cloud[0]
    header = ("ply\nformat binary_big_endian 1.0\ncomment made here\nelement vertex 500\nproperty double x\n"
              "property double y\nproperty double z\nproperty uchar red\nend_header\n")
    table = np.zeros(500, dtype=[("x", ">f8"), ("y", ">f8"), ("z", ">f8"), ("red", "u1")])
    table["x"], table["y"], table["z"] = points.T
    path = tmp_path / "c.ply"
    path.write_bytes(header.encode() + table.tobytes())
    np.testing.assert_allclose(readers.read_ply(path)[0], points)


@pytest.mark.parametrize("header", [
    "ply\nformat binary_little_endian 1.0\nelement vertex 10\nproperty float x\nproperty float y\nend_header\n",
    "ply\nformat binary_little_endian 1.0\nelement camera 1\nproperty float x\nelement vertex 10\nend_header\n",
    "ply\nformat binary_little_endian 1.0\nelement vertex 1000\nproperty float x\nproperty float y\n"
    "property float z\nend_header\n",  # truncated body
    "not a ply at all\n",
])
def test_unusual_ply_falls_back(tmp_path, header):
    path = tmp_path / "c.ply"
    path.write_bytes(header.encode() + bytes(12))
    assert readers.read_ply(path) is None


def test_xyz_equal_lines_and_commas(tmp_path, cloud):
    points = cloud[0]
    np.savetxt(tmp_path / "a.xyz", np.column_stack([points, points[:, :1]]))
    np.testing.assert_allclose(readers.read_text(tmp_path / "a.xyz"), points)
    np.savetxt(tmp_path / "b.txt", points, delimiter=",")
    np.testing.assert_allclose(readers.read_text(tmp_path / "b.txt"), points)


@pytest.mark.parametrize("text, rows", [
    ("1 2 3\n4 5 6 7\n8 9 10\n", [[1, 2, 3], [4, 5, 6], [8, 9, 10]]),  # unequal lines: line by line
    ("# comment\n1 2 3\n// another\n4 5 6\n", [[1, 2, 3], [4, 5, 6]]),
    ("3\n1 2 3\n4 5 6\n7 8 9\n", [[1, 2, 3], [4, 5, 6], [7, 8, 9]]),  # a .pts count
])
def test_uneven_or_commented_text_is_read_line_by_line(tmp_path, text, rows):
    path = tmp_path / "c.xyz"
    path.write_text(text)
    np.testing.assert_array_equal(readers.read_text(path), rows)


@pytest.mark.parametrize("text, words", [("1 2 3\n4 5\n6 7 8\n", "line 2 has fewer than 3"),
                                         ("1 2 3\n1 2 x\n4 5 6 7\n", "line 2 holds '1 2 x', not three numbers"),
                                         ("x y z\n", "holds no points"),
                                         ("just some words\nno numbers here\n", r"no line holds three numbers \(x y z\)")])
def test_text_that_is_not_points_is_refused_naming_the_line(tmp_path, text, words):
    from skelcore.errors import InputError

    path = tmp_path / "c.xyz"
    path.write_text(text)
    with pytest.raises(InputError, match=words):
        readers.read_text(path)


@pytest.mark.parametrize("name, text", [
    ("bom.xyz", "\ufeff{rows}"),
    ("names.xyz", "x y z\n{rows}"),
    ("comment_names.xyz", "# x y z\n{rows}"),
    ("quoted_names.csv.txt", '"X","Y","Z"\r\n{rows}'),
    ("bom_names.txt", "\ufeffx;y;z\n{rows}"),
    ("semicolons.txt", "{semicolons}"),
    ("semicolons_decimal_commas.txt", "x;y;z\n{decimal}"),
    ("commas.pts", "{commas}"),
])
def test_text_clouds_as_their_writers_make_them_are_read(tmp_path, cloud, name, text):
    points = np.round(cloud[0], 6)
    table = [[f"{v:.6f}" for v in row] for row in points]
    content = text.format(rows="\n".join(" ".join(row) for row in table),
                          semicolons="\n".join("; ".join(row) for row in table),
                          decimal="\n".join(";".join(v.replace(".", ",") for v in row) for row in table),
                          commas="\n".join(",".join(row) for row in table))
    path = tmp_path / name
    path.write_bytes(content.encode("utf-8"))
    np.testing.assert_array_equal(io.load(path).points, points)


def test_obj_and_off_of_vertices_only_are_point_clouds(tmp_path, cloud):
    points = cloud[0]
    obj = tmp_path / "points.obj"
    obj.write_text("# scan\n" + "".join(f"v {x!r} {y!r} {z!r}\nvn 0 0 1\n" for x, y, z in points.tolist()))
    loaded = io.load(obj)
    np.testing.assert_array_equal(loaded.points, points)
    assert loaded.faces is None
    off = tmp_path / "points.off"
    off.write_text(f"OFF\n{len(points)} 0 0\n" + "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in points.tolist()))
    np.testing.assert_array_equal(io.load(off).points, points)
    off.write_bytes(b"\xef\xbb\xbf" + off.read_bytes())  # a byte order mark before the OFF keyword
    np.testing.assert_array_equal(io.load(off).points, points)
    mesh = tmp_path / "mesh.obj"  # with faces it is a mesh, read by trimesh
    mesh.write_text(obj.read_text() + "".join(f"f 1 {i} {i + 1}\n" for i in range(2, len(points))))
    assert len(io.load(mesh, sample=0).faces) == len(points) - 2


def test_an_off_file_of_bare_rows_is_parsed_once(tmp_path, cloud, monkeypatch):
    points = cloud[0]
    path = tmp_path / "rows.off"
    path.write_text("".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in points.tolist()))
    parses = []
    equal_rows = text_clouds._equal_rows
    monkeypatch.setattr(text_clouds, "_equal_rows", lambda *args: parses.append(1) or equal_rows(*args))
    monkeypatch.setattr(text_clouds, "_rows", lambda *args: pytest.fail("parsed line by line as well"))
    np.testing.assert_array_equal(io.load(path).points, points)
    assert parses == [1]


def test_an_ascii_ply_whose_rows_disagree_with_its_header_is_refused(tmp_path):
    from skelcore.errors import InputError
    from skelcore.io import load

    rows = "\n".join(" ".join(map(str, p)) for p in np.random.default_rng(0).random((100, 3)))
    for promised in (80, 120):
        path = tmp_path / f"promised{promised}.ply"
        path.write_text(f"ply\nformat ascii 1.0\nelement vertex {promised}\nproperty float x\nproperty float y\n"
                        f"property float z\nend_header\n{rows}\n")
        with pytest.raises(InputError, match=f"promises {promised} vertices"):
            load(path)


def test_decimal_commas_are_refused_not_read_as_more_columns(tmp_path):
    from skelcore.errors import InputError
    from skelcore.io import load

    points = np.random.default_rng(1).random((50, 3))
    path = tmp_path / "comma.xyz"
    path.write_text("\n".join(" ".join(f"{v:.6f}".replace(".", ",") for v in p) for p in points))
    with pytest.raises(InputError, match="decimal commas"):
        load(path)
    path.write_text("\n".join(",".join(f"{v:.6f}" for v in p) for p in points))  # commas between numbers: read
    np.testing.assert_allclose(load(path).points, points, atol=1e-6)


def test_a_binary_ply_holding_more_vertices_than_its_header_counts_is_refused(tmp_path, cloud):
    """Its header said 400 of its 500 vertices: the 100 after them were left out without a word. A trailing
    newline, no whole vertex, is read as before."""
    from skelcore.errors import InputError

    points = cloud[0].astype("<f4")
    header = "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\n" \
             "property float z\nend_header\n"
    path = tmp_path / "miscounted.ply"
    path.write_bytes(header.format(400).encode() + points.tobytes())
    with pytest.raises(InputError, match=r"^miscounted.ply: the header promises 400 vertices, the file holds 1,200 "
                                         r"bytes more after them \(room for 100 more vertices\): its counts are wrong$"):
        io.load(path)
    path.write_bytes(header.format(500).encode() + points.tobytes() + b"\n")
    assert len(readers.read_ply(path)[0]) == 500


def _pcd(path, fields, data: str, body: bytes, points: int) -> None:
    """A PCD file of `fields` [(name, size, type, count)]."""
    names, sizes, types, counts = zip(*fields)
    header = (f"# .PCD v0.7\nVERSION 0.7\nFIELDS {' '.join(names)}\nSIZE {' '.join(map(str, sizes))}\n"
              f"TYPE {' '.join(types)}\nCOUNT {' '.join(map(str, counts))}\nWIDTH {points}\nHEIGHT 1\n"
              f"VIEWPOINT 0 0 0 1 0 0 0\nPOINTS {points}\nDATA {data}\n")
    path.write_bytes(header.encode() + body)


@pytest.mark.parametrize("kinds", [("<f8", "<f8", "<f8"), ("<f4", "<f4", "<f8"), ("<i2", "<i2", "<i2")])
def test_binary_pcd_fields_of_every_width_are_read_as_written(tmp_path, cloud, kinds):
    """open3d read 8-byte binary fields as zeros: z of F4 F4 F8 came out 0 and the run went on with a flat cloud;
    each field is now read as its SIZE and TYPE say, beside an rgb and a normal of three values."""
    values = np.round(cloud[0] * 100) if kinds[0] == "<i2" else cloud[0]
    layout = np.dtype([("x", kinds[0]), ("rgb", "<u4"), ("y", kinds[1]), ("normal", "<f4", (3,)), ("z", kinds[2])])
    records = np.zeros(len(values), layout)
    records["x"], records["y"], records["z"] = values.T
    fields = [("x", int(kinds[0][-1]), kinds[0][1].upper(), 1), ("rgb", 4, "U", 1),
              ("y", int(kinds[1][-1]), kinds[1][1].upper(), 1), ("normal", 4, "F", 3),
              ("z", int(kinds[2][-1]), kinds[2][1].upper(), 1)]
    path = tmp_path / "cloud.pcd"
    _pcd(path, fields, "binary", records.tobytes(), len(values))
    expected = np.column_stack([records["x"], records["y"], records["z"]]).astype(np.float64)
    np.testing.assert_array_equal(readers.READERS[".pcd"](path)[0], expected)


def test_ascii_pcd_is_read_by_its_fields_and_refused_when_its_rows_fall_short(tmp_path, cloud):
    path, cloud = tmp_path / "cloud.pcd", cloud[0]
    rows = "".join(f"{i} {x:.17g} {y:.17g} {z:.17g}\n" for i, (x, y, z) in enumerate(cloud))
    _pcd(path, [("id", 4, "U", 1), ("x", 8, "F", 1), ("y", 8, "F", 1), ("z", 8, "F", 1)], "ascii", rows.encode(),
         len(cloud))
    np.testing.assert_array_equal(readers.READERS[".pcd"](path)[0], cloud)
    xyz = "".join(f"{x:.17g} {y:.17g} {z:.17g}\n" for x, y, z in cloud)
    _pcd(path, [("x", 4, "F", 2), ("y", 4, "F", 1), ("z", 4, "F", 1)], "ascii", xyz.encode(), len(cloud))
    with pytest.raises(io.InputError, match="points of 4"):  # open3d read 3/4 of the points, garbled
        readers.READERS[".pcd"](path)
    _pcd(path, [("x", 8, "F", 1), ("y", 8, "F", 1), ("z", 8, "F", 1)], "binary_compressed", b"\0" * 16, len(cloud))
    with pytest.raises(io.InputError, match="8-byte coordinates is not supported"):
        readers.READERS[".pcd"](path)


def test_an_off_face_whose_count_exceeds_its_indices_says_so(tmp_path):
    """A face line "1000000000 0 1 2" was said to have "3 vertex indices; a face needs at least 3"."""
    path = tmp_path / "faces.off"
    path.write_text("OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1000000000 0 1 2\n")
    with pytest.raises(io.InputError, match="counts 1000000000 vertex indices but lists 3"):
        readers.READERS[".off"](path)


def test_a_glb_point_cloud_is_read_where_its_scene_places_it(tmp_path):
    """A scan exported as a glTF POINTS primitive has no triangles: it was refused as "no mesh geometry"."""
    points = np.random.default_rng(0).random((300, 3))
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.PointCloud(points), transform=trimesh.transformations.translation_matrix([5, 0, 0]))
    scene.export(tmp_path / "scan.glb")
    read = io.load(tmp_path / "scan.glb").points
    assert np.allclose(np.sort(read, axis=0), np.sort(points + [5, 0, 0], axis=0), atol=1e-6)


def test_a_glb_holding_a_mesh_and_points_reads_the_mesh_and_says_the_points_are_left_out(tmp_path):
    """They were dropped without a word."""
    mesh = trimesh.creation.icosphere(subdivisions=3)
    scene = trimesh.Scene()
    scene.add_geometry(mesh, transform=trimesh.transformations.translation_matrix([0, 2, 0]))
    scene.add_geometry(trimesh.PointCloud(np.random.default_rng(0).random((50, 3))))
    scene.export(tmp_path / "both.glb")
    cloud = io.load(tmp_path / "both.glb", sample=0)
    assert len(cloud.faces) == len(mesh.faces)
    assert np.allclose(np.sort(cloud.points, axis=0), np.sort(mesh.vertices + [0, 2, 0], axis=0), atol=1e-6)
    assert "glTF POINTS primitive (50 points) is left out" in cloud.notes[0]


def _write_las(path, points, scale=0.001):
    import laspy

    header = laspy.LasHeader(point_format=3, version="1.2")
    header.offsets, header.scales = points.min(axis=0), [scale] * 3
    las = laspy.LasData(header)
    las.x, las.y, las.z = points.T
    las.write(path)


@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_a_laser_scan_in_las_or_laz_is_read_in_its_map_coordinates_and_skeletonised(tmp_path, suffix):
    """Airborne and terrestrial scans (trees, above all) come as LAS or LAZ: they were refused as an unknown
    format. A scan in UTM metres keeps its coordinates to the file's millimetre and keeps the torus' loop."""
    import skelcore
    from skelcore.shapes import make_shape

    torus = make_shape("torus", 4000).points * 5.0 + [480_000.0, 5_400_000.0, 300.0]
    _write_las(tmp_path / f"scan{suffix}", torus)
    cloud = io.load(tmp_path / f"scan{suffix}")
    assert cloud.points.shape == torus.shape and np.abs(cloud.points - torus).max() <= 0.0006
    assert skelcore.skeletonize(tmp_path / f"scan{suffix}").skeleton.topology()["cycles"] == 1


def test_a_las_header_counting_more_points_than_the_budget_is_refused_before_reading(tmp_path):
    _write_las(tmp_path / "big.las", np.random.default_rng(0).random((5000, 3)))
    with pytest.raises(io.InputError, match="may hold up to 5,000 points, too many to read"):
        io.load(tmp_path / "big.las", budget=1000)


def test_a_file_named_las_that_is_not_one_is_refused_in_one_line(tmp_path):
    (tmp_path / "scan.las").write_bytes(b"ply\nformat ascii 1.0\n")
    with pytest.raises(io.InputError, match=r"scan.las: cannot parse as LAS") as error:
        io.load(tmp_path / "scan.las")
    assert "\n" not in str(error.value)


def test_every_format_the_loader_accepts_has_a_reader():
    from skelcore.formats import FORMATS

    assert sorted(readers.READERS) == sorted(FORMATS)


def test_a_gltf_is_read_with_its_buffers_beside_it_or_embedded_and_a_missing_one_is_named(tmp_path):
    """glTF's text form was refused as an unknown format."""
    torus = trimesh.creation.torus(1.0, 0.3)
    scene = trimesh.Scene()
    scene.add_geometry(torus, transform=trimesh.transformations.translation_matrix([0, 0, 5]))
    for name, data in scene.export(file_type="gltf").items():  # model.gltf and its .bin buffers
        (tmp_path / name).write_bytes(data)
    embedded = trimesh.exchange.gltf.export_gltf(scene, embed_buffers=True)["model.gltf"]
    (tmp_path / "embedded.gltf").write_bytes(embedded)
    for name in ("model.gltf", "embedded.gltf"):
        cloud = io.load(tmp_path / name, sample=0)
        assert len(cloud.faces) == len(torus.faces)
        assert np.allclose(np.sort(cloud.points, axis=0), np.sort(torus.vertices + [0, 0, 5], axis=0), atol=1e-6)
    alone = tmp_path / "alone"
    alone.mkdir()
    (alone / "model.gltf").write_bytes((tmp_path / "model.gltf").read_bytes())
    with pytest.raises(io.InputError, match=r"model.gltf: its buffer file 'gltf_buffer_0.bin' is missing"):
        io.load(alone / "model.gltf")


def test_a_las_point_dimension_gives_the_labels(tmp_path):
    """A scan's classification, or a forestry scan's tree ids in an extra dimension, weigh its parts as a PLY's
    label property does; a dimension it lacks is named with those it has."""
    import laspy

    points = np.random.default_rng(0).random((300, 3)) + [480_000.0, 5_400_000.0, 0.0]
    header = laspy.LasHeader(point_format=3, version="1.4")
    header.offsets, header.scales = points.min(axis=0), [0.001] * 3
    header.add_extra_dim(laspy.ExtraBytesParams(name="treeID", type=np.int32))
    las = laspy.LasData(header)
    las.x, las.y, las.z = points.T
    las.classification = np.where(points[:, 2] > 0.5, 5, 2).astype(np.uint8)
    las.treeID = np.arange(300) % 3
    las.write(tmp_path / "scan.laz")
    cloud = io.load(tmp_path / "scan.laz", labels="classification")
    np.testing.assert_array_equal(cloud.labels, np.where(points[:, 2] > 0.5, 5, 2))
    np.testing.assert_array_equal(io.load(tmp_path / "scan.laz", labels="treeid").labels, np.arange(300) % 3)
    with pytest.raises(io.InputError, match=r"no point dimension 'species' \(has: X, Y, Z, .*treeID\)"):
        io.load(tmp_path / "scan.laz", labels="species")
