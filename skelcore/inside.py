"""Which points lie inside a closed surface given by samples with outward normals (the boundedness test
X_k << X_o of the stability metrics), and dense outward-oriented samples of a mesh's surface.

A point cloud is its own sample (with MST-oriented PCA normals, skelcore.normals, whose parts facing away from
the open space are then turned, skelcore.open_space; a single view's signed to face its viewer instead,
skelcore.single_view); a mesh is sampled densely with its face normals after
trimesh's winding repair, each body turned outward. Away from a band around the
surface this agrees with the winding number of a closed mesh: the nearest sample lies within half a sample
spacing of the nearest surface point, whose normal gives the exact side.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, minimum_spanning_tree
from scipy.spatial import cKDTree

from .errors import InputError
from .neighbours import knn
from .normals import orient_outward, pca_features, tangent_edges
from .open_space import facing_open_space
from .regions import border_labels, dilated, label_regions
from .single_view import RIM_NEIGHBOURS, facing_viewer

SURFACE_NEIGHBOURS = 10  # PCA neighbourhood of a cloud's own surface normals (of_cloud)
MAX_CELLS = 2_000_000  # cells of an inside test's grid, about at most (a run's take a few hundred thousand)
SPLIT = -2  # a cell of a region whose votes split: judged by its centre when a point first falls in it
BORDER_LEAK = 0.02  # inside votes of a region touching the grid's border above which it is judged cell by cell


@dataclass(frozen=True)
class InsideTest:
    """Which points lie inside a closed surface given by samples with outward normals.

    The side of a point is that of the nearest sample's normal, (p - s).n <= band counting as inside.
    Deep inside a shape that nearest-sample query is slow (a point on a tube's axis is almost as far from
    a whole ring of samples), so it is only made near the surface: a voxel grid of cell `size` marks the
    cells holding a sample, dilated by one, as the shell; every connected region of empty cells lies on
    one side of the surface and takes the side most of its cells next to the shell vote for (regions
    touching the grid's border are outside). A region whose votes split (a surface with holes joins
    inside and outside) is judged cell by cell, each cell by its centre once a point falls in it (an open
    sheet such as a leaf splits the whole outside: judging its 2M cells at once took 3.3 s, judging those a
    run's points reach takes a few hundredths). A region touching the border is judged so as soon
    as more than BORDER_LEAK of its votes say inside: the outside of a closed surface votes inside only
    where a few normals are misoriented (0-0.2% measured), while through an open end (a scan cut off at the
    neck or the feet, a mesh with holes) the whole inside joins it (4-36% of its votes on cloudcontr's data).
    """
    origin: np.ndarray  # (3,) corner of the grid
    size: float  # cell edge
    cells: np.ndarray  # (nx,ny,nz) int8: 1 inside, 0 outside, -1 shell (decided per point), SPLIT (by centre)
    samples: np.ndarray
    normals: np.ndarray
    tree: cKDTree
    band: float
    spacing: np.ndarray  # each sample's distance to its nearest other sample
    undecided: np.ndarray  # (nx,ny,nz) bool: the cells made SPLIT, whether or not a point has resolved them since
    single_view: bool = False  # a cloud read as one view, its normals signed to face the viewer (of_cloud)

    @classmethod
    def from_samples(cls, samples: np.ndarray, normals: np.ndarray, band: float, tree: cKDTree | None = None,
                     spacing: np.ndarray | None = None, surface_edges: tuple[np.ndarray, np.ndarray] | None = None
                     ) -> "InsideTest":
        """tree, spacing: a cKDTree over `samples` and each sample's distance to its nearest other sample, when
        the caller has them (used only when every sample has a normal). surface_edges: (rows, cols) of the edges
        between samples the normals' orientation was propagated along (a cloud's; skelcore.normals.tangent_edges),
        so that a part may face inward as a whole: such parts are turned to face the open space
        (skelcore.open_space)."""
        keep = np.linalg.norm(np.nan_to_num(normals), axis=1) > 0.5  # mesh vertices without faces have none
        if keep.sum() < 4:
            raise InputError("no part of the cloud is large enough for its extent to have a surface normal "
                             "(small clusters far apart?); skeletonise the parts one by one")
        propagated = (samples, normals)  # as the edges index them (samples without a normal never vote)
        if tree is None or spacing is None or not keep.all():
            samples, normals = samples[keep], normals[keep]
            tree = cKDTree(samples)
            spacing = tree.query(samples, k=2, workers=-1)[0][:, 1]
        extent = np.ptp(samples, axis=0)
        size = _cell_size(extent, spacing, band)
        origin = samples.min(axis=0) - 2.5 * size
        shape = tuple(np.ceil(extent / size).astype(int) + 6)
        occupied = np.zeros(shape, bool)
        occupied[tuple(np.floor((samples - origin) / size).astype(int).T)] = True
        shell = dilated(occupied)
        regions, count = label_regions(~shell)
        border = border_labels(regions)
        voters = ~shell & dilated(shell)
        # Each voter's offset from its nearest sample, read along that sample's normal (side_of), once turned.
        centres = origin + (np.argwhere(voters) + 0.5) * size
        nearest = tree.query(centres, workers=-1)[1]
        offsets = centres - samples[nearest]
        if surface_edges is not None:
            open_space = np.isin(regions, border[border > 0])
            beside = open_space[voters]
            normals = facing_open_space(*propagated, surface_edges, origin, size, open_space, offsets[beside],
                                        np.flatnonzero(keep)[nearest[beside]])[keep]
        test = cls(origin, size, np.full(shape, -1, np.int8), samples, normals, tree, band, spacing,
                   np.zeros(shape, bool))
        votes = np.einsum("ij,ij->i", offsets, normals[nearest]) <= 0
        inside_share = (np.bincount(regions[voters], votes, count + 1)
                        / np.maximum(np.bincount(regions[voters], minlength=count + 1), 1))
        side = (inside_share > 0.5).astype(np.int8)
        side[border] = 0
        side[0] = -1  # label 0 is the shell
        mixed = (inside_share > 0.25) & (inside_share < 0.75)
        mixed[border] |= inside_share[border] > BORDER_LEAK
        mixed[0] = False
        cells = side[regions]
        cells[mixed[regions]] = SPLIT
        test.cells[...] = cells
        test.undecided[...] = cells == SPLIT
        return test

    @classmethod
    def of_cloud(cls, samples: np.ndarray, band: float, collapsed: float, tree: cKDTree | None = None
                 ) -> "InsideTest":
        """The inside test of a point cloud taken as its own surface sample. Its normals are PCA normals of
        SURFACE_NEIGHBOURS neighbours (k neighbours wrap around a thin tube, whose PCA normal then runs along its
        axis, so a small neighbourhood gives them), oriented outward along a minimum spanning tree and turned part
        by part to face the open space (skelcore.open_space), or if the cloud is a single view, signed to face its
        viewer (skelcore.single_view); collapsed: the neighbourhood size below which a point
        has no normal. tree: a cKDTree over `samples`, if made."""
        tree = cKDTree(samples) if tree is None else tree
        # One kNN query serves the normals, their orientation, the single view's rim and the test's spacing.
        distances, nearest = knn(samples, min(max(SURFACE_NEIGHBOURS, RIM_NEIGHBOURS), len(samples)), tree)
        idx = nearest[:, :SURFACE_NEIGHBOURS]
        normals, _, _ = pca_features(samples, idx.shape[1], collapsed=collapsed, neighbours=idx)
        edges = tangent_edges(samples, np.nan_to_num(normals), idx)  # the surface edges every step below reads
        viewed = facing_viewer(samples, normals, edges, nearest)
        if viewed is not None:  # no part of a view faces away from its viewer: nothing for the open space to turn
            return dataclasses.replace(cls.from_samples(samples, viewed, band, tree, distances[:, 1]), single_view=True)
        return cls.from_samples(samples, orient_outward(samples, normals, idx, edges), band, tree, distances[:, 1],
                                edges)

    def with_band(self, band: float) -> "InsideTest":
        """The same surface (samples, oriented normals, tree) tested with another band. The grid is made again
        only when the band sizes its cells (a band wider than twice the samples' spacing); else it is this one's
        as made (the cells points have resolved since made undecided again, so both tests answer alike)."""
        if _cell_size(np.ptp(self.samples, axis=0), self.spacing, band) != self.size:
            return InsideTest.from_samples(self.samples, self.normals, band, self.tree, self.spacing)
        cells = self.cells.copy()  # another thread may be resolving this test's undecided cells meanwhile
        cells[self.undecided] = SPLIT
        return dataclasses.replace(self, cells=cells, band=band)

    def cell_of(self, points: np.ndarray) -> np.ndarray:
        """(..., 3) the grid index of the cell holding each of `points` (..., 3), those off the grid clipped to it."""
        index = np.floor((points - self.origin) / self.size).astype(np.int64)
        return np.clip(index, 0, np.array(self.cells.shape) - 1)

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Boolean mask: inside the surface, or within `band` of it."""
        index = np.floor((points - self.origin) / self.size).astype(np.int64)
        on_grid = ((index >= 0) & (index < self.cells.shape)).all(axis=1)
        verdict = np.zeros(len(points), np.int8)
        verdict[on_grid] = self.cells[tuple(index[on_grid].T)]
        split = np.flatnonzero(verdict == SPLIT)
        if len(split):  # their cells judged by their centres, and remembered
            cell, back = np.unique(np.ravel_multi_index(tuple(index[split].T), self.cells.shape), return_inverse=True)
            centres = self.origin + (np.column_stack(np.unravel_index(cell, self.cells.shape)) + 0.5) * self.size
            sides = (self.side_of(centres) <= 0).astype(np.int8)
            np.put(self.cells, cell, sides)
            verdict[split] = sides[back.ravel()]
        near = verdict < 0
        verdict[near] = self.side_of(points[near]) <= self.band
        return verdict.astype(bool)

    def side_of(self, points: np.ndarray) -> np.ndarray:
        """Signed offset along the nearest sample's outward normal (eq.: (p - s) . n_s)."""
        _, nearest = self.tree.query(points, k=1, workers=-1)
        return np.einsum("ij,ij->i", points - self.samples[nearest], self.normals[nearest])


def _cell_size(extent: np.ndarray, spacing: np.ndarray, band: float) -> float:
    """The grid's cell edge for samples spanning `extent` (3,) at `spacing` (each one's distance to its nearest).
    Cells at least twice the sample spacing keep the dilated shell closed; at most 256 per axis and about
    MAX_CELLS in all (a small piece far from the rest would otherwise span 17M mostly empty cells)."""
    return max(band, 2.0 * float(np.quantile(spacing, 0.9)), float(extent.max()) / 256,
               (float(np.prod(extent + 1e-12 * extent.max())) / MAX_CELLS) ** (1 / 3), 1e-12)


def mesh_surface(vertices: np.ndarray, faces, spacing: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Dense surface samples with outward face normals (winding repaired), spaced about `spacing`/2."""
    import trimesh

    faces = np.asarray(faces)
    if faces.ndim != 2 or faces.shape[1] != 3 or not np.issubdtype(faces.dtype, np.integer):
        raise InputError(f"faces: need an (m,3) integer array, got shape {faces.shape}")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise InputError(f"faces: indices must lie in [0, {len(vertices)})")
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    mesh.update_faces(mesh.nondegenerate_faces())
    if not len(mesh.faces):
        raise InputError("faces: every face is degenerate")
    _wind_consistently(mesh)
    _turn_bodies_outward(mesh)
    count = int(np.clip(4.0 * mesh.area / spacing ** 2, 10_000, 200_000))
    samples, face_index = trimesh.sample.sample_surface(mesh, count, seed=seed)
    return (np.concatenate([np.asarray(samples), mesh.vertices]),
            np.concatenate([mesh.face_normals[face_index], mesh.vertex_normals]))


def _wind_consistently(mesh) -> None:
    """Make each connected body's winding consistent with its lowest face's, along a spanning forest of the faces
    (two faces sharing an edge agree when they run along it in opposite directions; the forest takes agreeing
    pairs where it can): a face's flip is the parity of the disagreements on its path, read off the connected
    components of the forest's two-sheeted cover (face f as f and f + m; an agreeing pair joins the sheets
    straight, a disagreeing pair across). On a body that can be wound consistently that is its one consistent
    winding; on one that cannot (a Moebius band, a scan's crossed patches) only edges off the forest disagree, as
    with trimesh.repair.fix_winding's breadth-first walk, which goes face by face in Python and held the GIL for
    4 s on a 49k-face scan while the contraction waited for it."""
    import trimesh

    faces, m = mesh.faces, len(mesh.faces)
    # edges of exactly two faces, as trimesh's face_adjacency takes them (mesh.edges: each face's three, directed)
    first, second = trimesh.grouping.group_rows(mesh.edges_sorted, require_count=2).reshape(-1, 2).T
    agree = mesh.edges[first, 0] == mesh.edges[second, 1]  # u -> v in one face, v -> u in the other
    low, high = np.sort(mesh.edges_face[np.stack([first, second], axis=1)], axis=1).T
    _, once = np.unique(low * m + high, return_index=True)  # faces sharing two edges: one pair (a sum would blur it)
    forest = minimum_spanning_tree(sp.coo_matrix((2.0 - agree[once], (low[once], high[once])), shape=(m, m))).tocoo()
    a, b, agree = forest.row, forest.col, forest.data == 1.0
    body = connected_components(forest, directed=False)[1]
    cover = sp.coo_matrix((np.ones(2 * len(a)), (np.r_[a, a + m], np.r_[np.where(agree, b, b + m),
                                                                        np.where(agree, b + m, b)])), shape=(2 * m,) * 2)
    sheet = connected_components(cover, directed=False)[1]
    root = np.full(body.max() + 1, m)
    np.minimum.at(root, body, np.arange(m))
    flip = sheet[m:] == sheet[root[body]]
    if flip.any():
        mesh.faces = np.where(flip[:, None], faces[:, ::-1], faces)


def _turn_bodies_outward(mesh) -> None:
    """Flip the winding of each connected body whose faces point inward. A consistent winding (_wind_consistently)
    settles no direction; by the divergence theorem the flux of x - c through a closed
    surface with outward normals is three times its volume, so an outward body's sum of area * n.(x - c) is
    positive (c: the body's area-weighted centroid), and it stays so for a body with a few holes."""
    import trimesh

    body = trimesh.graph.connected_component_labels(mesh.face_adjacency, node_count=len(mesh.faces))
    area, centre = mesh.area_faces, mesh.triangles_center
    weight = np.bincount(body, area)
    centroid = np.stack([np.bincount(body, area * centre[:, axis]) for axis in range(3)], axis=1)
    centroid /= np.maximum(weight, 1e-300)[:, None]
    flux = np.bincount(body, area * np.einsum("ij,ij->i", mesh.face_normals, centre - centroid[body]))
    inward = flux[body] < 0
    if inward.any():
        mesh.faces = np.where(inward[:, None], mesh.faces[:, ::-1], mesh.faces)
