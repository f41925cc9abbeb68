"""Skeletons (flip, bones, index) and the Poses2D / Poses3D columnar types."""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.errors import InputError
from gymtrack.poses import HOW_NAMES, HOW_PLANE, Poses2D, Poses3D
from gymtrack.skeletons import BODY25, COCO17, HALPE26, custom_skeleton, get_skeleton

ALL = (COCO17, BODY25, HALPE26)


@pytest.mark.parametrize("sk", ALL, ids=lambda s: s.name)
def test_flip_is_an_involution_mapping_left_to_right(sk):
    J = len(sk.joints)
    assert sk.flip.dtype == np.int64 and sk.flip.shape == (J,)
    assert np.array_equal(sk.flip[sk.flip], np.arange(J))
    for i, name in enumerate(sk.joints):
        mirror = sk.joints[sk.flip[i]]
        if name.startswith("left_"):
            assert mirror == "right_" + name[5:]
        elif name.startswith("right_"):
            assert mirror == "left_" + name[6:]
        else:
            assert mirror == name


@pytest.mark.parametrize("sk", ALL, ids=lambda s: s.name)
def test_bones_are_valid_distinct_and_mirror_symmetric(sk):
    J = len(sk.joints)
    b = sk.bones
    assert b.dtype == np.int64 and b.ndim == 2 and b.shape[1] == 2 and len(b) >= 12
    assert b.min() >= 0 and b.max() < J and np.all(b[:, 0] != b[:, 1])
    pairs = {frozenset(p) for p in b.tolist()}
    assert len(pairs) == len(b)
    assert {frozenset(sk.flip[list(p)].tolist()) for p in pairs} == pairs
    # every limb of the four
    idx = sk.index(["left_shoulder", "left_elbow", "right_knee", "right_ankle"])
    assert frozenset(idx[:2].tolist()) in pairs and frozenset(idx[2:].tolist()) in pairs
    # a skeleton is connected through its bones (no joint left out of the graph)
    seen, todo = {0}, [0]
    while todo:
        j = todo.pop()
        for a, c in b.tolist():
            for x, y in ((a, c), (c, a)):
                if x == j and y not in seen:
                    seen.add(y)
                    todo.append(y)
    assert seen == set(range(J))


def test_joint_orders_match_formats_md():
    assert COCO17.joints[:3] == ("nose", "left_eye", "right_eye") and len(COCO17.joints) == 17
    assert BODY25.joints[1] == "neck" and BODY25.joints[8] == "mid_hip" and BODY25.joints[24] == "right_heel"
    assert len(BODY25.joints) == 25 and len(HALPE26.joints) == 26
    assert HALPE26.joints[:17] == COCO17.joints and HALPE26.joints[17:20] == ("head", "neck", "hip")


def test_index_and_lookup():
    assert COCO17.index(["right_ankle", "neck", "nose"]).tolist() == [16, -1, 0]
    assert COCO17.index([]).shape == (0,)
    assert get_skeleton("body25") is BODY25
    with pytest.raises(InputError, match="unknown skeleton 'coco19'"):
        get_skeleton("coco19")
    sk = custom_skeleton(["head", "neck", "left_wrist", "right_wrist", "left_elbow"])
    assert sk.name == "custom" and sk.flip.tolist() == [0, 1, 3, 2, 4]
    assert {tuple(sorted(p)) for p in sk.bones.tolist()} == {(0, 1), (2, 4)}
    assert sk == custom_skeleton(list(sk.joints)) and sk != COCO17 and hash(sk) == hash(custom_skeleton(sk.joints))
    for bad in ([], ["a", "a"], ["a", 3], "abc"):
        with pytest.raises(InputError, match="joints"):
            custom_skeleton(bad)


def _poses2d(rng, n, sk=COCO17, cams=("a", "b", "c")):
    J = len(sk.joints)
    kp = rng.uniform(0, 1000, (n, J, 3))
    return Poses2D(rng.integers(0, 5, n), rng.integers(0, len(cams), n), rng.integers(-1, 3, n), kp,
                   rng.uniform(0, 500, (n, 4)), sk, cams)


def test_poses2d_subset_concat_sorted_round_trip():
    rng = np.random.default_rng(0)
    p = _poses2d(rng, 20)
    assert len(p) == 20 and p.camera.dtype == np.int64
    q = Poses2D.concat([p.subset(slice(0, 7)), p.subset(slice(7, 20))])
    for c in ("frame", "camera", "track_id", "keypoints", "bbox"):
        assert np.array_equal(getattr(q, c), getattr(p, c))
    s = p.sorted()
    key = s.frame * 10 + s.camera
    assert np.all(np.diff(key) >= 0)
    # sorting is a permutation: every row is still there once
    order = np.lexsort((p.camera, p.frame))
    assert np.array_equal(s.keypoints, p.keypoints[order])
    mask = p.track_id >= 0
    assert len(p.subset(mask)) == mask.sum()
    e = Poses2D.empty(COCO17, ("a", "b", "c"))
    assert len(e) == 0 and e.keypoints.shape == (0, 17, 3)
    assert len(Poses2D.concat([e, p, e])) == 20
    with pytest.raises(ValueError, match="concat"):
        Poses2D.concat([p, Poses2D.empty(BODY25, ("a", "b", "c"))])
    with pytest.raises(ValueError, match="keypoints"):
        Poses2D(p.frame, p.camera, p.track_id, p.keypoints[:, :5], p.bbox, COCO17, p.camera_names)


def test_poses2d_found():
    p = _poses2d(np.random.default_rng(1), 2)
    p.keypoints[0, 3, 2] = 0
    p.keypoints[1, 4, 0] = np.nan
    f = p.found()
    assert f.sum() == 2 * 17 - 2 and not f[0, 3] and not f[1, 4]


def test_poses3d_subset_concat_sorted_round_trip():
    rng = np.random.default_rng(2)
    M, J = 12, len(BODY25.joints)
    p = Poses3D(rng.integers(0, 4, M), rng.integers(0, 3, M), rng.normal(size=(M, J, 3)), rng.uniform(size=(M, J)),
                rng.integers(0, 4, (M, J)), rng.uniform(0, 5, (M, J)), rng.integers(0, 4, (M, J)), BODY25)
    assert p.how.dtype == np.int8 and HOW_NAMES[HOW_PLANE] == "plane" and Poses3D.HOW_NAMES == HOW_NAMES
    q = Poses3D.concat([p.subset(np.arange(5)), p.subset(np.arange(5, M))])
    for c in ("frame", "track_id", "xyz", "score", "n_views", "reproj_px", "how"):
        assert np.array_equal(getattr(q, c), getattr(p, c))
    s = p.sorted()
    assert np.all(np.diff(s.frame * 10 + s.track_id) >= 0)
    assert len(Poses3D.concat([Poses3D.empty(BODY25), p])) == M
    with pytest.raises(ValueError, match="score"):
        Poses3D(p.frame, p.track_id, p.xyz, p.score[:, :3], p.n_views, p.reproj_px, p.how, BODY25)
