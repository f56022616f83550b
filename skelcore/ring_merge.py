"""GLSkeleton's merged rings (Wen et al., RA-L 2024; the authors' MATLAB, weiqimeng1/GLSkeleton, Source/
Ring_combination.m and update_rings_after_manipulation.m), for the points skelcore.glskeleton's merge rule lets
absorb their nearest ring neighbour.

The absorber's new ring is ring(i) U ring(j) minus i and j, at the INPUT positions, projected on the plane normal
to G_i (the PCA plane of the candidates when G_i vanishes), the 2-D Delaunay fan of i. A fan with fewer than 3
triangles cancels the merge (MATLAB: a ring list of <= 3 entries; here its two points wait for the next step
instead of pairing with others). Every other ring renames j to i and drops the triangles that degenerate. A point
takes part in at most one merge per step (`greedy_matching`).
"""
from __future__ import annotations

import numpy as np

from .neighbours import OneRings, delaunay_fans, plane_basis

MIN_FAN_TRIANGLES = 3  # Ring_combination.m: more than 3 ring entries (a closed fan repeats its first one)
FAN_GROUP = 10  # merged rings up to this many candidates are triangulated apart from the longer ones


def greedy_matching(source: np.ndarray, target: np.ndarray, priority: np.ndarray, n: int) -> np.ndarray:
    """Greedy matching: take the pairs (source, target) by increasing priority, skipping any pair that touches
    a point already taken. Done in rounds: a pair is taken once it has the lowest priority of the pairs left
    at both its ends. Returns the mask of pairs taken."""
    taken = np.zeros(len(source), dtype=bool)
    left = np.arange(len(source))
    while len(left):
        lowest = np.full(n, np.iinfo(np.int64).max)
        np.minimum.at(lowest, source[left], priority[left])
        np.minimum.at(lowest, target[left], priority[left])
        wins = left[(lowest[source[left]] == priority[left]) & (lowest[target[left]] == priority[left])]
        taken[wins] = True
        used = np.zeros(n, dtype=bool)
        used[source[wins]] = used[target[wins]] = True
        left = left[~(used[source[left]] | used[target[left]])]
    return taken


def merge_rings(rings: OneRings, absorbers: np.ndarray, absorbed: np.ndarray, gamma: np.ndarray,
                origin: np.ndarray) -> tuple[OneRings, np.ndarray, np.ndarray] | None:
    """Merge each absorbed point into its absorber: the absorber's ring becomes the Delaunay fan of both rings
    (module docstring), the other rings rename the absorbed point. `origin`: the input positions of the
    present points. Returns the new rings, the mask of points kept and the new row of every old row; None when
    no merge is valid."""
    if not len(absorbers):
        return None
    n = rings.n_points
    ids, valid = _merged_candidates(rings, absorbers, absorbed)
    enough = np.flatnonzero(valid.sum(axis=1) >= 3)
    if not len(enough):
        return None
    ids, valid = ids[enough], valid[enough]

    offsets = origin[ids] - origin[absorbers[enough]][:, None, :]
    u, v = plane_basis(_fan_normals(gamma[absorbers[enough]], offsets, valid))
    planar = np.stack([np.einsum("pwc,pc->pw", offsets, u), np.einsum("pwc,pc->pw", offsets, v)], axis=-1)
    ring_row, ring_slot, tri_row, tri_j, tri_l = _fans_by_length(planar, valid)
    good = np.bincount(tri_row, minlength=len(enough)) >= MIN_FAN_TRIANGLES
    if not good.any():
        return None
    entries, triangles = good[ring_row], good[tri_row]
    fan_centre, fan_id = absorbers[enough][ring_row[entries]], ids[ring_row[entries], ring_slot[entries]]
    tri_row, tri_j, tri_l = tri_row[triangles], tri_j[triangles], tri_l[triangles]
    fan_triangles = np.column_stack([absorbers[enough][tri_row], ids[tri_row, tri_j], ids[tri_row, tri_l]])
    absorbers, absorbed = absorbers[enough][good], absorbed[enough][good]

    keep = np.ones(n, dtype=bool)
    keep[absorbed] = False
    target = np.arange(n)
    target[absorbed] = absorbers
    new_row = (np.cumsum(keep) - 1)[target]
    changed = np.zeros(n, dtype=bool)
    changed[absorbers] = changed[absorbed] = True

    triangles = new_row[np.concatenate([rings.triangles[~changed[rings.triangles[:, 0]]], fan_triangles])]
    i, j, l = triangles.T
    triangles = triangles[(i != j) & (j != l) & (l != i)]  # collapsed onto the absorber

    centres = rings.centres()
    old = ~changed[centres]
    centre = new_row[np.concatenate([centres[old], fan_centre])]
    neighbour = new_row[np.concatenate([rings.indices[old], fan_id])]
    order = np.argsort(centre, kind="stable")
    centre, neighbour = centre[order], neighbour[order]
    m = int(keep.sum())
    key = centre * m + neighbour
    by_key = np.argsort(key, kind="stable")
    repeat = np.zeros(len(key), dtype=bool)  # drop repeats, keep the first in fan order
    repeat[by_key[1:]] = key[by_key[1:]] == key[by_key[:-1]]
    centre, neighbour = centre[~repeat], neighbour[~repeat]
    indptr = np.concatenate([[0], np.cumsum(np.bincount(centre, minlength=m))])
    return OneRings(indptr=indptr, indices=neighbour, triangles=triangles), keep, new_row


def _merged_candidates(rings: OneRings, absorbers: np.ndarray, absorbed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per pair, ring(i) U ring(j) minus i and j in increasing order, packed left (ids (pairs, w), 0 where not
    valid; w the longest union). Sorting each short row twice (repeats and i, j pushed to the end in between)
    costs a quarter of one np.unique over all the pairs' keys."""
    n, pairs = rings.n_points, len(absorbers)
    counts = np.diff(rings.indptr)
    first = counts[absorbers]
    which, entry = _ranges(np.concatenate([rings.indptr[absorbers], rings.indptr[absorbed]]),
                           np.concatenate([first, counts[absorbed]]))
    column = entry - rings.indptr[np.concatenate([absorbers, absorbed])][which]
    second = which >= pairs
    which[second] -= pairs
    column[second] += first[which[second]]
    union = np.full((pairs, int((first + counts[absorbed]).max())), n, dtype=np.int64)  # n: no candidate
    union[which, column] = rings.indices[entry]
    union[(union == absorbers[:, None]) | (union == absorbed[:, None])] = n
    union.sort(axis=1)
    union[:, 1:][union[:, 1:] == union[:, :-1]] = n
    union.sort(axis=1)
    valid = union < n
    width = int(valid.sum(axis=1).max())
    ids, valid = union[:, :width], valid[:, :width]
    ids[~valid] = 0
    return ids, valid


def _fans_by_length(planar: np.ndarray, valid: np.ndarray):
    """delaunay_fans of rows of different lengths (valid entries packed left), each group of rows trimmed to its
    longest: a fan does not depend on its row's padding, and a few long unions no longer widen every row."""
    lengths = valid.sum(axis=1)
    groups = [rows for rows in (np.flatnonzero(lengths <= FAN_GROUP), np.flatnonzero(lengths > FAN_GROUP))
              if len(rows)]
    parts = [delaunay_fans(planar[rows, :lengths[rows].max()], valid[rows, :lengths[rows].max()]) for rows in groups]
    ring_row = np.concatenate([rows[part[0]] for rows, part in zip(groups, parts)])
    tri_row = np.concatenate([rows[part[2]] for rows, part in zip(groups, parts)])
    ring_order, tri_order = np.argsort(ring_row, kind="stable"), np.argsort(tri_row, kind="stable")
    ring_slot, tri_j, tri_l = (np.concatenate([part[index] for part in parts]) for index in (1, 3, 4))
    return (ring_row[ring_order], ring_slot[ring_order], tri_row[tri_order], tri_j[tri_order],
            tri_l[tri_order])


def _fan_normals(gamma: np.ndarray, offsets: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Unit normals of the merged rings' planes: G_i, or the PCA normal of the candidates and the centre
    where G_i vanishes (Ring_combination.m)."""
    length = np.linalg.norm(gamma, axis=1)
    normals = gamma / np.maximum(length, 1e-300)[:, None]
    flat = np.flatnonzero(length < 1e-12)
    if len(flat):
        weight = valid[flat][..., None]
        mean = (offsets[flat] * weight).sum(axis=1) / (weight.sum(axis=1) + 1)
        centred = (offsets[flat] - mean[:, None]) * weight
        covariance = np.einsum("pwa,pwb->pab", centred, centred) + np.einsum("pa,pb->pab", mean, mean)
        normals[flat] = np.linalg.eigh(covariance)[1][:, :, 0]
    return normals


def _ranges(starts: np.ndarray, counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For ranges [start, start + count): the range of every position, and the positions."""
    which = np.repeat(np.arange(len(starts)), counts)
    offsets = np.arange(len(which)) - np.repeat(np.cumsum(counts) - counts, counts)
    return which, starts[which] + offsets
