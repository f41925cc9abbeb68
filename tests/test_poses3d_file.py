"""poses_3d.csv: write, read back, and clear errors."""

import numpy as np
import pytest

from gymtrack.errors import InputError
from gymtrack.formats.poses3d import POSES_3D_COLUMNS, read_poses_3d, write_poses_3d
from gymtrack.poses import HOW_FUSED, HOW_PLANE, HOW_TRIANGULATED, Poses3D
from gymtrack.skeletons import BODY25, COCO17, custom_skeleton


def _poses(skeleton=COCO17):
    J = len(skeleton.joints)
    rng = np.random.default_rng(1)
    xyz = rng.normal(size=(3, J, 3))
    xyz[0, J - 1] = np.nan  # a joint not estimated: no line
    how = np.full((3, J), HOW_TRIANGULATED, np.int8)
    how[1, :3] = HOW_PLANE
    how[2, J - 1] = HOW_FUSED
    nv = np.full((3, J), 2)
    rp = np.full((3, J), 1.5)
    rp[1, :3] = np.nan  # plane only: no reprojection over views
    return Poses3D([5, 5, 6], [2, 1, 2], xyz, np.full((3, J), 0.8), nv, rp, how, skeleton)


def test_round_trip(tmp_path):
    p = _poses()
    path = write_poses_3d(tmp_path / "poses_3d.csv", p)
    lines = path.read_text().splitlines()
    assert lines[0] == ",".join(POSES_3D_COLUMNS)
    assert len(lines) == 1 + 3 * 17 - 1
    q = read_poses_3d(path)
    assert q.skeleton == COCO17
    s = p.sorted()
    assert q.frame.tolist() == [5, 5, 6] and q.track_id.tolist() == [1, 2, 2]
    assert np.allclose(q.xyz, s.xyz, atol=6e-5, equal_nan=True)
    est = np.isfinite(s.xyz[..., 0])
    assert np.array_equal(np.isfinite(q.xyz[..., 0]), est)
    assert np.array_equal(q.how[est], s.how[est])
    assert np.allclose(q.reproj_px[est], s.reproj_px[est], equal_nan=True)
    assert (q.n_views[np.isfinite(q.xyz[..., 0])] == 2).all()


def test_skeleton_guessed_from_names(tmp_path):
    write_poses_3d(tmp_path / "a.csv", _poses(BODY25))
    assert read_poses_3d(tmp_path / "a.csv").skeleton == BODY25
    sk = custom_skeleton(["head", "tail"])
    write_poses_3d(tmp_path / "b.csv", _poses(sk))
    assert read_poses_3d(tmp_path / "b.csv").skeleton.joints == ("head", "tail")


def test_without_how_column(tmp_path):
    f = tmp_path / "p.csv"
    f.write_text("frame,track_id,joint,x,y,z,score,n_views,reproj_px\n1,0,nose,1,2,3,0.5,2,\n")
    q = read_poses_3d(f)
    assert q.xyz[0, 0].tolist() == [1, 2, 3] and q.how[0, 0] == 0 and np.isnan(q.reproj_px[0, 0])


@pytest.mark.parametrize("body, where, what", [
    ("1,0,nose,1,2,3,0.5,2,1.0,triangulated\n1,0,nose,1,2,3,0.5,2,1.0,triangulated\n", "line 3", "twice"),
    ("1,0,nose,1,x,3,0.5,2,1.0,triangulated\n", "line 2", "y must be a number"),
    ("1,0,nose,1,2,3,0.5,2,1.0,guessed\n", "line 2", "how must be one of"),
    ("1.5,0,nose,1,2,3,0.5,2,1.0,plane\n", "line 2", "frame must be a whole number"),
    ("1,0,nose,1,2,3,0.5,2\n", "line 2", "expected 10 values"),
])
def test_errors_name_the_line(tmp_path, body, where, what):
    f = tmp_path / "p.csv"
    f.write_text(",".join(POSES_3D_COLUMNS) + "\n" + body)
    with pytest.raises(InputError) as e:
        read_poses_3d(f)
    assert where in str(e.value) and what in str(e.value) and "p.csv" in str(e.value)


def test_unknown_joint_for_a_given_skeleton(tmp_path):
    f = tmp_path / "p.csv"
    f.write_text(",".join(POSES_3D_COLUMNS) + "\n1,0,tail,1,2,3,0.5,2,1.0,plane\n")
    with pytest.raises(InputError, match="joint 'tail' is not in the coco17"):
        read_poses_3d(f, skeleton=COCO17)
